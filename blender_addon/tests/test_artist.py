"""What an artist does to a rig is what gets exported: scale on the rig and on a part, a
handle parented to a drawer, a door turned by its own rotation (the gizmo's channel), limits
edited, Apply Scale. Each export is compared, independently of the add-on's own check, with
the meshes Blender shows, at the rig's pose and at a second one."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_export_check import export
from test_import_pose import import_rig, rig_objects

from conftest import addon_module

TOLERANCE = 1e-4  # m: float32 world matrices of a metre-sized object


def load(path):
    from real2code_export.formats import load as load_any

    return load_any(path)


def shown_vertices(bpy, ob) -> np.ndarray:
    """The part's own mesh as the viewport shows it, in world coordinates."""
    evaluated = ob.evaluated_get(bpy.context.evaluated_depsgraph_get())
    data = evaluated.to_mesh()
    try:
        co = np.array([v.co for v in data.vertices], dtype=np.float64)
    finally:
        evaluated.to_mesh_clear()
    world = np.array(evaluated.matrix_world, dtype=np.float64)
    return co @ world[:3, :3].T + world[:3, 3]


def rig_values(root, model, scale_along: dict | None = None) -> dict[str, float]:
    """The rig's joint values in the model's units (a prismatic joint's travel as shown)."""
    rp = addon_module("rig_props")
    joints = rig_objects(root, rp.ROLE_JOINT)
    scale_along = scale_along or {}
    return {j.name: rp.joint_value(joints[j.name]) * scale_along.get(j.name, 1.0)
            for j in model.joints if j.type.movable}


def worst_gap(bpy, root, model, values) -> float:
    """How far the exported model, posed at ``values``, puts each part's own vertices from
    where Blender shows them (the exported visual starts with the part's own mesh)."""
    from real2code_export.model import forward_kinematics

    rp = addon_module("rig_props")
    parts = rig_objects(root, rp.ROLE_PART)
    poses = forward_kinematics(model, values)
    worst = 0.0
    for part in model.parts:
        ob = parts[part.name]
        if ob.type != "MESH":
            continue
        shown = shown_vertices(bpy, ob)
        placed = part.visual.vertices[: len(shown)] @ poses[part.name][:3, :3].T + \
            poses[part.name][:3, 3]
        worst = max(worst, float(np.linalg.norm(placed - shown, axis=1).max()))
    return worst


def pose_everything(bpy, root, fraction: float) -> None:
    """Every movable joint at ``fraction`` of its range, through the panel's setter."""
    rp = addon_module("rig_props")
    panel = addon_module("panel")
    for je, _, _ in panel.joint_sliders(root):
        panel.set_joint_value(je, je[rp.LOWER] + fraction * (je[rp.UPPER] - je[rp.LOWER]))
    bpy.context.view_layer.update()


def export_json(bpy, root, out):
    assert export(bpy, root, out, formats={"json"}, check=False) == {"FINISHED"}
    return load(out / "object.json")


def test_rig_scaled_twice(blender, generated, tmp_path):
    original = load(generated["storage_furniture"]["json"])
    root = import_rig(blender, generated["storage_furniture"]["json"])
    root.scale = (2.0, 2.0, 2.0)
    root.location = (1.0, -3.0, 0.5)  # moving the rig does not move the object
    blender.context.view_layer.update()
    out = export_json(blender, root, tmp_path)
    size = lambda m: np.ptp(np.concatenate([p.visual.vertices for p in m.parts]), axis=0)  # noqa: E731
    assert np.allclose(size(out), 2.0 * size(original), rtol=1e-5)
    slides = {j.name: 2.0 for j in out.joints if j.type.value == "prismatic"}
    for j in out.joints:  # a drawer's range is its travel as shown: twice as long
        if j.name in slides:
            assert math.isclose(j.limits.upper, 2.0 * original.joint(j.name).limits.upper,
                                rel_tol=1e-6)
    root.location = (0.0, 0.0, 0.0)
    for fraction in (0.3, 0.9):
        pose_everything(blender, root, fraction)
        assert worst_gap(blender, root, out, rig_values(root, out, slides)) < 2 * TOLERANCE


def test_part_scaled_twice(blender, generated, tmp_path):
    """The body scaled: its doors and drawers hang from it, scaled and moved with it."""
    original = load(generated["storage_furniture"]["json"])
    root = import_rig(blender, generated["storage_furniture"]["json"])
    rp = addon_module("rig_props")
    parts = rig_objects(root, rp.ROLE_PART)
    parts[original.root.name].scale = (2.0, 2.0, 2.0)
    blender.context.view_layer.update()
    out = export_json(blender, root, tmp_path)
    slides = {j.name: 2.0 for j in out.joints if j.type.value == "prismatic"}
    body = out.part(original.root.name)
    assert np.allclose(np.ptp(body.visual.vertices, axis=0),
                       2.0 * np.ptp(original.root.visual.vertices, axis=0), rtol=1e-5)
    assert body.inertial.mass == original.root.inertial.mass  # same object, drawn bigger
    for fraction in (0.2, 0.7):
        pose_everything(blender, root, fraction)
        assert worst_gap(blender, root, out, rig_values(root, out, slides)) < 2 * TOLERANCE


def test_stretched_across_a_hinge_is_refused(blender, generated, tmp_path):
    original = load(generated["storage_furniture"]["json"])
    root = import_rig(blender, generated["storage_furniture"]["json"])
    rp = addon_module("rig_props")
    hinge = next(j for j in original.joints if j.type.value == "revolute")
    rig_objects(root, rp.ROLE_PART)[hinge.parent].scale = (1.0, 1.0, 1.5)
    blender.context.view_layer.update()
    out = tmp_path / "out"
    with pytest.raises(RuntimeError, match=f"joint '{hinge.name}'.*shear"):
        export(blender, root, out, formats={"json"}, check=False)
    assert not out.exists()


def test_parented_handle_is_exported(blender, generated, tmp_path):
    original = load(generated["storage_furniture"]["json"])
    root = import_rig(blender, generated["storage_furniture"]["json"])
    rp = addon_module("rig_props")
    slide = next(j for j in original.joints if j.type.value == "prismatic")
    drawer = rig_objects(root, rp.ROLE_PART)[slide.child]
    import bmesh

    data = blender.data.meshes.new("handle")
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=0.02)
    bm.to_mesh(data)
    bm.free()
    handle = blender.data.objects.new("handle", data)
    blender.context.scene.collection.objects.link(handle)
    handle.location = np.array(drawer.matrix_world.translation) + np.array([0.3, 0.0, 0.0])
    blender.context.view_layer.update()
    world = handle.matrix_world.copy()
    handle.parent = drawer  # parented as Ctrl+P does: it stays where it is
    handle.matrix_parent_inverse = drawer.matrix_world.inverted()
    lamp = blender.data.objects.new("lamp", blender.data.lights.new("lamp", "POINT"))
    blender.context.scene.collection.objects.link(lamp)
    lamp.parent = drawer
    blender.context.view_layer.update()
    assert np.allclose(np.array(handle.matrix_world), np.array(world), atol=1e-6)
    with pytest.warns(Warning, match="light 'lamp' is parented to the part but has no geometry"):
        addon_module("ops_export").export_rig(root, tmp_path, ["json"],
                                              blender.context.view_layer)
    out = load(tmp_path / "object.json")
    got = out.part(slide.child).visual
    assert len(got.vertices) == len(original.part(slide.child).visual.vertices) + 8
    from real2code_export.model import forward_kinematics

    pose = forward_kinematics(out, rig_values(root, out))[slide.child]
    corners = got.vertices[-8:] @ pose[:3, :3].T + pose[:3, 3]
    shown = shown_vertices(blender, handle)
    assert np.abs(np.sort(corners, axis=0) - np.sort(shown, axis=0)).max() < TOLERANCE
    # the handle moves with the drawer: every file holds it as part of the drawer
    pose_everything(blender, root, 0.8)
    assert worst_gap(blender, root, out, rig_values(root, out)) < TOLERANCE


def test_gizmo_pose_and_edited_limits(blender, generated, tmp_path):
    original = load(generated["storage_furniture"]["json"])
    root = import_rig(blender, generated["storage_furniture"]["json"])
    rp = addon_module("rig_props")
    panel = addon_module("panel")
    hinge = next(j for j in original.joints if j.type.value == "revolute")
    je = rig_objects(root, rp.ROLE_JOINT)[hinge.name]
    door = rig_objects(root, rp.ROLE_PART)[hinge.child]
    # the rotate tool writes the Empty's own Z rotation (the other axes are locked)
    assert tuple(je.lock_rotation) == (True, True, False)
    je.rotation_euler.z = 0.7
    blender.context.view_layer.update()
    assert getattr(je, panel.SLIDER_ANGLE) == pytest.approx(0.7, abs=1e-6)  # the slider shows it
    out = export_json(blender, root, tmp_path)
    assert worst_gap(blender, root, out, rig_values(root, out)) < TOLERANCE
    # turned past its range, the door is held at the limit the constraint shows
    je.rotation_euler.z = hinge.limits.upper + 0.5
    blender.context.view_layer.update()
    reading = addon_module("from_blender").read_rig_objects(
        root, blender.context.evaluated_depsgraph_get())
    shown = addon_module("from_blender").rig_configuration(reading)[hinge.name]
    assert shown == pytest.approx(hinge.limits.upper, abs=1e-5)
    assert worst_gap(blender, root, out, {**rig_values(root, out), hinge.name: shown}) < TOLERANCE
    # the slider follows an edited limit, both ways
    je[rp.UPPER] = 0.5
    setattr(je, panel.SLIDER_ANGLE, 1.2)
    assert rp.joint_value(je) == pytest.approx(0.5)
    je[rp.UPPER] = 1.5
    setattr(je, panel.SLIDER_ANGLE, 1.2)
    assert rp.joint_value(je) == pytest.approx(1.2)
    blender.context.view_layer.update()
    assert np.array(door.matrix_world).any()


def test_apply_scale_on_the_rig(blender, generated, tmp_path):
    """Object > Apply > Scale on the rig's Empty: Blender moves the scale into the children;
    the export still moves as the viewport does, at every pose."""
    root = import_rig(blender, generated["storage_furniture"]["json"])
    root.scale = (2.0, 2.0, 2.0)
    blender.context.view_layer.update()
    for ob in blender.context.view_layer.objects:
        ob.select_set(False)
    root.select_set(True)
    blender.context.view_layer.objects.active = root
    assert blender.ops.object.transform_apply(location=False, rotation=False,
                                              scale=True) == {"FINISHED"}
    blender.context.view_layer.update()
    out = tmp_path / "out"
    assert export(blender, root, out, formats={"json"}, check=False) == {"FINISHED"}
    model = load(out / "object.json")
    for fraction in (0.25, 0.75):
        pose_everything(blender, root, fraction)
        slides = {}
        for j in model.joints:  # the travel as shown: the Empty's channel times its scale
            if j.type.value == "prismatic":
                rp = addon_module("rig_props")
                je = rig_objects(root, rp.ROLE_JOINT)[j.name]
                parent = np.array(je.parent.matrix_world) @ np.array(je.matrix_parent_inverse)
                slides[j.name] = float(np.linalg.norm(parent[:3, 2]))
        assert worst_gap(blender, root, model, rig_values(root, model, slides)) < 2 * TOLERANCE


def test_box_edges_are_sharp(blender, generated):
    root = import_rig(blender, generated["storage_furniture"]["json"])
    rp = addon_module("rig_props")
    body = next(ob for ob in rig_objects(root, rp.ROLE_PART).values() if ob.type == "MESH")
    sharp = body.data.attributes.get("sharp_edge")
    assert sharp is not None and any(a.value for a in sharp.data)
