"""The stricter joint score: extra parts and joints, and wrong axes, lower the precision and
recall of movable joints, where the per-joint figures see only each true joint's match."""

from __future__ import annotations

import copy

import numpy as np

from pipeline.predictors.evaluate import Scores, score_object
from pipeline.procedural import generate
from real2code_export.model import Joint, JointType, Limits, Part


def _with_extra_door(obj):
    """``obj`` and one more part, a copy of its first child shifted aside, on a hinge."""
    out = copy.deepcopy(obj)
    root = out.root.name
    child = out.part(out.movable_joints[0].child)
    away = np.eye(4)
    away[2, 3] = 5.0  # far above every part
    shifted = child.visual.transformed(away)
    out.parts.append(Part("spurious", visual=shifted))
    out.joints.append(Joint("spurious_joint", JointType.REVOLUTE, root, "spurious",
                            limits=Limits(0.0, 1.0)))
    return out


def test_precision_and_recall_count_extra_and_wrong_joints():
    truth = generate("storage_furniture", 4, 1)
    n = len(truth.movable_joints)
    exact = Scores()
    score_object(truth, np.eye(4), truth, exact)
    row = next(iter(exact.table().values()))
    assert row["joint_precision"] == 1.0 and row["joint_recall"] == 1.0
    assert row["predicted_joints"] == n

    extra = Scores()
    score_object(truth, np.eye(4), _with_extra_door(truth), extra)
    row = next(iter(extra.table().values()))
    assert row["type_accuracy"] == 1.0  # the per-joint figures do not see the extra joint
    assert row["joint_precision"] == n / (n + 1) and row["joint_recall"] == 1.0

    turned = copy.deepcopy(truth)
    j = turned.movable_joints[0]
    j.axis = np.cross(j.axis, [0.3, 0.5, 0.8])  # 90 degrees off
    j.axis = j.axis / np.linalg.norm(j.axis)
    wrong = Scores()
    score_object(truth, np.eye(4), turned, wrong)
    row = next(iter(wrong.table().values()))
    assert row["joint_precision"] == (n - 1) / n == row["joint_recall"]


def test_a_piece_of_the_carcass_is_not_credited_with_a_drawers_joint():
    """A predicted part made of the carcass's surface nearest a moving part, on that part's
    true joint: its centre lies near the part's, but none of it is the part, so the part is
    matched to nothing and its joint counts as missed (the score matches by surfaces)."""
    from real2code_export.model import Mesh, forward_kinematics

    truth = generate("storage_furniture", 4, 1)
    n = len(truth.movable_joints)
    stand_in = copy.deepcopy(truth)
    poses = forward_kinematics(stand_in, stand_in.observed_configuration(), None)
    child = stand_in.part(stand_in.movable_joints[0].child)
    carcass = stand_in.root.visual.transformed(poses[stand_in.root.name])
    centre = child.visual.transformed(poses[child.name]).vertices.mean(axis=0)
    face_centres = carcass.vertices[carcass.faces].mean(axis=1)
    near = np.argsort(np.linalg.norm(face_centres - centre, axis=1))[:max(4, len(carcass.faces) // 5)]
    piece = Mesh(carcass.vertices, carcass.faces[near])
    child.visual = piece.transformed(np.linalg.inv(poses[child.name]))
    scores = Scores()
    match = score_object(truth, np.eye(4), stand_in, scores)
    assert child.name not in match or match[child.name] != child.name
    row = next(iter(scores.table().values()))
    assert row["joint_recall"] == (n - 1) / n and row["joint_precision"] == (n - 1) / n
