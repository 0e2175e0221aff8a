"""Box features for the learned joint predictor (numpy only, shared by training and use).

Each box becomes one token. Besides its own shape (extent sorted by the canonical axes,
in units of the object's size) it carries its relation to the largest box, the usual root:
its centre and that box's axes seen from its own frame (which also says how well its axes
line up with that box), and how far each of its twelve candidate hinge lines (3 axes x 4 edges) lies
from that box's surface. The relations make the task's symmetries explicit, so a small
network learns them from a few thousand procedural objects.
"""

from __future__ import annotations

import numpy as np

from ..joint_code import joint_axis_and_position
from ..obb import OBB

EDGES = ((-1, -1), (-1, 1), (1, -1), (1, 1))
N_FEATURES = 3 + 3 + 9 + 3 + 12 + 3 + 1


def _surface_distance(box: OBB, points: np.ndarray) -> np.ndarray:
    local = np.abs((points - box.center) @ box.R) - box.extent
    outside = np.linalg.norm(np.maximum(local, 0.0), axis=-1)
    return np.where(outside > 0, outside, local.max(axis=-1))


def box_features(boxes: list[OBB]) -> np.ndarray:
    """(n_boxes, N_FEATURES) float32 features; rotation about z and shifts leave the
    box-relative features unchanged up to the canonical axis order."""
    corners = np.concatenate([b.corners() for b in boxes])
    center = (corners.min(axis=0) + corners.max(axis=0)) / 2
    scale = float(np.linalg.norm(corners.max(axis=0) - corners.min(axis=0))) or 1.0
    anchor = boxes[int(np.argmax([b.volume for b in boxes]))]
    rows = []
    for b in boxes:
        rel_anchor = (anchor.center - b.center) @ b.R / scale  # anchor centre, own frame
        anchor_axes = (b.R.T @ anchor.R).ravel()  # anchor axes, own frame
        hinge = []
        for idx in range(3):
            pts = np.array([joint_axis_and_position(b, idx, e, 1)[1] for e in EDGES])
            hinge.extend(_surface_distance(anchor, pts) / scale)
        up = b.R[2]  # world z in the box frame: which box axis is vertical
        is_anchor = 1.0 if b is anchor else 0.0
        rows.append(np.concatenate([
            (b.center - center) @ b.R / scale, b.extent / scale, anchor_axes, rel_anchor,
            hinge, up, [is_anchor],
        ]))
    feats = np.asarray(rows, dtype=np.float32)
    feats[:, 3:6] *= 4.0  # extents are small next to the other features
    return feats
