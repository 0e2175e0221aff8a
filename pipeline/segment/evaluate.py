"""How well a segmentation matches the ground truth, over all views at once: predicted
labels matched one to one to true parts by an optimal assignment on their IoU."""

from __future__ import annotations

import numpy as np

from real2code_export.errors import InputError


def matched_part_iou(predicted: list[np.ndarray], truth: list[np.ndarray],
                     ) -> tuple[float, dict[int, float]]:
    """Mean IoU over the true parts (labels > 0 of ``truth``) and each one's IoU with the
    predicted label assigned to it (0 when none is); pixels pooled over every view."""
    from scipy.optimize import linear_sum_assignment

    p = np.concatenate([a.ravel() for a in predicted]).astype(np.int64)
    t = np.concatenate([a.ravel() for a in truth]).astype(np.int64)
    t_labels = [k for k in np.unique(t) if k > 0]
    p_labels = [k for k in np.unique(p) if k > 0]
    if not t_labels:
        raise InputError("the ground truth has no parts")
    if not p_labels:
        return 0.0, dict.fromkeys(map(int, t_labels), 0.0)
    pairs = np.zeros((max(t_labels) + 1, max(p_labels) + 1))
    np.add.at(pairs, (t, p), 1)
    t_area, p_area = pairs.sum(1), pairs.sum(0)
    iou = np.zeros((len(t_labels), len(p_labels)))
    for i, a in enumerate(t_labels):
        for j, b in enumerate(p_labels):
            inter = pairs[a, b]
            iou[i, j] = inter / (t_area[a] + p_area[b] - inter)
    rows, cols = linear_sum_assignment(-iou)
    per_part = dict.fromkeys(map(int, t_labels), 0.0)
    for r, c in zip(rows, cols, strict=True):
        per_part[int(t_labels[r])] = float(iou[r, c])
    return float(np.mean(list(per_part.values()))), per_part
