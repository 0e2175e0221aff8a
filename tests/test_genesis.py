"""Genesis (.venv-genesis, scripts/setup_genesis.sh), every test's runs in one Genesis
process: importing it is ~18 s of CPU and its first scene's build ~8 s, most of a run's
cost (real files, the real engine; `real2code simulate`'s plumbing is tested with the
engines of test_dynamics.py and test_simulate_contacts.py)."""

from __future__ import annotations

import pytest

from pipeline.procedural import generate
from real2code_export.dynamics import EngineUnavailable, genesis, mujoco
from real2code_export.dynamics.contacts import CONTACT_EXPERIMENTS
from real2code_export.dynamics.experiments import EXPERIMENTS
from real2code_export.dynamics.run import TOL_ANGLE, compare
from real2code_export.formats import write_formats

from helpers import laptop_with_laws

MOTION = [(name, kind) for name in ("swing", "limit") for kind in ("mjcf", "urdf")]
CONTACTS = ["drop", "shut"]


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory):
    """(experiment, file kind) -> (experiment, trajectory, MuJoCo's from the MJCF or the
    contact experiment's judge): the laptop's motion from the MJCF and the URDF, generated
    storage furniture's contacts from the URDF (drawers and doors on one carcass)."""
    folder = tmp_path_factory.mktemp("genesis")
    laptop, furniture = laptop_with_laws(), generate("storage_furniture", seed=1)
    planned = {}
    for name in ("swing", "limit"):
        variant, experiment = EXPERIMENTS[name](laptop)
        files = write_formats(variant, folder / name, ["mjcf", "urdf"])
        reference = mujoco.simulate(files["mjcf"], experiment)
        for kind in ("mjcf", "urdf"):
            planned[name, kind] = (files[kind], experiment, reference)
    for name in CONTACTS:
        variant, experiment, judge, _ = CONTACT_EXPERIMENTS[name](furniture)
        planned[name, "urdf"] = (write_formats(variant, folder / name, ["urdf"])["urdf"],
                                 experiment, judge)
    try:
        runs = genesis.simulate_many([(path, e) for path, e, _ in planned.values()])
    except EngineUnavailable as e:
        pytest.skip(str(e))
    out = {}
    for key, (path, experiment, check), (trajectory, _) in zip(
            planned, planned.values(), runs, strict=True):
        assert not isinstance(trajectory, Exception), (key, path, trajectory)
        out[key] = (experiment, trajectory, check)
    return out


def test_genesis_agrees_with_mujoco(outcomes):
    """An armature of 0 kept 0, MuJoCo's Euler, the joint values of the step just taken:
    from the MJCF its free swing is MuJoCo's to 1e-9 (a one-step lag would be 1e-3); from
    the URDF, its laws, armature and limit softness set, it stops as MuJoCo."""
    worst = {}
    for key in MOTION:
        experiment, trajectory, reference = outcomes[key]
        _, worst[key], _ = compare(experiment, reference, trajectory)
    assert all(a < TOL_ANGLE for a in worst.values()), worst
    assert worst["swing", "mjcf"] < 1e-9
    assert worst["limit", "urdf"] < 1e-3


@pytest.mark.parametrize("name", CONTACTS)
def test_genesis_keeps_the_box_and_stops_the_doors(outcomes, name):
    """From the URDF, parent/child and touching pairs colliding (Genesis filters both unless
    told): every box stays in its drawer, every door stops at its frame."""
    _, trajectory, judge = outcomes[name, "urdf"]
    verdict = judge(trajectory)
    assert verdict.ok, verdict.message
