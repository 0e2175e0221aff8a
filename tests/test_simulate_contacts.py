"""The contact experiments of `real2code simulate`: a box dropped into every open drawer stays
in it, every door thrown shut stops at its frame (real files, real engines)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pipeline.procedural import generate
from real2code_export.cli import run
from real2code_export.dynamics import Trajectory
from real2code_export.dynamics.contacts import BOX_SIZE, CONTACT_EXPERIMENTS, closed_end
from real2code_export.dynamics.run import simulate_file
from real2code_export.formats import object_json, write_formats
from real2code_export.model import JointType


@pytest.fixture(scope="module")
def furniture(tmp_path_factory):
    """Generated storage furniture: drawers and doors on one carcass."""
    obj = generate("storage_furniture", seed=1)
    assert any(j.type is JointType.PRISMATIC for j in obj.movable_joints)
    return obj, object_json.save(obj, tmp_path_factory.mktemp("furniture"))


def test_drop_finds_a_floor_inside_every_open_drawer(furniture):
    obj, _ = furniture
    variant, experiment, _, notes = CONTACT_EXPERIMENTS["drop"](obj)
    drawers = [j for j in obj.movable_joints if j.type is JointType.PRISMATIC]
    assert len(experiment.boxes) + len(notes) == len(drawers)
    # only the drawers move; the doors are held open
    assert set(experiment.joints) == {j.name for j in drawers}
    for centre in experiment.boxes:  # released above the object's floor, below its top
        assert 0 < centre[2] - BOX_SIZE / 2 < max(m.vertices[:, 2].max()
                                                  for p in obj.parts for m in p.collision)


def test_mujoco_keeps_the_box_and_stops_the_doors(furniture, tmp_path):
    _, path = furniture
    out = tmp_path / "report.json"
    assert run(["simulate", str(path), "--engines", "mujoco-urdf", "--experiments",
                "drop,shut", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    runs = {(r["experiment"], r["engine"]): r for r in data["runs"]}
    assert set(runs) == {(e, f"MuJoCo ({f})") for e in ("drop", "shut") for f in ("MJCF", "URDF")}
    assert all(r["status"] == "ok" for r in runs.values())
    assert "at rest in their drawers" in runs[("drop", "MuJoCo (MJCF)")]["message"]
    # the boxes are part of the experiment as written to --json
    assert next(e for e in data["experiments"] if e["name"] == "drop")["boxes"]


def test_a_door_sunk_into_its_frame_does_not_shut(tmp_path):
    """The box's lid with its pieces moved 2 cm into the base meets the base before it is
    closed: the check fails (exit status 1) and names the joint."""
    obj = generate("box", seed=1)
    lid = next(p for p in obj.parts if p is not obj.root)
    joint = next(j for j in obj.joints if j.child == lid.name)
    down = np.linalg.inv(joint.origin[:3, :3]) @ np.array([0.0, 0.0, -0.02])
    lid.collision = [m.transformed(np.block([[np.eye(3), down[:, None]], [0, 0, 0, 1]]))
                     for m in lid.collision]
    path = object_json.save(obj, tmp_path / "sunk")
    report = simulate_file(path, ["mujoco"], ["shut"])
    (r,) = report.runs
    assert r.status == "disagree" and joint.name in r.message and "before" in r.message
    assert run(["simulate", str(path), "--engines", "mujoco", "--experiments", "shut"]) == 1


def test_the_judges_see_a_box_thrown_out_and_a_door_through_its_frame(furniture):
    obj, _ = furniture
    _, drop, judge, _ = CONTACT_EXPERIMENTS["drop"](obj)
    times = np.array([0.0, 2.0])
    q = np.tile(np.array(drop.q0), (2, 1))
    boxes = np.array([drop.boxes, drop.boxes])
    boxes[1, :, 2] -= 0.02 + 0.0005  # landed: 2 cm down, 0.5 mm into the floor
    assert judge(Trajectory(list(drop.joints), times, q, boxes=boxes)).ok
    boxes[1, 0, 0] += 1.0  # a metre away
    verdict = judge(Trajectory(list(drop.joints), times, q, boxes=boxes))
    assert not verdict.ok and verdict.distance > 0.5
    _, shut, judge, _ = CONTACT_EXPERIMENTS["shut"](obj)
    door = next(i for i, v in enumerate(shut.v0) if v)
    closed = closed_end(obj.joint(shut.joints[door]))
    q = np.tile(np.array(shut.q0), (2, 1))
    q[1] = [closed_end(obj.joint(n)) for n in shut.joints]
    assert judge(Trajectory(list(shut.joints), times, q)).ok
    q[1, door] = closed + 0.3 * np.sign(shut.v0[door])  # through its frame
    verdict = judge(Trajectory(list(shut.joints), times, q))
    assert not verdict.ok and verdict.angle == pytest.approx(0.3)


def test_physx_keeps_the_box_and_stops_the_doors(furniture):
    """PhysX from the USD (its gravity and collision filters set in a layer over the file):
    ~10 s here (Newton and Genesis: test_newton.py and test_genesis.py, each in the process
    its other tests share)."""
    _, path = furniture
    report = simulate_file(path, ["physx"], ["drop", "shut"])
    runs = [r for r in report.runs if r.engine != "MuJoCo (MJCF)"]
    if any(r.status == "skipped" for r in runs):
        pytest.skip(runs[0].message)
    assert [r.status for r in runs] == ["ok", "ok"], [r.message for r in runs]


def test_the_files_ask_for_several_contact_points_per_pair(furniture, tmp_path):
    """MuJoCo's default, written out for Newton, which turns it off unless told."""
    import mujoco
    from pxr import Usd

    files = write_formats(furniture[0], tmp_path, ["mjcf", "usd"])
    spec = mujoco.MjSpec.from_file(str(files["mjcf"]))
    assert not spec.option.disableflags & int(mujoco.mjtDisableBit.mjDSBL_MULTICCD)
    assert '<flag multiccd="enable"/>' in files["mjcf"].read_text()
    stage = Usd.Stage.Open(str(files["usd"]))
    assert stage.GetPrimAtPath("/PhysicsScene").GetAttribute("mjc:flag:multiccd").Get() is True
