"""The geometric baseline: joints from the boxes by rules, no learning.

The root is the largest box. A child box turned relative to its parent is a door on a
hinge: the hinge axis is the child's axis still parallel to a parent axis (a rotation keeps
its own axis), the hinge edge the one that stays on the parent's surface, the sign the one
that makes the observed opening positive. A child aligned with its parent and sticking out
of it is a drawer sliding along the axis it sticks out of. A child aligned and inside is
ambiguous from boxes alone: thin parts are taken as doors, deep ones as drawers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from real2code_export.errors import InputError

from ..closing import box_surface_distance, hinge_opening
from ..joint_code import ArticulationProgram, ChildJoint, joint_axis_and_position
from ..obb import OBB

ALIGNED_DEG = 3.0


def _alignment(parent: OBB, child: OBB) -> np.ndarray:
    """|cos| between every child axis (rows) and parent axis (columns)."""
    return np.abs(child.R.T @ parent.R)


@dataclass
class GeometricPredictor:
    name: str = "geometric"
    thin_ratio: float = 0.15  # thickness / width below which an aligned part is a door

    def predict(self, boxes: list[OBB]) -> ArticulationProgram:
        if not boxes:
            raise InputError("no boxes")
        root = int(np.argmax([b.volume for b in boxes]))
        joints = [self._child(boxes[root], boxes[i], i) for i in range(len(boxes)) if i != root]
        return ArticulationProgram(root, tuple(joints))

    def _child(self, parent: OBB, child: OBB, index: int) -> ChildJoint:
        align = _alignment(parent, child)
        best_cos = align.max(axis=1)
        aligned = bool(np.all(best_cos > np.cos(np.radians(ALIGNED_DEG))))
        if not aligned:
            return self._hinge(parent, child, index, idx=int(np.argmax(best_cos)))
        # protrusion of the child beyond the parent along each parent axis, both directions
        rel = (child.center - parent.center) @ parent.R
        child_ext = np.abs(parent.R.T @ child.R) @ child.extent
        out_pos = rel + child_ext - parent.extent
        out_neg = -rel + child_ext - parent.extent
        protrusion = np.maximum(out_pos, out_neg)
        k = int(np.argmax(protrusion))
        front_sign = 1.0 if out_pos[k] >= out_neg[k] else -1.0
        direction = front_sign * parent.R[:, k]
        idx = int(np.argmax(np.abs(child.R.T @ direction)))
        sign = 1 if child.R[:, idx] @ direction > 0 else -1
        thickness = child.extent[idx]
        width = np.delete(child.extent, idx).max()
        if protrusion[k] > 0.5 * thickness or thickness > self.thin_ratio * width:
            return ChildJoint(index, "slide", idx, (0, 0), sign)
        # a closed, thin part: a door; hinge along its longer in-plane axis, on the edge
        # nearest the parent's side (no information says which: take the first)
        others = [i for i in range(3) if i != idx]
        hinge_idx = max(others, key=lambda i: child.extent[i])
        return self._hinge(parent, child, index, idx=hinge_idx)

    def _hinge(self, parent: OBB, child: OBB, index: int, idx: int) -> ChildJoint:
        # The hinge edge stays on the parent's surface; the free edge swings away from it.
        edges = [(a, b) for a in (-1, 1) for b in (-1, 1)]
        distances = []
        for e in edges:
            _, p = joint_axis_and_position(child, idx, e, 1)
            distances.append(abs(box_surface_distance(parent, p)))
        edge = edges[int(np.argmin(distances))]
        axis, point = joint_axis_and_position(child, idx, edge, 1)
        # the sign that makes the observed opening positive
        sign = 1 if hinge_opening(parent, child, axis, point) >= 0 else -1
        return ChildJoint(index, "hinge", idx, edge, sign)
