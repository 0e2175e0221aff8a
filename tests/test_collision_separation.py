"""Collision pieces faithful to the object: hollow parts keep their insides, and no two
parts' pieces overlap at q = 0 or along a joint's range (measured by MuJoCo's collision
detection on the exported MJCF, every pair included, as a URDF leaves them)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from real2code_export import transforms as tf
from real2code_export.collision import collision_pieces
from real2code_export.collision_separation import separate
from real2code_export.dynamics.overlap import overlaps
from real2code_export.errors import Real2CodeWarning
from real2code_export.formats import write_formats
from real2code_export.formats.urdf import load
from real2code_export.inertia import inertial_from_meshes
from real2code_export.model import ArticulatedObject, Joint, Limits, Mesh, Part, validate


def open_box(extents, center=(0.0, 0.0, 0.0), open_side: int = 0) -> Mesh:
    """A box surface without the face on +open_side (a carcass without its front, a drawer
    without its top)."""
    tm = trimesh.creation.box(extents)
    keep = tm.triangles_center[:, open_side] < extents[open_side] / 2 - 1e-9
    mesh = Mesh(tm.vertices, tm.faces[keep])
    return mesh.transformed(tf.make(translation=center))


def slab(extents, center) -> Mesh:
    tm = trimesh.creation.box(extents)
    return Mesh.from_trimesh(tm).transformed(tf.make(translation=center))


def part(name: str, mesh: Mesh) -> Part:
    pieces = collision_pieces(mesh, "auto")
    return Part(name, visual=mesh, collision=pieces, inertial=inertial_from_meshes([mesh], 500))


def cabinet() -> ArticulatedObject:
    """A carcass open at +x; a door over the opening, sunk 5 mm into the carcass's rim and
    hinged at its -y edge, opening outward; a drawer (open at +z) inside, its sides sunk 3 mm
    into the carcass's bottom."""
    carcass = part("carcass", open_box([0.4, 0.6, 0.5], open_side=0))
    door = part("door", slab([0.02, 0.6, 0.5], [0.205, 0.0, 0.0]))
    drawer = part("drawer", open_box([0.36, 0.58, 0.1], [0.0, 0.0, -0.203], open_side=2))
    hinge = Joint("door_hinge", "revolute", "carcass", "door",
                  origin=tf.make(translation=[0.2, -0.3, 0.0]), axis=[0, 0, -1],
                  limits=Limits(0.0, 1.5))
    door.visual = door.visual.transformed(tf.make(translation=[-0.2, 0.3, 0.0]))
    door.collision = [m.transformed(tf.make(translation=[-0.2, 0.3, 0.0]))
                      for m in door.collision]
    door.inertial = inertial_from_meshes([door.visual], 500)
    slide = Joint("drawer_slide", "prismatic", "carcass", "drawer", axis=[1, 0, 0],
                  limits=Limits(0.0, 0.3))
    return validate(ArticulatedObject("cabinet", [carcass, door, drawer], [hinge, slide]))


def measured(obj: ArticulatedObject, tmp_path, q=None):
    return overlaps(write_formats(obj, tmp_path, ["mjcf"])["mjcf"], q)


def test_a_hollow_carcass_keeps_its_inside(tmp_path):
    carcass = cabinet().part("carcass")
    assert len(carcass.collision) >= 5  # back, sides, top, bottom: its hull would be one
    inside = np.array([[0.0, 0.0, 0.0], [0.15, 0.2, 0.2], [-0.15, -0.25, -0.2]])
    for piece in carcass.collision:
        assert not piece.to_trimesh().contains(inside).any()


def test_separation_leaves_no_overlap_at_rest_nor_along_the_ranges(tmp_path):
    obj = cabinet()
    before = {tuple(sorted((o.part_a, o.part_b))) for o in measured(obj, tmp_path / "a")}
    assert {("carcass", "door"), ("carcass", "drawer")} <= before
    separated, cuts = separate(obj)
    assert {c.outcome for c in cuts} == {"cut"}
    assert measured(separated, tmp_path / "b") == []
    for joint in separated.movable_joints:  # a door against its frame, a drawer its carcass
        for value in np.linspace(joint.limits.lower, joint.limits.upper, 4):
            found = measured(separated, tmp_path / f"{joint.name}{value:.2f}",
                             {joint.name: float(value)})
            assert not [o for o in found if {o.part_a, o.part_b} == {joint.parent, joint.child}]
    # only the overlapping rims were cut: the parts keep nearly all of their volume
    for name in ("carcass", "door", "drawer"):
        volume = sum(p.to_trimesh().volume for p in obj.part(name).collision)
        kept = sum(p.to_trimesh().volume for p in separated.part(name).collision)
        assert 0.8 * volume < kept <= volume + 1e-12


def test_a_shaft_through_a_block_is_carved_around():
    """Cutting either by a plane would remove most of it: the block is split around the
    shaft's box instead, and stays so as the shaft turns."""
    block = slab([0.2, 0.2, 0.2], [0, 0, 0])
    shaft = slab([0.04, 0.04, 0.4], [0, 0, 0])
    obj = validate(ArticulatedObject("axle", [
        Part("block", collision=[block], inertial=inertial_from_meshes([block], 500)),
        Part("shaft", collision=[shaft], inertial=inertial_from_meshes([shaft], 500))],
        [Joint("spin", "continuous", "block", "shaft")]))
    separated, cuts = separate(obj)
    assert "carved" in {c.outcome for c in cuts} and "left" not in {c.outcome for c in cuts}
    assert len(separated.part("block").collision) >= 4
    kept = sum(p.to_trimesh().volume for p in separated.part("block").collision)
    assert 0.6 * 0.008 < kept < 0.008
    shaft_kept = sum(p.to_trimesh().volume for p in separated.part("shaft").collision)
    assert 0.7 * 0.04 * 0.04 * 0.4 < shaft_kept <= 0.04 * 0.04 * 0.4 + 1e-12


URDF = """<robot name="shelf">
  <link name="body">
    <visual><geometry><box size="0.4 0.4 0.4"/></geometry></visual>
    {body_collision}
  </link>
  <link name="lid">
    <visual><origin xyz="0 0 0.21"/><geometry><box size="0.4 0.4 0.04"/></geometry></visual>
    <collision><origin xyz="0 0 0.21"/><geometry><box size="0.4 0.4 0.04"/></geometry></collision>
  </link>
  <joint name="hinge" type="revolute">
    <parent link="body"/><child link="lid"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="1.5" effort="1" velocity="1"/>
  </joint>
</robot>"""


def test_urdf_collision_that_is_the_visual_is_kept_apart(tmp_path):
    """Asked for, PartNet-style links (collision = visual shapes) sunk 1 cm into each other
    are cut apart, with a warning naming the pair; an author's own collision shape is never cut."""
    same = tmp_path / "same.urdf"
    same.write_text(URDF.format(body_collision='<collision><geometry><box size="0.4 0.4 0.4"/>'
                                              "</geometry></collision>"))
    assert measured(load(same), tmp_path / "default")  # as before unless asked
    with pytest.warns(Real2CodeWarning, match="lid against body|body against lid"):
        obj = load(same, faithful_collision=True)
    assert measured(obj, tmp_path / "same") == []
    authored = tmp_path / "authored.urdf"
    authored.write_text(URDF.format(body_collision='<collision><geometry><box size="0.41 0.4 '
                                                   '0.4"/></geometry></collision>'))
    obj = load(authored, faithful_collision=True)  # the lid's piece is cut, not the body's
    (piece,) = obj.part("body").collision
    np.testing.assert_allclose(np.ptp(piece.vertices, axis=0), [0.41, 0.4, 0.4])
    assert measured(obj, tmp_path / "authored") == []


def test_check_reports_overlapping_pieces(tmp_path):
    """`check` measures the parts' pieces at q = 0 (MuJoCo's collision detection on the MJCF,
    exclusions lifted) and names the pairs deeper than the tolerance, in its table and JSON;
    a robot's links overlap at their joints by design, so they do not fail the check."""
    import json

    from pipeline.procedural import generate
    from real2code_export.cli import run
    from real2code_export.formats import export

    obj = generate("box", seed=1)
    clean = export(obj, tmp_path / "clean", ["mjcf", "urdf"])
    assert run(["check", *map(str, clean.values()), "--json", str(tmp_path / "c.json")]) == 0
    assert json.loads((tmp_path / "c.json").read_text())["overlaps_at_zero"]["pairs"] == []
    lid = next(p for p in obj.parts if p is not obj.root)
    joint = next(j for j in obj.joints if j.child == lid.name)
    down = np.linalg.inv(joint.origin[:3, :3]) @ np.array([0.0, 0.0, -0.02])
    lid.collision = [m.transformed(np.block([[np.eye(3), down[:, None]], [0, 0, 0, 1]]))
                     for m in lid.collision]
    sunk = export(obj, tmp_path / "sunk", ["mjcf", "urdf"])
    out = tmp_path / "s.json"
    assert run(["check", *map(str, sunk.values()), "--json", str(out)]) == 0
    found = json.loads(out.read_text())["overlaps_at_zero"]
    assert found["file"].endswith(".xml")
    assert [sorted(p["parts"]) for p in found["pairs"]] == [sorted([obj.root.name, lid.name])]
    assert found["pairs"][0]["depth"] > 0.005


def test_a_partnet_object_whose_pieces_trimesh_finds_no_box_for():
    """PartNet 12036's thin pieces: trimesh's oriented_bounds finds no box (every candidate's
    volume NaN); the voxels are then axis-aligned and the object loads with its pieces."""
    from real2code_export.formats import load as load_any

    from conftest import partnet_dir

    path = partnet_dir() / "12036" / "mobility.urdf"
    if not path.is_file():
        pytest.skip(f"{path} is not here")
    with pytest.warns(Real2CodeWarning):
        obj = load_any(path, faithful_collision=True)
    assert all(p.collision for p in obj.parts if p.visual is not None)


def test_a_flat_piece_trimesh_finds_no_box_for_keeps_axis_aligned_voxels(monkeypatch):
    """trimesh's oriented_bounds fails on some exactly flat point sets (ValueError: a
    PartNet panel's face cut out by its colour, in `evaluate joints`): the voxels are then
    axis-aligned, as where it finds no box, and the carcass keeps its inside."""
    from real2code_export import collision_boxes

    def no_box(points, *args, **kwargs):
        raise ValueError("zero-size array to reduction operation maximum which has no identity")

    monkeypatch.setattr(trimesh.bounds, "oriented_bounds", no_box)
    carcass = open_box([0.4, 0.6, 0.5], open_side=0)
    hull = trimesh.convex.convex_hull(carcass.vertices).volume
    boxes = collision_boxes.hollow_pieces(carcass, hull, 0.4 / 40, 16)
    assert boxes is not None and len(boxes) >= 5  # back, sides, top, bottom


def test_pieces_that_meet_along_a_range_are_kept_apart_halfway_too(tmp_path):
    """PartNet 8867's door: a corner of one piece cut across an edge of the other between two
    swept values, both of which left them clear; separation now also cuts the pieces that
    met along a range halfway between the values, where `simulate` measures too."""
    from real2code_export.dynamics.overlap import overlaps_along_ranges
    from real2code_export.formats import load as load_any

    from conftest import partnet_dir

    path = partnet_dir() / "8867" / "mobility.urdf"
    if not path.is_file():
        pytest.skip(f"{path} is not here")
    with pytest.warns(Real2CodeWarning):
        obj = load_any(path, faithful_collision=True)
    mjcf = write_formats(obj, tmp_path, ["mjcf"])["mjcf"]
    assert overlaps(mjcf) == []
    assert overlaps_along_ranges(mjcf, obj) == []
