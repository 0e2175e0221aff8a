"""Newton 1.8's MuJoCo solver (.venv-engines, scripts/setup_engines.sh), every test's runs
in one Newton process: importing it and compiling its kernels is most of a run's cost
(real files, the real engine; `real2code simulate`'s plumbing is tested with the engines of
test_dynamics.py and test_simulate_contacts.py)."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.procedural import generate
from real2code_export.dynamics import EngineUnavailable, mujoco, newton
from real2code_export.dynamics.contacts import CONTACT_EXPERIMENTS
from real2code_export.dynamics.experiments import EXPERIMENTS
from real2code_export.dynamics.run import compare
from real2code_export.formats import write_formats

from helpers import laptop_with_laws

KINDS = ["usd", "mjcf", "urdf"]


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory):
    """(experiment, file kind) -> (experiment, Newton's trajectory, MuJoCo's from the MJCF,
    the contact experiment's judge or None): the laptop thrown into its limit and generated
    storage furniture's box dropped into its drawer, from each file; its doors thrown shut,
    from the USD."""
    folder = tmp_path_factory.mktemp("newton")
    furniture = generate("storage_furniture", seed=1)
    variants = {"limit": (*EXPERIMENTS["limit"](laptop_with_laws()), None)}
    for name in ("drop", "shut"):
        variant, experiment, judge, _ = CONTACT_EXPERIMENTS[name](furniture)
        variants[name] = (variant, experiment, judge)
    files, references = {}, {}
    for name, (variant, experiment, _) in variants.items():
        files[name] = write_formats(variant, folder / name, ["mjcf", *KINDS])
        references[name] = mujoco.simulate(files[name]["mjcf"], experiment)
    planned = [(name, kind) for name in ("limit", "drop") for kind in KINDS] + [("shut", "usd")]
    try:
        runs = newton.simulate_many([(files[name][kind], variants[name][1])
                                     for name, kind in planned])
    except EngineUnavailable as e:
        pytest.skip(str(e))
    out = {}
    for (name, kind), (trajectory, _) in zip(planned, runs, strict=True):
        assert not isinstance(trajectory, Exception), (name, kind, trajectory)
        _, experiment, judge = variants[name]
        out[name, kind] = (experiment, trajectory, references[name], judge)
    return out


@pytest.mark.parametrize("kind", KINDS)
def test_newton_agrees_at_a_limit(outcomes, kind):
    """Newton reads our MJCF's and USD's limit softness (the URDF's is set as MuJoCo's is),
    and its USD limits are not shifted by mjc:ref: a joint thrown into its limit stops as in
    MuJoCo, not on Newton's default spring."""
    experiment, trajectory, reference, _ = outcomes["limit", kind]
    _, angle, _ = compare(experiment, reference, trajectory)
    assert angle < 1e-3, angle


@pytest.mark.parametrize("name", ["drop", "shut"])
def test_newton_keeps_the_box_and_stops_the_doors(outcomes, name):
    """From the USD, its importer's filters lifted: every box stays in its drawer, every
    door stops at its frame."""
    _, trajectory, _, judge = outcomes[name, "usd"]
    verdict = judge(trajectory)
    assert verdict.ok, verdict.message


@pytest.mark.parametrize("kind", KINDS)
def test_newton_rests_the_box_as_deep_as_mujoco(outcomes, kind):
    """With one contact point per pair of convex pieces (Newton's default) the box rests
    5 mm deep in the drawer; with MuJoCo's several, which our MJCF and USD ask for and a
    URDF's run is told, as MuJoCo does: within 1 mm, from each file."""
    _, trajectory, reference, _ = outcomes["drop", kind]
    assert np.abs(trajectory.boxes[-1] - reference.boxes[-1]).max() < 1e-3
