"""The model: validation with precise errors, kinematics, comparison, object.json."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from real2code_export import atomic
from real2code_export import transforms as tf
from real2code_export.errors import FormatError, ModelError
from real2code_export.formats import export, load, object_json
from real2code_export.model import (
    Inertial,
    Joint,
    JointType,
    Mesh,
    corner_bounds,
    differences,
    forward_kinematics,
    sample_configuration,
    sanitize_name,
    validate,
)

from helpers import box_inertial, box_mesh, small_cabinet


def test_small_cabinet_is_valid():
    obj = validate(small_cabinet())
    assert obj.root.name == "body"
    assert [j.name for j in obj.joints_in_tree_order()] == [
        "door_hinge", "knob_turn", "drawer_slide", "handle_mount"]


def test_forward_kinematics_matches_hand_composition():
    obj = small_cabinet()
    q = {"door_hinge": 0.7, "drawer_slide": 0.2, "knob_turn": -1.0}
    poses = forward_kinematics(obj, q)
    door = obj.joint("door_hinge")
    expected_door = door.origin @ tf.make(tf.axis_angle_matrix(door.axis, 0.7))
    np.testing.assert_allclose(poses["door"], expected_door, atol=1e-12)
    knob = obj.joint("knob_turn")
    expected_knob = expected_door @ knob.origin @ tf.make(tf.axis_angle_matrix([1, 0, 0], -1.0))
    np.testing.assert_allclose(poses["knob"], expected_knob, atol=1e-12)
    # the drawer slides 0.2 m along its axis (x in its frame, rotated by nothing here)
    np.testing.assert_allclose(poses["drawer"][:3, 3], [0.25, 0.1, 0.2], atol=1e-12)
    np.testing.assert_allclose(poses["handle"][:3, 3], [0.47, 0.1, 0.2], atol=1e-12)
    with pytest.raises(KeyError, match="nope"):
        forward_kinematics(obj, {"nope": 1.0})


def test_sample_configuration_stays_within_limits():
    obj = small_cabinet()
    rng = np.random.default_rng(0)
    for _ in range(50):
        q = sample_configuration(obj, rng)
        assert 0.0 <= q["door_hinge"] <= 1.6 and 0.0 <= q["drawer_slide"] <= 0.35
        assert -np.pi <= q["knob_turn"] <= np.pi
        assert "handle_mount" not in q


@pytest.mark.parametrize(
    "mutate, element, message",
    [
        (lambda o: o.joints.append(Joint("loop", "fixed", "knob", "body")), "object 'small_cabinet'", "a cycle"),
        (lambda o: setattr(o.joints[2], "child", "door"), "joint 'handle_mount'", "already has parent joint 'door_hinge'"),
        (lambda o: setattr(o.joints[2], "child", "drawer"), "joint 'handle_mount'", "to itself"),
        (lambda o: o.joints.pop(2), "object 'small_cabinet'", "exactly one root"),
        (lambda o: o.joints[0].origin.__setitem__((0, 3), np.nan), "joint 'door_hinge'", "origin is not finite"),
        (lambda o: setattr(o.joints[1], "axis", np.zeros(3)), "joint 'drawer_slide'", "zero length"),
        (lambda o: setattr(o.joints[1], "axis", np.array([1.0, 1.0, 0.0])), "joint 'drawer_slide'", "unit vector"),
        (lambda o: setattr(o.joints[0].limits, "lower", 2.0), "joint 'door_hinge'", "lower limit 2.0 > upper"),
        (lambda o: setattr(o.joints[0], "state", 3.0), "joint 'door_hinge'", "outside the limits"),
        (lambda o: setattr(o.joints[0], "limits", None), "joint 'door_hinge'", "needs limits"),
        (lambda o: setattr(o.joints[1], "parent", "ghost"), "joint 'drawer_slide'", "'ghost' does not exist"),
        (lambda o: setattr(o.parts[1], "name", "body"), "part 'body'", "duplicate part name"),
        (lambda o: setattr(o.parts[1], "name", "door 1"), "part 'door 1'", "identifier"),
        (lambda o: setattr(o.parts[2], "inertial", Inertial(-1.0)), "part 'drawer'", "mass must be positive"),
        (lambda o: setattr(o.parts[2], "inertial", Inertial(1.0, inertia=np.diag([1.0, 1.0, 3.0]))),
         "part 'drawer'", "triangle inequality"),
        (lambda o: setattr(o.parts[2], "inertial", Inertial(1.0, inertia=np.diag([1.0, -1.0, 1.0]))),
         "part 'drawer'", "positive definite"),
        (lambda o: setattr(o.joints[0].dynamics, "damping", -1.0), "joint 'door_hinge'", "damping must be >= 0"),
        (lambda o: [setattr(o.parts[i], "inertial", None) for i in (2, 3)], "joint 'drawer_slide'", "no mass"),
        (lambda o: o.joints[0].origin.__setitem__((slice(0, 3), slice(0, 3)), np.diag([1.0, 1.0, 2.0])),
         "joint 'door_hinge'", "not a rigid transform"),
    ],
)
def test_validation_names_the_element(mutate, element, message):
    obj = small_cabinet()
    mutate(obj)
    with pytest.raises(ModelError) as info:
        validate(obj)
    assert info.value.element == element
    assert message in str(info.value)


def test_unknown_joint_type_is_refused():
    with pytest.raises(ValueError, match="'slider' is not a valid JointType"):
        Joint("j", "slider", "a", "b")


def test_sanitize_name_makes_identifiers_unique():
    taken: set[str] = set()
    assert sanitize_name("link-0", taken) == "link_0"
    assert sanitize_name("link 0", taken) == "link_0_1"
    assert sanitize_name("0door", taken) == "_0door"


def test_differences_reports_and_tolerates():
    a, b = small_cabinet(), small_cabinet()
    assert differences(a, b, tol=0) == []
    b.joints[0].origin[0, 3] += 1e-8
    assert differences(a, b, tol=1e-6) == []
    b.joints[0].origin[0, 3] += 1e-3
    b.joints[1].dynamics.damping = 3.0
    diffs = differences(a, b)
    assert any("door_hinge" in d and "origin" in d for d in diffs)
    assert any("drawer_slide" in d and "damping" in d for d in diffs)


def test_object_json_round_trip_is_exact_and_deterministic(tmp_path):
    obj = small_cabinet()
    export(obj, tmp_path / "a", ["json"])
    back = load(tmp_path / "a" / "object.json")
    assert differences(obj, back, tol=0) == []
    assert back.joints[0].type is JointType.REVOLUTE
    assert back.metadata == obj.metadata
    export(back, tmp_path / "b", ["json"])
    written = sorted(p.relative_to(tmp_path / "a") for p in (tmp_path / "a").rglob("*"))
    assert written == sorted(p.relative_to(tmp_path / "b") for p in (tmp_path / "b").rglob("*"))
    assert Path("meshes/door.obj") in written
    for rel in written:
        if (tmp_path / "a" / rel).is_file():
            assert (tmp_path / "a" / rel).read_bytes() == (tmp_path / "b" / rel).read_bytes()


def _write_json(tmp_path, data) -> object:
    path = tmp_path / "object.json"
    path.write_text(json.dumps(data))
    return path


def test_object_json_errors_name_file_and_element(tmp_path):
    obj = small_cabinet()
    export(obj, tmp_path, ["json"])
    data = json.loads((tmp_path / "object.json").read_text())

    bad = json.loads(json.dumps(data))
    bad["joints"][0]["origin"]["translation"][1] = float("nan")
    with pytest.raises(FormatError, match=r"object.json: joint 'door_hinge': origin translation is not finite"):
        object_json.from_dict(bad, tmp_path / "object.json")

    bad = json.loads(json.dumps(data))
    bad["joints"][1]["type"] = "slider"
    with pytest.raises(FormatError, match=r"joint 'drawer_slide': unknown joint type 'slider'"):
        object_json.from_dict(bad, tmp_path / "object.json")

    bad = json.loads(json.dumps(data))
    bad["joints"][0]["limits"]["lower"] = 5.0
    with pytest.raises(FormatError, match=r"joint 'door_hinge': lower limit 5.0 > upper"):
        object_json.from_dict(bad, tmp_path / "object.json")

    (tmp_path / "meshes" / "door.obj").unlink()
    with pytest.raises(FormatError, match=r"object.json: part 'door' visual: mesh file not found"):
        load(tmp_path / "object.json")

    (tmp_path / "broken.json").write_text('{"schema": "real2code_export/object",\n  "name": }')
    with pytest.raises(FormatError, match=r"broken.json:2: malformed JSON"):
        load(tmp_path / "broken.json")


def test_failed_export_leaves_nothing(tmp_path):
    obj = small_cabinet()
    obj.joints[0].axis = np.zeros(3)  # invalid: refused before anything is written
    out = tmp_path / "out"
    with pytest.raises(ModelError):
        export(obj, out, ["json"])
    assert not out.exists()

    out.mkdir()
    (out / "keep.txt").write_text("a good file")
    with pytest.raises(RuntimeError), atomic.staged_output(out) as staging:
        (staging / "half.xml").write_text("<half")
        raise RuntimeError("writer failed")
    assert sorted(p.name for p in out.iterdir()) == ["keep.txt"]


def test_a_file_a_library_writes_itself_replaces_the_old_one_whole_or_not_at_all(tmp_path):
    target = tmp_path / "object.usda"
    target.write_text("the good file")

    def half_then_fail(path: Path):
        assert path.suffix == ".usda" and path.parent == tmp_path  # the library's own suffix
        path.write_text("half")
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        atomic.write_with(target, half_then_fail)
    assert [p.name for p in tmp_path.iterdir()] == ["object.usda"]
    assert target.read_text() == "the good file"
    atomic.write_with(target, lambda path: path.write_text("new"))
    assert [p.name for p in tmp_path.iterdir()] == ["object.usda"] and target.read_text() == "new"
    assert target.stat().st_mode & 0o777 == 0o666 & ~atomic._UMASK  # as open() makes files


def test_box_inertial_helper_is_valid():
    from real2code_export.model import validate_inertial

    validate_inertial(box_inertial([1, 2, 3], 4.0), "test")


def _arm(*joints):
    """A base (massless: the world) and one 1 kg link per joint, chained in order."""
    from real2code_export.model import ArticulatedObject, Part

    parts = [Part("base")] + [Part(j.child, inertial=box_inertial([0.1, 0.1, 0.1], 1.0))
                              for j in joints]
    return ArticulatedObject("arm", parts, list(joints))


def test_ball_and_floating_joints_are_held_at_their_origin_and_validated():
    from real2code_export.model import Joint, Limits

    free = Joint("free", "floating", "base", "torso", origin=tf.make(translation=[0, 0, 1]))
    ball = Joint("shoulder", "ball", "torso", "arm", origin=tf.make(translation=[0.2, 0, 0]))
    obj = validate(_arm(free, ball))
    assert obj.movable_joints == [] and obj.joint("shoulder").type.multi_dof
    np.testing.assert_allclose(forward_kinematics(obj)["arm"][:3, 3], [0.2, 0, 1])
    ball.limits = Limits(-1, 1)
    with pytest.raises(ModelError, match="'shoulder'.*ball joint takes no limits"):
        validate(obj)
    ball.limits, ball.cone_limit = None, -0.1
    with pytest.raises(ModelError, match="'shoulder'.*cone limit must be >= 0"):
        validate(obj)
    ball.cone_limit = 0.0  # held at its rest (MuJoCo's limited ball without a range)
    validate(obj)
    ball.cone_limit, free.cone_limit = 0.5, 0.5
    with pytest.raises(ModelError, match="'free'.*floating joint takes no cone limit"):
        validate(obj)
    free.cone_limit, ball.state = None, 0.3
    with pytest.raises(ModelError, match="'shoulder'.*ball joint has no state"):
        validate(obj)
    ball.state, ball.cone_limit, ball.type = 0.0, None, JointType.FLOATING
    with pytest.raises(ModelError, match="floating joint must hang from the root part 'base'"):
        validate(obj)


def test_mimics_are_validated_and_unusable_ones_dropped_with_a_reason():
    from real2code_export.model import Joint, Limits, Mimic
    from real2code_export.repairs import unusable_mimics

    lead = Joint("lead", "revolute", "base", "a", limits=Limits(-1, 1))
    follow = Joint("follow", "revolute", "a", "b", limits=Limits(-1, 1),
                   mimic=Mimic("lead", -2.0, 0.1))
    obj = validate(_arm(lead, follow))
    follow.mimic = Mimic("nothing")
    with pytest.raises(ModelError, match="'follow'.*mimics joint 'nothing', which does not"):
        validate(obj)
    lead.mimic, follow.mimic = Mimic("follow"), Mimic("lead")
    with pytest.raises(ModelError, match="mimics another joint itself"):
        validate(obj)
    assert [name for name, _ in unusable_mimics(obj)] == ["lead"]  # follow's leader then free
    assert lead.mimic is None and follow.mimic is not None
    validate(obj)
    other = _arm(Joint("lead", "revolute", "base", "a", limits=Limits(-1, 1)),
                 Joint("follow", "revolute", "a", "b", limits=Limits(-1, 1), mimic=Mimic("x")))
    (name, message), = unusable_mimics(other)
    assert name == "follow" and "'x' dropped (it does not exist)" in message


def test_chained_mimics_are_composed_into_one_coupling_and_cycles_left():
    """A follower of a follower is coupled to the chain's first leader with the product of
    the multipliers (q3 = 2 (-0.5 q1 + 0.1) + 0.3); a cycle is not composed (left to
    unusable_mimics and validation)."""
    from real2code_export.model import Joint, Limits, Mimic
    from real2code_export.repairs import composed_mimic_chains

    one, two, three = (Joint(f"j{k}", "revolute", "base" if k == 1 else f"p{k - 1}", f"p{k}",
                             limits=Limits(-1, 1)) for k in (1, 2, 3))
    two.mimic, three.mimic = Mimic("j1", -0.5, 0.1), Mimic("j2", 2.0, 0.3)
    obj = _arm(one, two, three)
    (name, message), = composed_mimic_chains(obj)
    assert name == "j3" and "mimics 'j2' which mimics 'j1'" in message
    assert three.mimic == Mimic("j1", -1.0, pytest.approx(0.5))
    validate(obj)
    one.mimic, two.mimic, three.mimic = Mimic("j2"), Mimic("j1"), Mimic("j2")
    assert composed_mimic_chains(obj) == []
    assert (one.mimic, two.mimic, three.mimic) == (Mimic("j2"), Mimic("j1"), Mimic("j2"))


def test_merging_fixed_joints_keeps_every_field_of_the_joints_below():
    from real2code_export.model import DriveLimits, Limits, Mimic
    from real2code_export.simplify import merge_fixed_joints

    weld = Joint("weld", "fixed", "base", "bracket", origin=tf.make(translation=[0, 0, 0.5]))
    lead = Joint("lead", "revolute", "bracket", "a", limits=Limits(-1, 1), state=0.2)
    follow = Joint("follow", "revolute", "a", "b", limits=Limits(-1, 1),
                   mimic=Mimic("lead", -2.0, 0.1))
    spin = Joint("spin", "continuous", "b", "c", drive_limits=DriveLimits(3.0, 7.0))
    merged = validate(merge_fixed_joints(validate(_arm(weld, lead, follow, spin))))
    assert [p.name for p in merged.parts] == ["base", "a", "b", "c"]
    assert merged.joint("lead").parent == "base" and merged.joint("lead").state == 0.2
    np.testing.assert_allclose(merged.joint("lead").origin[:3, 3], [0, 0, 0.5])
    assert merged.joint("follow").mimic == Mimic("lead", -2.0, 0.1)
    assert merged.joint("spin").drive_limits == DriveLimits(3.0, 7.0)


def _placements_hold(mesh: Mesh) -> bool:
    """Every placement's stretch of the mesh is its asset at its pose (Placement)."""
    for p in mesh.placements:
        moved = p.asset.transformed(p.pose)
        if not (np.allclose(mesh.vertices[p.vertex:p.vertex_end], moved.vertices, atol=1e-12)
                and np.array_equal(mesh.faces[p.face:p.face_end], p.asset.faces + p.vertex)):
            return False
    return True


def test_placements_follow_the_mesh_through_concatenate_transform_and_remainder():
    """Mesh.placed says which asset a mesh places; concatenating (with colours, which
    reorders the pieces), moving and taking the remainder keep every placement true; what
    makes a mesh otherwise drops them."""
    from real2code_export.primitives import Primitive, ShapeKind

    asset = box_mesh([0.1, 0.2, 0.3])
    turn = tf.make(tf.rpy_to_matrix([0.3, -0.2, 1.1]), [0.1, 0.2, 0.3])
    pieces = [Mesh.placed(asset, turn), Mesh.of_primitive(Primitive(ShapeKind.BOX, [0.1] * 3)),
              box_mesh([0.05] * 3), Mesh.placed(asset)]
    assert pieces[3].placements[0].asset is asset
    assert np.shares_memory(pieces[3].vertices, asset.vertices)  # not moved: kept exactly
    for colours in (None, [(1.0, 0.0, 0.0, 1.0), (0.0, 1.0, 0.0, 1.0), (0.0, 1.0, 0.0, 1.0),
                           (0.0, 0.0, 1.0, 1.0)]):
        joined = Mesh.concatenate(pieces, colours)
        assert len(joined.placements) == 2 and _placements_hold(joined)
        moved = joined.transformed(tf.make(tf.rpy_to_matrix([1.0, 0.5, -0.4]), [1.0, 2.0, 3.0]))
        assert len(moved.placements) == 2 and _placements_hold(moved)
        assert len(moved.remainder().placements) == 2 and _placements_hold(moved.remainder())
    mirrored = pieces[0].transformed(np.diag([-1.0, 1.0, 1.0, 1.0]))
    assert mirrored.placements == ()


def test_corner_bounds_are_numpys_down_the_rows_bit_for_bit():
    """The quick corners are ``min(axis=0)`` / ``max(axis=0)`` exactly, a zero's sign
    included (the .usda's extent text shows it), for float32 and float64 points."""
    rng = np.random.default_rng(0)
    values = np.array([0.0, -0.0, 1.0, -1.0, 2.5])
    for k in range(300):
        dtype = np.float32 if k % 2 else np.float64
        points = rng.choice(values[: 2 + k % 4], size=(int(rng.integers(1, 3000)), 3))
        if k % 5 == 0:
            points = rng.normal(size=points.shape)
        points = points.astype(dtype)
        low, high = corner_bounds(points)
        assert low.tobytes() == points.min(axis=0).tobytes()
        assert high.tobytes() == points.max(axis=0).tobytes()
