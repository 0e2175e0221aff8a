"""From an articulated object (or part meshes) to the predictor's view: one box per part at
the observed state, and the ground-truth program that labels those boxes."""

from __future__ import annotations

import numpy as np

from real2code_export.errors import InputError
from real2code_export.kinematics import world_joints
from real2code_export.model import ArticulatedObject, JointType, Mesh

from .joint_code import ArticulationProgram, ChildJoint, encode_joint
from .obb import OBB, part_obb


def part_boxes(meshes: dict[str, Mesh], fit=part_obb) -> dict[str, OBB]:
    return {name: fit(m.vertices) for name, m in meshes.items()}


def ground_truth_program(obj: ArticulatedObject, order: list[str], boxes: list[OBB],
                         q: dict[str, float] | None = None,
                         base: np.ndarray | None = None) -> ArticulationProgram:
    """The program that describes ``obj``'s joints on ``boxes`` (one per part in ``order``).

    Parts joined by fixed joints are expected to have been merged by the caller; a movable
    joint's parent is its parent part's box.
    """
    index = {name: i for i, name in enumerate(order)}
    axes = world_joints(obj, q, base)
    root = index[obj.root.name]
    joints = []
    for j in obj.joints:
        if j.type is JointType.FIXED:
            raise InputError(f"joint {j.name!r} is fixed: merge its part into its parent first")
        axis, point = axes[j.name]
        kind = "slide" if j.type is JointType.PRISMATIC else "hinge"
        enc = encode_joint(boxes[index[j.child]], kind, axis, point)
        parent = index[j.parent]
        joints.append(ChildJoint(index[j.child], kind, enc.idx, enc.edge, enc.sign,
                                 None if parent == root else parent))
    joints.sort(key=lambda c: c.box)
    return ArticulationProgram(root, tuple(joints))
