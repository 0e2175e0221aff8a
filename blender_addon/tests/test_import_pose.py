"""Import every generated category (object.json, URDF, MJCF, glTF) and the dev PartNet-Mobility
objects; pose the rig through the panel's sliders; the parts' world matrices must be the
model's forward kinematics (from the main venv) to 1e-5."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import (
    CATEGORIES,
    INPUT_FORMATS,
    addon_module,
    fk_reference,
    partnet_dev,
    partnet_ids,
    partnet_urdf,
)

FK_TOLERANCE = 1e-5
CONFIGURATIONS = 4  # the observed state and three random ones


def import_rig(bpy, path):
    assert bpy.ops.import_scene.real2code(filepath=str(path)) == {"FINISHED"}
    root = bpy.context.view_layer.objects.active
    assert addon_module("from_blender").find_rig(root) is root
    return root


def rig_objects(root, role: str) -> dict:
    """model name -> object, for the rig's objects of one role."""
    rp = addon_module("rig_props")
    coll = root.users_collection[0]
    objects = list(coll.all_objects)
    return {o[rp.NAME]: o for o in objects if o.get(rp.ROLE) == role}


def check_structure(bpy, root, ref: dict) -> None:
    """One object per part, parented along the tree through joint Empties; limits as local
    constraints; collision pieces hidden; custom properties present."""
    rp = addon_module("rig_props")
    parts, joints = rig_objects(root, rp.ROLE_PART), rig_objects(root, rp.ROLE_JOINT)
    assert sorted(parts) == sorted(ref["parts"])
    assert sorted(joints) == sorted(ref["joints"])
    for name, jtype in ref["joints"].items():
        je = joints[name]
        assert je[rp.TYPE] == jtype
        assert je.parent.get(rp.ROLE) == rp.ROLE_PART
        child = [c for c in je.children if c.get(rp.ROLE) == rp.ROLE_PART]
        assert len(child) == 1
        for key in ("damping", "friction", "stiffness", "spring_ref", "armature"):
            assert rp.dynamics_key(key) in je
        if jtype in ("revolute", "prismatic"):
            kind = "LIMIT_ROTATION" if jtype == "revolute" else "LIMIT_LOCATION"
            cons = [c for c in je.constraints if c.type == kind]
            assert len(cons) == 1 and cons[0].owner_space == "LOCAL"
            assert rp.LOWER in je and rp.UPPER in je and rp.AXIS in je
    hidden = [c for c in root.users_collection[0].children
              if c.get(rp.ROLE) == rp.ROLE_COLLISION]
    assert len(hidden) == 1 and hidden[0].hide_viewport and hidden[0].hide_render
    for ob in hidden[0].objects:
        assert ob.get(rp.ROLE) == rp.ROLE_COLLISION
        assert ob.parent.get(rp.ROLE) == rp.ROLE_PART


def check_poses(bpy, root, ref: dict) -> float:
    """Set every configuration through the panel's sliders; the worst position error."""
    panel = addon_module("panel")
    rp = addon_module("rig_props")
    parts = rig_objects(root, rp.ROLE_PART)
    sliders = {label: ob for ob, _, label in panel.joint_sliders(root)}
    worst = 0.0
    for q, poses in zip(ref["configurations"], ref["poses"], strict=True):
        assert set(q) == set(sliders)
        for name, value in q.items():
            panel.set_joint_value(sliders[name], value)
        bpy.context.view_layer.update()
        for name, pose in poses.items():
            got = np.array(parts[name].matrix_world, dtype=np.float64)
            err = np.abs(got - np.array(pose)).max()
            assert err <= FK_TOLERANCE, (name, q, err)
            worst = max(worst, err)
    return worst


@pytest.mark.parametrize("category", list(CATEGORIES))
def test_generated_categories(blender, generated, category):
    files = generated[category]
    refs = fk_reference([{"path": str(files[f]), "configurations": CONFIGURATIONS, "seed": 0}
                         for f in INPUT_FORMATS])
    cube = blender.data.objects.new("users_cube", blender.data.meshes.new("users_cube"))
    blender.context.scene.collection.objects.link(cube)
    for fmt in INPUT_FORMATS:
        root = import_rig(blender, files[fmt])
        ref = refs[str(files[fmt])]
        check_structure(blender, root, ref)
        check_poses(blender, root, ref)
    # importing never clears the scene: the user's object and every earlier rig are still there
    assert "users_cube" in blender.context.scene.objects
    rp = addon_module("rig_props")
    roots = [o for o in blender.context.scene.objects if o.get(rp.ROLE) == rp.ROLE_OBJECT]
    assert len(roots) == len(INPUT_FORMATS)


@pytest.fixture(scope="session")
def partnet_references():
    """Forward kinematics of every dev object, in one run of the main venv."""
    return fk_reference([{"path": str(p), "configurations": CONFIGURATIONS, "seed": 1}
                         for p in partnet_dev()])


@pytest.mark.partnet
@pytest.mark.parametrize("object_id", partnet_ids())
def test_partnet_dev_objects(blender, partnet_references, object_id):
    path = partnet_urdf(object_id)
    ref = partnet_references[str(path)]
    root = import_rig(blender, path)
    check_structure(blender, root, ref)
    check_poses(blender, root, ref)


def test_usd_import(blender, generated):
    """USD goes through Blender's own pxr (OpenUSD 25.08 in Blender 5.0, whose UsdPhysics
    parser has the older name the reader falls back to)."""
    files = generated["storage_furniture"]
    ref = fk_reference([{"path": str(files["usd"]), "configurations": CONFIGURATIONS,
                         "seed": 0}])[str(files["usd"])]
    root = import_rig(blender, files["usd"])
    check_structure(blender, root, ref)
    check_poses(blender, root, ref)
