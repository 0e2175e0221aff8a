"""Closed state and range of a predicted joint, from the boxes.

Real2Code predicts a joint's type, axis and position and nothing else. Exports need q = 0
(the door shut, the drawer in) and a range. The observed opening is the turn or slide that
brings the child's box back flush with its parent's; the range is found by sweeping the
joint open until the child's box runs into its parent's, capped by a typical bound for the
joint kind when nothing stops it.
"""

from __future__ import annotations

import numpy as np

from real2code_export.transforms import axis_angle_matrix

from .obb import OBB

# Typical upper bounds when nothing stops the sweep: cabinet doors open ~100 degrees,
# flaps, lids and screens about 90; drawers pull out to ~80 % of their depth.
VERTICAL_HINGE_BOUND = np.radians(100.0)
HORIZONTAL_HINGE_BOUND = np.radians(90.0)
SLIDE_FRACTION = 0.8
SWEEP_STEP = np.radians(1.0)


def box_surface_distance(box: OBB, point: np.ndarray) -> float:
    """Distance from a point to the box surface (negative inside)."""
    local = np.abs((point - box.center) @ box.R) - box.extent
    outside = np.linalg.norm(np.maximum(local, 0.0))
    return float(outside if outside > 0 else local.max())


def rotated_box(box: OBB, axis: np.ndarray, point: np.ndarray, angle: float) -> OBB:
    r = axis_angle_matrix(axis, angle)
    return OBB(r @ (box.center - point) + point, r @ box.R, box.extent)


def flush_score(parent: OBB, child: OBB) -> float:
    """How far ``child`` is from lying flush against a face of ``parent`` (m): the gap to
    the nearest face plus how far it overhangs that face's edges. 0 for a shut door."""
    c = parent.R.T @ (child.center - parent.center)
    e = np.abs(parent.R.T @ child.R) @ child.extent
    gaps = np.abs(c) - parent.extent - e
    overhang = np.maximum(0.0, np.abs(c) + e - parent.extent)
    best = np.inf
    for k in range(3):
        others = [j for j in range(3) if j != k]
        best = min(best, abs(gaps[k]) + float(overhang[others].sum()))
    return best


def hinge_opening(parent: OBB, child: OBB, axis: np.ndarray, point: np.ndarray) -> float:
    """The observed opening angle about +axis (positive: open): among the turns that
    realign the boxes (90 degrees apart), the one that leaves the child flush against a
    face of its parent; between equally flush ones, the smaller opening."""
    idx = int(np.argmax(np.abs(child.R.T @ axis)))
    u = child.R[:, [i for i in range(3) if i != idx][0]]
    scale = float(np.linalg.norm(child.extent))
    best, best_score = 0.0, np.inf
    for k in range(3):
        d = parent.R[:, k]
        if abs(d @ axis) > 0.5:
            continue
        for s in (1.0, -1.0):
            target = s * d
            angle = float(np.arctan2(np.cross(u, target) @ axis, u @ target))
            closed = rotated_box(child, axis, point, angle)
            # a small preference for smaller turns breaks ties between flush candidates
            score = flush_score(parent, closed) / scale + 0.01 * abs(angle)
            if score < best_score:
                best, best_score = angle, score
    return -best


def slide_opening(parent: OBB, child: OBB, axis: np.ndarray) -> float:
    """How far the child sticks out of its parent along +axis (its front face past the
    parent's), which is the observed opening of a drawer; 0 when flush or inside."""
    child_front = child.center @ axis + np.abs(child.R.T @ axis) @ child.extent
    parent_front = parent.center @ axis + np.abs(parent.R.T @ axis) @ parent.extent
    return float(max(0.0, child_front - parent_front))


def boxes_overlap(a: OBB, b: OBB, tolerance: float = 0.0) -> bool:
    """Separating-axis test: True when the boxes interpenetrate by more than ``tolerance``."""
    axes = [a.R[:, i] for i in range(3)] + [b.R[:, i] for i in range(3)]
    axes += [np.cross(a.R[:, i], b.R[:, j]) for i in range(3) for j in range(3)]
    d = b.center - a.center
    for ax in axes:
        n = np.linalg.norm(ax)
        if n < 1e-9:
            continue
        ax = ax / n
        ra = np.abs(a.R.T @ ax) @ a.extent
        rb = np.abs(b.R.T @ ax) @ b.extent
        if abs(d @ ax) > ra + rb - tolerance:
            return False
    return True


def hinge_upper(parent: OBB, closed_child: OBB, axis: np.ndarray, point: np.ndarray,
                observed: float) -> float:
    """Sweep the closed child open about (axis, point) until it runs into the parent; cap
    at the typical bound; never below the observed opening."""
    vertical = abs(axis[2]) > 0.7
    bound = VERTICAL_HINGE_BOUND if vertical else HORIZONTAL_HINGE_BOUND
    tolerance = 0.5 * float(closed_child.extent.min())
    angle = SWEEP_STEP
    limit = max(bound, observed)
    while angle <= limit:
        if angle > observed and boxes_overlap(parent, rotated_box(closed_child, axis, point, angle),
                                              tolerance):
            return max(observed, angle - SWEEP_STEP)
        angle += SWEEP_STEP
    return float(limit)


def slide_upper(closed_child: OBB, axis: np.ndarray, observed: float) -> float:
    depth = 2.0 * float(np.abs(closed_child.R.T @ axis) @ closed_child.extent)
    return max(observed, SLIDE_FRACTION * depth)
