"""Real2Code's articulation step: boxes, the code format, its parser, the axis/edge helper,
the multi-state screw estimator."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from pipeline.joint_code import (
    ArticulationProgram,
    ChildJoint,
    CodeFormatError,
    encode_joint,
    format_boxes,
    format_program,
    joint_axis_and_position,
    line_distance,
    parse_program,
)
from pipeline.multistate import estimate_screw
from pipeline.obb import OBB, canonical, gravity_aligned_obb, minimal_obb
from real2code_export import transforms as tf

BOX = OBB(np.array([1.0, 2.0, 3.0]), np.eye(3), np.array([0.1, 0.2, 0.3]))


@pytest.mark.parametrize("idx, edge, sign", [
    (i, e, s) for i in range(3) for e in itertools.product((-1, 1), repeat=2) for s in (-1, 1)])
def test_helper_every_axis_edge_and_sign(idx, edge, sign):
    axis, pos = joint_axis_and_position(BOX, idx, edge, sign)
    expected_axis = np.zeros(3)
    expected_axis[idx] = sign
    np.testing.assert_allclose(axis, expected_axis)
    others = [i for i in range(3) if i != idx]
    expected_pos = BOX.center.copy()
    expected_pos[others[0]] += edge[0] * BOX.extent[others[0]]
    expected_pos[others[1]] += edge[1] * BOX.extent[others[1]]
    np.testing.assert_allclose(pos, expected_pos)
    # the position lies on a box edge: the hinge line touches two faces
    local = np.abs(pos - BOX.center)
    assert np.isclose(local[others], BOX.extent[others]).all()
    # encoding the absolute joint gives back the same choice
    enc = encode_joint(BOX, "hinge", axis, pos + 0.05 * axis)
    assert (enc.idx, enc.edge, enc.sign) == (idx, tuple(edge), sign)


def test_helper_on_a_rotated_box():
    r = tf.axis_angle_matrix([0, 0, 1], 0.4)
    box = OBB(np.array([0.5, 0.0, 0.2]), r, np.array([0.3, 0.01, 0.4]))
    axis, pos = joint_axis_and_position(box, 2, (1, -1), 1)
    np.testing.assert_allclose(axis, [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(pos, box.center + 0.3 * r[:, 0] - 0.01 * r[:, 1])


def test_line_distance_parallel_and_skew():
    assert line_distance([0, 0, 0], [0, 0, 1], [1, 0, 5], [0, 0, -1]) == pytest.approx(1.0)
    assert line_distance([0, 0, 0], [1, 0, 0], [0, 1, 2], [0, 1, 0]) == pytest.approx(2.0)


def test_program_text_round_trip():
    prog = ArticulationProgram(0, (
        ChildJoint(1, "hinge", 2, (1, -1), 1),
        ChildJoint(2, "slide", 0, (0, 0), -1),
        ChildJoint(3, "hinge", 1, (-1, -1), 1, parent=1),
    ))
    text = format_program(prog)
    assert parse_program(text, n_boxes=4) == prog
    boxes_text = format_boxes([BOX, BOX])
    assert boxes_text.startswith("bboxes={") and "'extent': [0.10, 0.20, 0.30]" in boxes_text


@pytest.mark.parametrize("text, line, message", [
    ("root_geom = 0\nchild_joints = [\n dict(box=1, type='hinge', idx=5, edge=[1, 1], sign=1),\n]",
     3, "idx must be one of [0, 1, 2], got 5"),
    ("root_geom = 0\nchild_joints = [\n dict(box=1, type='ball', idx=0),\n]", 3, "'hinge' or 'slide'"),
    ("root_geom = 0\nchild_joints = [dict(box=1, type='hinge', idx=0, edge=[1, 2])]", 2,
     "edge must be one of [-1, 1], got 2"),
    ("root_geom = 0\nchild_joints = [dict(box=9, type='slide', idx=0)]", 2,
     "box must be one of [0, 1, 2], got 9"),
    ("root_geom = 0\nchild_joints = [dict(box=1, type='slide', idx=os.system('x'))]", 2,
     "must be a literal"),
    ("root_geom = 0\nimport os\nchild_joints = []", 2, "expected only"),
    ("root_geom = 0\nchild_joints = [dict(box=1, type='hinge', idx=0, edge=[1, 1]", 2,
     "not valid Python"),
    ("child_joints = []", None, "missing `root_geom"),
    ("root_geom = 0\nchild_joints = [dict(box=0, type='slide', idx=0)]", 2, "is the root"),
    ("root_geom = 0\nchild_joints = [dict(box=1, type='slide', idx=0, parent=2),\n"
     " dict(box=2, type='slide', idx=0, parent=1)]", 2, "cycle"),
])
def test_malformed_output_names_the_line(text, line, message):
    with pytest.raises(CodeFormatError) as info:
        parse_program(text, n_boxes=3)
    assert info.value.line == line
    assert message in str(info.value)


def test_obb_fits_recover_a_rotated_box():
    rng = np.random.default_rng(0)
    r = tf.axis_angle_matrix([0, 0, 1], 0.6)
    extent = np.array([0.4, 0.05, 0.3])
    local = rng.uniform(-1, 1, (2000, 3)) * extent
    pts = local @ r.T + [1.0, -0.5, 0.3]
    for fit in (gravity_aligned_obb(pts), minimal_obb(pts)):
        assert fit.volume <= 8 * np.prod(extent) * 1.0001
        assert fit.contains(pts, tol=1e-6).all()
        assert np.isclose(np.linalg.det(fit.R), 1.0)
        np.testing.assert_allclose(fit.R[:, 2], [0, 0, 1], atol=1e-3)
    # a stable order: the same box rotated by 90 degrees about z gives the same canonical box
    again = gravity_aligned_obb(pts @ tf.axis_angle_matrix([0, 0, 1], np.pi / 2).T)
    np.testing.assert_allclose(np.sort(again.extent), np.sort(extent), rtol=1e-3)


def test_canonical_is_right_handed_and_sorted():
    r = tf.axis_angle_matrix(np.ones(3) / np.sqrt(3), 2 * np.pi / 3)  # cycles the axes
    box = canonical([0, 0, 0], -r, [1, 2, 3])
    np.testing.assert_allclose(box.R, np.eye(3), atol=1e-12)
    assert np.isclose(np.linalg.det(box.R), 1.0)


def _poses_about(axis, point, angles, start):
    out = []
    for a in angles:
        m = np.eye(4)
        m[:3, :3] = tf.axis_angle_matrix(axis, a)
        m[:3, 3] = point - m[:3, :3] @ point
        out.append(m @ start)
    return out


def test_multistate_recovers_a_hinge_exactly():
    axis = np.array([0.2, -0.3, 0.9]) / np.linalg.norm([0.2, -0.3, 0.9])
    point = np.array([0.4, 0.1, -0.2])
    start = tf.make(tf.rpy_to_matrix([0.1, 0.2, 0.3]), [0.5, 0.5, 0.5])
    est = estimate_screw(_poses_about(axis, point, [0.0, 0.3, 1.1], start))
    assert est.type == "revolute"
    np.testing.assert_allclose(est.axis, axis, atol=1e-10)
    assert line_distance(est.point, est.axis, point, axis) < 1e-10
    np.testing.assert_allclose(est.values, [0.0, 0.3, 1.1], atol=1e-10)
    assert est.residual < 1e-10


def test_multistate_recovers_a_slide_and_tolerates_noise():
    axis = np.array([1.0, 0.5, 0.0]) / np.linalg.norm([1.0, 0.5, 0.0])
    start = tf.make(np.eye(3), [0.1, 0.2, 0.3])
    poses = [tf.make(None, axis * d) @ start for d in (0.0, 0.1, 0.25)]
    est = estimate_screw(poses)
    assert est.type == "prismatic"
    np.testing.assert_allclose(est.axis, axis, atol=1e-12)
    np.testing.assert_allclose(est.values, [0.0, 0.1, 0.25], atol=1e-12)

    rng = np.random.default_rng(1)
    hinge = np.array([0.0, 0.0, 1.0])
    noisy = []
    for p in _poses_about(hinge, np.array([0.3, 0.0, 0.0]), [0.0, 0.5, 0.9, 1.3], start):
        noise = tf.make(tf.axis_angle_matrix(rng.normal(size=3), 2e-3), rng.normal(0, 1e-3, 3))
        noisy.append(noise @ p)
    est = estimate_screw(noisy)
    assert est.type == "revolute"
    assert np.degrees(np.arccos(min(1.0, abs(est.axis @ hinge)))) < 0.5
    assert line_distance(est.point, est.axis, [0.3, 0, 0], hinge) < 0.01
    assert est.residual < 0.01
