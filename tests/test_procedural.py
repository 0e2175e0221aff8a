"""The procedural generator: valid, deterministic, physically sensible objects in every
Real2Code category and every household category (closed without overlaps, opening outward,
standing on the floor)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from pipeline.procedural import (
    ALL_CATEGORIES,
    CATEGORIES,
    FRONT,
    GENERATOR,
    HOUSEHOLD_CATEGORIES,
    UP,
    GenerationError,
    generate,
    part_count_range,
)
from pipeline.procedural._build import _local_boxes, _penetrates
from real2code_export import transforms as tf
from real2code_export.errors import Real2CodeError
from real2code_export.formats import object_json
from real2code_export.model import JointType, differences, forward_kinematics, validate

CLEARANCE = 1e-3  # closed fronts keep at least this much air to every other part (m)
SEEDS = (0, 1, 2)


def _every_count(categories=CATEGORIES, seeds=SEEDS):
    return [(c, n, s) for c in categories for n in range(part_count_range(c)[0],
                                                         part_count_range(c)[1] + 1)
            for s in seeds]


CASES = _every_count()
# Household categories: every part count once, the seed alternating (the suite's time).
HOUSEHOLD_CASES = [(c, n, n % 2) for c, n, _ in _every_count(HOUSEHOLD_CATEGORIES, seeds=(0,))]
_cache: dict[tuple, object] = {}


def _generated(category, n_parts, seed):
    """Generation is deterministic (tested below), so tests share the objects."""
    key = (category, n_parts, seed)
    if key not in _cache:
        _cache[key] = generate(category, n_parts, seed)
    return _cache[key]


def _piece_boxes(obj, q):
    """World axis-aligned bounds of every collision piece at ``q``, and each piece's part."""
    poses = forward_kinematics(obj, q)
    owners, lo, hi = [], [], []
    for part in obj.parts:
        for piece in part.collision:
            v = piece.transformed(poses[part.name]).vertices
            owners.append(part.name)
            lo.append(v.min(axis=0))
            hi.append(v.max(axis=0))
    return np.array(owners), np.array(lo), np.array(hi)


def _clashes(obj, q, clearance=CLEARANCE):
    """Pairs of pieces of different parts whose bounds are not ``clearance`` apart along any
    axis. The pieces are boxes (or cylinders) aligned with the world axes when the object is
    closed, so bounds that are apart prove the parts do not touch."""
    owners, lo, hi = _piece_boxes(obj, q)
    gap = np.maximum(lo[:, None, :] - hi[None, :, :], lo[None, :, :] - hi[:, None, :]).max(axis=2)
    bad = (gap < clearance) & (owners[:, None] < owners[None, :])
    return sorted({(str(owners[i]), str(owners[j]), round(float(gap[i, j]), 4))
                   for i, j in zip(*np.nonzero(bad), strict=True)})


def _world_vertices(obj, part, q):
    return obj.part(part).visual.transformed(forward_kinematics(obj, q)[part]).vertices


# -- validity, names, metadata ------------------------------------------------------------------
def test_part_count_ranges_follow_real2code():
    assert part_count_range("storage_furniture") == (2, 15)  # the paper's 2-15 part objects
    assert part_count_range("laptop") == part_count_range("box") == (2, 2)
    for category in CATEGORIES:
        lo, hi = part_count_range(category)
        assert 2 <= lo <= hi


@pytest.mark.parametrize("category, n_parts, seed", CASES)
def test_generated_objects_are_valid_and_named(category, n_parts, seed):
    obj = _generated(category, n_parts, seed)
    assert validate(obj) is obj
    assert len(obj.parts) == n_parts
    assert obj.name == f"{category}_{seed}"
    assert obj.root.name == "body"
    meta = obj.metadata
    assert (meta["category"], meta["seed"], meta["generator"]) == (category, seed, GENERATOR)
    assert json.loads(json.dumps(meta)) == meta
    assert set(meta["part_labels"]) == {p.name for p in obj.parts}
    assert set(meta["joint_labels"]) == {j.name for j in obj.joints}
    for j in obj.joints:
        assert j.parent == "body" and j.type.movable
        label = meta["joint_labels"][j.name]
        assert meta["part_labels"][j.child] == label
        if label == "drawer":
            assert j.type is JointType.PRISMATIC and j.name == f"{j.child}_slide"
        else:
            assert label in ("door", "lid") and j.type is JointType.REVOLUTE
            assert j.name == f"{j.child}_hinge" and j.name in meta["hinge_sides"]
    fronts = [p.name for p in obj.parts if p.name.startswith(("door_", "drawer_"))]
    assert sorted(int(n.rsplit("_", 1)[1]) for n in fronts) == list(range(len(fronts)))


@pytest.mark.parametrize("category", ALL_CATEGORIES)
def test_part_count_from_the_seed(category):
    lo, hi = part_count_range(category)
    counts = set()
    for seed in range(12 if category in CATEGORIES else 6):
        obj = generate(category, None, seed)
        assert lo <= len(obj.parts) <= hi
        if seed == 0:  # the count comes from the seed (whole objects: byte_for_byte below)
            assert len(generate(category, None, seed).parts) == len(obj.parts)
        counts.add(len(obj.parts))
    assert hi == lo or len(counts) > 1


@pytest.mark.parametrize("category, n_parts", [
    ("storage_furniture", 1), ("storage_furniture", 16), ("table", 0), ("refrigerator", 4),
    ("laptop", 3), ("box", 1), ("laptop", 2.0), ("box", True),
])
def test_impossible_part_counts_are_refused(category, n_parts):
    with pytest.raises(GenerationError, match=category if isinstance(n_parts, int) and
                       not isinstance(n_parts, bool) else "n_parts") as info:
        generate(category, n_parts, 0)
    assert isinstance(info.value, ValueError) and isinstance(info.value, Real2CodeError)


def test_bad_category_and_seed_are_refused():
    with pytest.raises(GenerationError, match="unknown category 'chair'"):
        generate("chair", 2, 0)
    with pytest.raises(GenerationError, match="unknown category"):
        part_count_range("chair")
    with pytest.raises(GenerationError, match="seed"):
        generate("box", 2, -1)


# -- determinism --------------------------------------------------------------------------------
@pytest.mark.parametrize("category, n_parts", [("storage_furniture", 9), ("table", 3),
                                               ("refrigerator", 3), ("laptop", 2), ("box", 2),
                                               ("oven", 7), ("door", 3)])
def test_same_seed_same_object_byte_for_byte(tmp_path, category, n_parts):
    a, b = generate(category, n_parts, 7), generate(category, n_parts, 7)
    assert differences(a, b, tol=0.0) == []
    assert a.metadata == b.metadata
    object_json.save(a, tmp_path / "a")
    object_json.save(b, tmp_path / "b")
    files_a = sorted(p.relative_to(tmp_path / "a") for p in (tmp_path / "a").rglob("*") if p.is_file())
    files_b = sorted(p.relative_to(tmp_path / "b") for p in (tmp_path / "b").rglob("*") if p.is_file())
    assert files_a == files_b and len(files_a) > 2
    for rel in files_a:
        assert (tmp_path / "a" / rel).read_bytes() == (tmp_path / "b" / rel).read_bytes(), rel
    # The lossless format gives the generated object back exactly.
    assert differences(object_json.load(tmp_path / "a" / "object.json"), a, tol=0.0) == []
    # ... and another seed gives another object.
    assert differences(generate(category, n_parts, 8), a, tol=1e-9)


# -- joints -------------------------------------------------------------------------------------
@pytest.mark.parametrize("category", CATEGORIES)
def test_limits_and_observed_states(category):
    fractions = []
    for (_, n, s) in _every_count([category]):
        obj = _generated(category, n, s)
        size = np.ptp(obj.root.visual.vertices, axis=0)
        for j in obj.joints:
            lim = j.limits
            assert lim.lower == 0.0 and lim.lower <= j.state <= lim.upper
            assert lim.effort > 0 and lim.velocity > 0
            if j.type is JointType.REVOLUTE:
                assert 1.0 <= lim.upper <= 2.7  # doors ~60-115 degrees, lids up to ~145
            else:  # a drawer comes out by most of its depth, never out of the body's
                assert 0.05 <= lim.upper < size[0]
            fractions.append(j.state / lim.upper)
    fractions = np.array(fractions)
    # Mostly partly open, as Real2Code renders them, some closed.
    assert np.mean((fractions > 0.1) & (fractions < 0.95)) > 0.6
    if len(fractions) > 20:
        assert np.any(fractions == 0.0)


@pytest.mark.parametrize("category, n_parts, seed", CASES + HOUSEHOLD_CASES)
def test_closed_parts_do_not_interpenetrate(category, n_parts, seed):
    obj = _generated(category, n_parts, seed)
    assert _clashes(obj, {}) == []


def test_clash_check_finds_a_drawer_pushed_into_the_body():
    obj = generate("storage_furniture", 6, 3)
    drawers = [j for j in obj.joints if j.type is JointType.PRISMATIC]
    doors = [j for j in obj.joints if j.type is JointType.REVOLUTE]
    assert drawers or doors
    if drawers:  # pushed 3 cm past closed, the drawer's back goes through the carcass back
        assert _clashes(obj, {drawers[0].name: -0.03})
    for j in doors:  # a door turned inward hits the carcass
        assert _clashes(obj, {j.name: -0.3})


def test_box_overlap_test_matches_geometry():
    """Two unit cubes, the second turned 45 degrees about z: they touch when their centres
    are 0.5 + sqrt(2)/2 apart along x."""
    cube = (np.zeros((1, 3)), np.full((1, 3), 0.5))
    turned = tf.make(tf.axis_angle_matrix([0, 0, 1], np.pi / 4))
    touch = 0.5 + math.sqrt(0.5)
    for d, expected in ((touch - 0.01, True), (touch + 0.01, False), (0.3, True)):
        pose = turned.copy()
        pose[:3, 3] = [d, 0.0, 0.0]
        assert _penetrates(cube, cube, np.eye(4), pose) is expected, d
        assert _penetrates(cube, cube, pose, np.eye(4)) is expected, d


@pytest.mark.parametrize("category", ALL_CATEGORIES)
def test_observed_configuration_is_collision_free(category):
    cases = _every_count([category]) if category in CATEGORIES else \
        [case for case in HOUSEHOLD_CASES if case[0] == category]
    for (_, n, s) in cases:
        obj = _generated(category, n, s)
        poses = forward_kinematics(obj, obj.observed_configuration())
        boxes = {p.name: _local_boxes(p) for p in obj.parts}
        for j in obj.joints:
            for other in obj.parts:
                if other.name != j.child:
                    assert not _penetrates(boxes[j.child], boxes[other.name], poses[j.child],
                                           poses[other.name]), (obj.name, j.child, other.name)


@pytest.mark.parametrize("category, n_parts, seed", CASES)
def test_opening_moves_fronts_out_and_lids_up(category, n_parts, seed):
    obj = _generated(category, n_parts, seed)
    body_front = obj.root.visual.vertices[:, 0].max()
    for j in obj.joints:
        label = obj.metadata["joint_labels"][j.name]
        closed = _world_vertices(obj, j.child, {})
        opened = _world_vertices(obj, j.child, {j.name: j.limits.upper})
        if j.type is JointType.PRISMATIC:
            np.testing.assert_allclose(opened - closed, np.outer(np.ones(len(closed)),
                                                                 j.limits.upper * FRONT), atol=1e-12)
            assert opened[:, 0].max() > body_front + 0.5 * j.limits.upper
            continue
        # The point farthest from the hinge line moves outward by most of its radius.
        hinge = j.origin[:3, 3]
        axis = j.origin[:3, :3] @ j.axis
        rel = closed - hinge
        radius = np.linalg.norm(rel - np.outer(rel @ axis, axis), axis=1)
        far = int(np.argmax(radius))
        outward = UP if label == "lid" else FRONT
        assert (opened[far] - closed[far]) @ outward > 0.5 * radius[far], (j.name, label)
        # ... and the part's centre moves that way too.
        assert (opened.mean(axis=0) - closed.mean(axis=0)) @ outward > 0.0


# The joint each household label has: its type, and for a hinge how its far point moves.
HOUSEHOLD_JOINTS = {"door": "outward", "lid": "up", "pedal": "down", "knob": "own axis",
                    "turntable": "own axis", "drawer": "slide", "rack": "slide",
                    "sliding_door": "slide"}


@pytest.mark.parametrize("category, n_parts, seed", HOUSEHOLD_CASES)
def test_household_objects_are_valid_and_joints_as_intended(category, n_parts, seed):
    obj = _generated(category, n_parts, seed)
    assert validate(obj) is obj and len(obj.parts) == n_parts and obj.root.name == "body"
    meta = obj.metadata
    assert (meta["category"], meta["seed"], meta["generator"]) == (category, seed, GENERATOR)
    assert json.loads(json.dumps(meta)) == meta
    assert set(meta["part_labels"]) == {p.name for p in obj.parts}
    for j in obj.joints:
        label = meta["joint_labels"][j.name]
        motion = HOUSEHOLD_JOINTS[label]
        assert j.parent == "body" and meta["part_labels"][j.child] == label
        assert 0.0 == j.limits.lower <= j.state <= j.limits.upper
        closed = _world_vertices(obj, j.child, {})
        opened = _world_vertices(obj, j.child, {j.name: j.limits.upper})
        if motion == "slide":
            assert j.type is JointType.PRISMATIC and j.name == f"{j.child}_slide"
            along = FRONT if label != "sliding_door" else np.array([0.0, np.sign(j.axis[1]), 0.0])
            assert abs(j.axis @ along) == 1.0  # racks and drawers along +X, sliding doors along Y
            np.testing.assert_allclose(opened - closed, np.outer(np.ones(len(closed)),
                                                                 j.limits.upper * along), atol=1e-12)
            continue
        assert j.type is JointType.REVOLUTE and j.name == f"{j.child}_hinge"
        hinge = j.origin[:3, 3]
        if motion == "own axis":  # a knob or turntable turns about the axis through its middle
            centre = closed.mean(axis=0)
            off_axis = (centre - hinge) - ((centre - hinge) @ j.axis) * j.axis
            assert np.linalg.norm(off_axis) < 0.01 and 3.0 < j.limits.upper < 2 * np.pi
            continue
        assert j.name in meta["hinge_sides"]
        rel = closed - hinge
        radius = np.linalg.norm(rel - np.outer(rel @ j.axis, j.axis), axis=1)
        far = int(np.argmax(radius))
        direction = {"outward": FRONT, "up": UP, "down": -UP}[motion]
        assert (opened[far] - closed[far]) @ direction > 0.2 * radius[far], (j.name, label)


def test_household_styles_vary_with_the_seed():
    assert {_generated("oven", 3, s).metadata["style"]["kind"] for s in range(6)} == {"range", "wall"}
    doors = [_generated("door", 2, s) for s in range(8)]
    assert {o.metadata["style"]["layout"] for o in doors} == {"hinged", "sliding"}
    assert {_generated("trash_can", 3, s).metadata["style"]["lid"] for s in range(6)} == \
        {"single", "butterfly"}
    objs = doors + [_generated(*case) for case in HOUSEHOLD_CASES]
    labels = {lab for o in objs for lab in o.metadata["joint_labels"].values()}
    assert labels == set(HOUSEHOLD_JOINTS)


# -- geometry and mass ------------------------------------------------------------------------
@pytest.mark.parametrize("category, n_parts, seed", CASES + HOUSEHOLD_CASES)
def test_stands_on_the_floor(category, n_parts, seed):
    obj = _generated(category, n_parts, seed)
    assert obj.root.visual.vertices[:, 2].min() == 0.0
    # Nothing goes below the floor, closed or with any one joint at its upper limit.
    for q in [{}] + [{j.name: j.limits.upper} for j in obj.joints]:
        for part in obj.parts:
            assert _world_vertices(obj, part.name, q)[:, 2].min() >= -1e-12, (part.name, q)
    # Centred on the z axis: the body's footprint straddles the origin.
    lo, hi = obj.root.visual.bounds()
    assert np.all(lo[:2] < 0) and np.all(hi[:2] > 0)


@pytest.mark.parametrize("category, n_parts, seed",
                         [(c, n, 0) for c, n, s in CASES if s == 0] + HOUSEHOLD_CASES)
def test_meshes_are_closed_convex_boxes_and_inertials_match_them(category, n_parts, seed):
    import trimesh

    obj = _generated(category, n_parts, seed)
    faces = 0
    for part in obj.parts:
        assert sum(len(m.faces) for m in part.collision) == len(part.visual.faces)
        for piece in part.collision:
            tm = trimesh.Trimesh(piece.vertices, piece.faces)
            assert tm.is_volume and tm.is_convex
        faces += len(part.visual.faces)
        # The centre of mass is inside the part, and the mass is what its pieces' volumes
        # hold at some material density between cardboard's and solid steel's.
        inertial = part.inertial
        lo, hi = part.visual.bounds()
        assert np.all(inertial.com >= lo) and np.all(inertial.com <= hi)
        volume = sum(trimesh.Trimesh(m.vertices, m.faces).volume for m in part.collision)
        assert 100.0 < inertial.mass / volume < 8000.0
    assert faces < 5000  # modest: every part is a few dozen boxes


@pytest.mark.parametrize("seed", range(4))
def test_inertials_equal_the_integrated_pieces(seed):
    """Box parts are one material: their combined box inertials equal trimesh's integration
    of the collision pieces at that density."""
    from real2code_export.inertia import inertial_from_meshes

    obj = generate("box", 2, seed)
    for part in obj.parts:
        volume = sum(p.to_trimesh().volume for p in part.collision)
        ref = inertial_from_meshes(part.collision, density=part.inertial.mass / volume)
        np.testing.assert_allclose(part.inertial.com, ref.com, atol=1e-12)
        np.testing.assert_allclose(part.inertial.inertia, ref.inertia, rtol=1e-6,
                                   atol=1e-9 * np.abs(ref.inertia).max())


@pytest.mark.parametrize("category, low, high", [
    ("storage_furniture", 5.0, 300.0), ("table", 5.0, 100.0), ("refrigerator", 20.0, 200.0),
    ("laptop", 0.5, 5.0), ("box", 0.02, 30.0), ("oven", 20.0, 120.0), ("dishwasher", 10.0, 60.0),
    ("microwave", 5.0, 25.0), ("trash_can", 0.5, 15.0), ("door", 10.0, 250.0),
])
def test_masses_and_sizes_are_realistic(category, low, high):
    cases = _every_count([category]) if category in CATEGORIES else \
        [case for case in HOUSEHOLD_CASES if case[0] == category]
    largest = 3.5 if category == "door" else 2.1  # a sliding door runs over the wall beside
    for (_, n, s) in cases:
        obj = _generated(category, n, s)
        assert low <= obj.total_mass() <= high, (obj.name, obj.total_mass())
        size = np.ptp(np.concatenate([_world_vertices(obj, p.name, {}) for p in obj.parts]), axis=0)
        assert np.all(size > 0.01) and np.all(size < largest), (obj.name, size)
        if category == "storage_furniture":
            assert size.min() >= 0.3 and size.max() <= 2.1


def test_styles_vary_with_the_seed():
    objs = [generate("storage_furniture", n, s) for n in (3, 5, 8) for s in range(6)]
    sides = {side for o in objs for side in o.metadata["hinge_sides"].values()}
    assert {"left", "right", "top"} <= sides
    labels = {lab for o in objs for lab in o.metadata["joint_labels"].values()}
    assert labels == {"door", "drawer"}
    for key in ("layout", "base", "handle", "body_color"):
        assert len({o.metadata["style"][key] for o in objs}) > 1, key
    assert len({tuple(round(c, 6) for c in o.root.color) for o in objs}) > 5
    fridge = {generate("refrigerator", 3, s).metadata["style"]["layout"] for s in range(12)}
    assert fridge == {"top_freezer", "bottom_freezer", "side_by_side"}


@pytest.mark.parametrize("category, n_parts, seed", [("table", 3, 4), ("storage_furniture", 8, 1)])
def test_drawers_are_open_containers(category, n_parts, seed):
    """A drawer is a front panel plus a box without a top: looking down into it from above
    its middle, only its bottom is in the way (a solid block or a lidded box would not be)."""
    obj = generate(category, n_parts, seed)
    drawers = [j.child for j in obj.joints if j.type is JointType.PRISMATIC]
    assert drawers
    for name in drawers:
        part = obj.part(name)
        lo, _ = part.visual.bounds()
        middle = np.array([lo[0] / 2, 0.0])  # the part frame is at the front face's centre
        above = [piece for piece in part.collision
                 if np.all(piece.bounds()[0][:2] <= middle) and np.all(middle <= piece.bounds()[1][:2])]
        assert len(above) == 1, name
        assert np.ptp(above[0].vertices[:, 2]) < 0.03  # a thin bottom board


# -- simulators ---------------------------------------------------------------------------------
@pytest.mark.parametrize("category, n_parts", [("storage_furniture", 15), ("storage_furniture", 12),
                                               ("storage_furniture", 4),
                                               ("table", 5), ("refrigerator", 3), ("laptop", 2),
                                               ("box", 2), ("oven", 12), ("door", 3)])
def test_compiles_in_mujoco(tmp_path, category, n_parts):
    mujoco = pytest.importorskip("mujoco")
    mjcf = pytest.importorskip("real2code_export.formats.mjcf")
    if not hasattr(mjcf, "save"):
        pytest.skip("the MJCF exporter is not written yet")
    obj = generate(category, n_parts, 5)
    model = mujoco.MjModel.from_xml_path(str(mjcf.save(obj, tmp_path)))
    assert model.njnt == len(obj.joints)
    data = mujoco.MjData(model)
    for j in obj.joints:
        data.joint(j.name).qpos[0] = j.state
    mujoco.mj_forward(model, data)
    poses = forward_kinematics(obj, obj.observed_configuration())
    for part in obj.parts:
        np.testing.assert_allclose(data.body(part.name).xpos, poses[part.name][:3, 3], atol=1e-6)
    assert math.isclose(float(model.body_mass.sum()), obj.total_mass(), rel_tol=1e-6)
    # MuJoCo's own collision detection (GJK/EPA on the convex pieces) finds no part pushed
    # into another at the observed state (it skips body-child pairs: tested above with boxes).
    deep = [(model.body(model.geom_bodyid[c.geom1]).name, model.body(model.geom_bodyid[c.geom2]).name,
             float(c.dist)) for c in data.contact[:data.ncon] if c.dist < -1e-4]
    assert deep == []
