"""Our files in Blender's own importers, without the add-on: the .glb plays every joint with
one press of play; the USD shows the parts by name."""

from __future__ import annotations

import numpy as np

from conftest import CATEGORIES


def load(path):
    from real2code_export.formats import load as load_any

    return load_any(path)


def _matrix(ob) -> np.ndarray:
    return np.array(ob.matrix_world, dtype=np.float64)


def _angle(rotation: np.ndarray) -> float:
    return float(np.arccos(np.clip((np.trace(rotation) - 1.0) / 2.0, -1.0, 1.0)))


def test_gltf_importer_plays_every_joint(blender, generated):
    files = generated["storage_furniture"]
    model = load(files["json"])
    assert blender.ops.import_scene.gltf(filepath=str(files["gltf"])) == {"FINISHED"}
    # box collision pieces are implicit shapes: no collider mesh for the importer to show
    assert "Orphan Nodes" not in blender.data.collections
    assert {ob.name for ob in blender.data.objects if ob.type == "MESH"} == \
        {p.name for p in model.parts if p.visual is not None}
    objects = blender.data.objects
    scene = blender.context.scene
    movable = model.movable_joints
    # every moving part carries the action that plays them all
    actions = {objects[j.child].animation_data.action.name for j in movable}
    assert actions == {f"{model.name} all joints"}

    def relative(joint) -> np.ndarray:
        return np.linalg.inv(_matrix(objects[joint.parent])) @ _matrix(objects[joint.child])

    start, end = (int(v) for v in blender.data.actions[f"{model.name} all joints"].frame_range)
    scene.frame_set(start)
    at_start = {j.name: relative(j) for j in movable}
    scene.frame_set((start + end) // 4)  # a quarter through: every joint on its way up
    for joint in movable:
        moved = np.linalg.inv(at_start[joint.name]) @ relative(joint)
        span = joint.limits.upper - joint.limits.lower
        if joint.type.value == "prismatic":
            assert _angle(moved[:3, :3]) < 1e-5, joint.name
            assert np.linalg.norm(moved[:3, 3]) > 0.2 * span, joint.name
        else:
            assert _angle(moved[:3, :3]) > 0.2 * span, joint.name


def test_usd_importer_names_the_parts(blender, generated):
    for category in CATEGORIES:
        files = generated[category]
        model = load(files["json"])
        blender.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
        assert blender.ops.wm.usd_import(filepath=str(files["usd"])) == {"FINISHED"}
        meshes = {ob.name for ob in blender.data.objects if ob.type == "MESH"}
        assert meshes == {p.name for p in model.parts if p.visual is not None}, category
