"""Import -> export keeps names, limits and dynamics (exactly) and everything else to float32
precision; what an artist edits in the rig is what gets exported."""

from __future__ import annotations

import numpy as np
import pytest
from test_export_check import export
from test_import_pose import import_rig, rig_objects

from conftest import CATEGORIES, addon_module, partnet_urdf


def load(path):
    from real2code_export.formats import load as load_any

    return load_any(path)


def same_names_limits_dynamics(a, b) -> None:
    assert a.name == b.name
    assert [p.name for p in a.parts] == [p.name for p in b.parts]
    assert sorted(j.name for j in a.joints) == sorted(j.name for j in b.joints)
    for ja in a.joints:
        jb = b.joint(ja.name)
        assert (ja.type, ja.parent, ja.child) == (jb.type, jb.parent, jb.child)
        assert ja.limits == jb.limits  # dataclass equality: exact floats
        assert ja.dynamics == jb.dynamics
        assert ja.state == jb.state


@pytest.mark.parametrize("category", list(CATEGORIES))
def test_object_json_roundtrip(blender, generated, tmp_path, category):
    from real2code_export.model import differences

    path = generated[category]["json"]
    original = load(path)
    root = import_rig(blender, path)
    read_back = addon_module("from_blender").read_rig(root, blender.context.evaluated_depsgraph_get())
    # meshes go through Blender's float32 vertices; all else is exact
    assert differences(original, read_back, tol=1e-6) == []
    assert export(blender, root, tmp_path, formats={"json"}, check=False) == {"FINISHED"}
    exported = load(tmp_path / "object.json")
    same_names_limits_dynamics(original, exported)
    assert differences(original, exported, tol=1e-6) == []
    for ja in original.joints:
        assert np.array_equal(ja.origin, exported.joint(ja.name).origin)
        assert np.array_equal(ja.axis, exported.joint(ja.name).axis)
    assert exported.metadata == original.metadata


@pytest.mark.partnet
def test_urdf_roundtrip_partnet(blender, tmp_path):
    path = partnet_urdf("45332")
    original = load(path)
    root = import_rig(blender, path)
    assert export(blender, root, tmp_path, formats={"urdf"}, check=False) == {"FINISHED"}
    exported = load(next(tmp_path.glob("*.urdf")))
    same_names_limits_dynamics(original, exported)


def test_artist_edits_are_exported(blender, generated, tmp_path):
    from real2code_export.model import forward_kinematics

    path = generated["storage_furniture"]["json"]
    original = load(path)
    root = import_rig(blender, path)
    rp = addon_module("rig_props")
    panel = addon_module("panel")
    joints = rig_objects(root, rp.ROLE_JOINT)
    parts = rig_objects(root, rp.ROLE_PART)
    hinge = next(j for j in original.joints if j.type.value == "revolute")
    slide = next(j for j in original.joints if j.type.value == "prismatic")

    je = joints[hinge.name]
    je[rp.UPPER] = 0.5  # a narrower range, and dynamics
    je[rp.dynamics_key("damping")] = 2.5
    je[rp.STATE] = 0.25
    je[rp.EFFORT] = 7.0
    je.location = (0.0, 0.01, 0.0)  # the hinge moved 1 cm along the joint frame's y
    joints[slide.name].name = "drawer_slide_renamed"
    parts[hinge.child].name = "left_door"
    body = parts[original.root.name]
    body.data.vertices[0].co.x += 0.05  # a mesh edit
    pieces = [c for c in parts[slide.child].children if c.get(rp.ROLE) == rp.ROLE_COLLISION]
    blender.data.objects.remove(pieces[-1])  # one collision piece fewer

    # the constraint follows the new range: the slider beyond it is held at 0.5
    panel.set_joint_value(je, 1.2)
    blender.context.view_layer.update()
    original.joint(hinge.name).limits.upper = 0.5
    clamped = forward_kinematics(original, {hinge.name: 0.5})[hinge.child]
    shown = np.array(parts[hinge.child].matrix_world, dtype=np.float64)
    # (the hinge also moved 1 cm: compare rotations only)
    assert np.allclose(shown[:3, :3], clamped[:3, :3], atol=1e-5)

    assert export(blender, root, tmp_path, formats={"json"}, check=False) == {"FINISHED"}
    out = load(tmp_path / "object.json")
    jh = out.joint(hinge.name)
    assert jh.limits.upper == 0.5 and jh.limits.lower == hinge.limits.lower
    assert jh.limits.effort == 7.0
    assert jh.dynamics.damping == 2.5 and jh.state == 0.25
    assert jh.child == "left_door" and "left_door" in [p.name for p in out.parts]
    moved = hinge.origin[:3, 3] + hinge.origin[:3, :3] @ (
        _alignment(hinge)[:3, :3] @ np.array([0.0, 0.01, 0.0]))
    assert np.allclose(jh.origin[:3, 3], moved, atol=1e-6)
    assert "drawer_slide_renamed" in [j.name for j in out.joints]
    assert len(out.part(slide.child).collision) == len(original.part(slide.child).collision) - 1
    body_out = out.part(original.root.name).visual
    assert abs(body_out.vertices[0, 0] - original.root.visual.vertices[0, 0] - 0.05) < 1e-6


def _alignment(joint):
    return addon_module("to_blender").joint_alignment(joint)


def test_changing_a_joint_kind_is_refused(blender, generated, tmp_path):
    root = import_rig(blender, generated["box"]["json"])
    rp = addon_module("rig_props")
    je = next(iter(rig_objects(root, rp.ROLE_JOINT).values()))
    je[rp.TYPE] = "prismatic"
    out = tmp_path / "out"
    with pytest.raises(RuntimeError, match="type changed from revolute to prismatic"):
        export(blender, root, out, check=False)
    assert not out.exists()


def test_a_continuous_joints_effort_and_velocity_round_trip(blender, generated, tmp_path):
    """A joint without a range keeps its effort and velocity (``drive_limits``) through the
    rig: imported as ID properties, exported back."""
    from real2code_export.formats import object_json
    from real2code_export.model import DriveLimits, JointType, differences

    obj = load(generated["laptop"]["json"])
    hinge = next(j for j in obj.joints if j.type is JointType.REVOLUTE)
    hinge.type, hinge.limits, hinge.state = JointType.CONTINUOUS, None, 0.0
    hinge.drive_limits = DriveLimits(7.0, 2.0)
    path = object_json.save(obj, tmp_path / "in")
    root = import_rig(blender, path)
    assert export(blender, root, tmp_path / "out", formats={"json"}, check=False) == {"FINISHED"}
    exported = load(tmp_path / "out" / "object.json")
    assert exported.joint(hinge.name).drive_limits == DriveLimits(7.0, 2.0)
    assert [d for d in differences(obj, exported, tol=1e-6) if "limit" in d] == []
