"""Oriented bounding boxes (OBBs): the abstraction Real2Code hands to its joint predictor.

An :class:`OBB` is a centre, a rotation whose columns are the box axes, and half-lengths
along them. Two fits: the paper's gravity-aware tight box (one axis held to a world axis,
the other two from a 2-D fit in the plane across it, the smallest volume over the three
world axes) and a general minimal-volume box (trimesh). Axes come out in a stable order and
sign (:func:`canonical`), so the same part gives the same box text for the predictor.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class OBB:
    center: np.ndarray  # (3,)
    R: np.ndarray  # (3, 3), columns are the box axes, right-handed
    extent: np.ndarray  # (3,) half-lengths along the columns of R

    @property
    def volume(self) -> float:
        return float(8.0 * np.prod(self.extent))

    @property
    def diagonal(self) -> float:
        return float(2.0 * np.linalg.norm(self.extent))

    def corners(self) -> np.ndarray:
        signs = np.array(list(itertools.product((-1, 1), repeat=3)), dtype=float)
        return self.center + (signs * self.extent) @ self.R.T

    def transformed(self, transform: np.ndarray) -> OBB:
        r = transform[:3, :3]
        return OBB(r @ self.center + transform[:3, 3], r @ self.R, self.extent.copy())

    def contains(self, points: np.ndarray, tol: float = 1e-9) -> np.ndarray:
        local = (np.asarray(points) - self.center) @ self.R
        return np.all(np.abs(local) <= self.extent + tol, axis=-1)


def canonical(center, rotation, extent) -> OBB:
    """The same box with its axes ordered and signed stably: the axis closest to world x
    first, then y, then z, each pointing along the positive world axis it matches; if that
    makes the frame left-handed, the least aligned axis is flipped."""
    rotation = np.asarray(rotation, float)
    extent = np.asarray(extent, float)
    best = max(itertools.permutations(range(3)),
               key=lambda p: sum(abs(rotation[i, p[i]]) for i in range(3)))
    r = rotation[:, best].copy()
    e = extent[list(best)].copy()
    for i in range(3):
        if r[i, i] < 0:
            r[:, i] *= -1
    if np.linalg.det(r) < 0:
        weakest = int(np.argmin(np.abs(np.diag(r))))
        r[:, weakest] *= -1
    return OBB(np.asarray(center, float).copy(), r, e)


def _points(points) -> np.ndarray:
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    if len(pts) < 4 or not np.all(np.isfinite(pts)):
        raise ValueError(f"need at least 4 finite points to fit a box, got {len(pts)}")
    return pts


def gravity_aligned_obb(points, up_axes: tuple[int, ...] = (0, 1, 2)) -> OBB:
    """The paper's gravity-aware tight box: one box axis held to a world axis, the other two
    from the minimum-area rectangle of the points projected on the plane across it; the
    smallest volume over the world axes in ``up_axes`` (``(2,)`` holds z only)."""
    import trimesh.bounds

    pts = _points(points)
    best: OBB | None = None
    for k in up_axes:
        plane = [i for i in range(3) if i != k]
        flat = pts[:, plane]
        try:
            to_origin, size = trimesh.bounds.oriented_bounds_2D(flat)
        except Exception:  # degenerate (collinear) projection: axis-aligned in the plane
            to_origin, size = np.eye(3), np.ptp(flat, axis=0)
            to_origin[:2, 2] = -(flat.min(axis=0) + flat.max(axis=0)) / 2
        rot2 = to_origin[:2, :2].T  # columns: rectangle axes in plane coordinates
        center2 = -rot2 @ to_origin[:2, 2]
        r = np.zeros((3, 3))
        r[plane, 0] = rot2[:, 0]
        r[plane, 1] = rot2[:, 1]
        r[k, 2] = 1.0
        if np.linalg.det(r) < 0:
            r[:, 1] *= -1
        lo, hi = pts[:, k].min(), pts[:, k].max()
        center = np.zeros(3)
        center[plane] = center2
        center[k] = (lo + hi) / 2
        extent = np.array([size[0] / 2, size[1] / 2, (hi - lo) / 2])
        box = canonical(center, r, extent)
        if best is None or box.volume < best.volume - 1e-15:
            best = box
    assert best is not None
    return best


def minimal_obb(points) -> OBB:
    """A general minimal-volume box (trimesh's ``oriented_bounds``), canonicalised."""
    import trimesh.bounds

    pts = _points(points)
    to_origin, extents = trimesh.bounds.oriented_bounds(pts, angle_digits=3)
    from_origin = np.linalg.inv(to_origin)
    return canonical(from_origin[:3, 3], from_origin[:3, :3], np.asarray(extents) / 2)


def part_obb(points, tolerance: float = 0.02) -> OBB:
    """The box a part is summarised by: the gravity-aware box when it is tight (within
    ``tolerance`` of the minimal volume), else the minimal box. The gravity-aware box keeps
    the axes of upright parts stable, but cannot follow a lid or a screen tilted about a
    hinge that is not along a world axis; the minimal box can."""
    gravity = gravity_aligned_obb(points)
    minimal = minimal_obb(points)
    return gravity if gravity.volume <= (1.0 + tolerance) * minimal.volume else minimal


def frame_aligned_obb(points, frame: np.ndarray, hold: str = "all") -> OBB:
    """A box in the frame whose columns are ``frame``'s axes: ``hold="all"`` the points'
    bounding box along all three axes; ``hold="one"`` one of them held, the other two from
    the minimum-area rectangle across it (the gravity-aware fit, in this frame)."""
    pts = _points(points)
    frame = np.asarray(frame, float)
    local = pts @ frame
    if hold == "all":
        lo, hi = local.min(axis=0), local.max(axis=0)
        return canonical(frame @ ((lo + hi) / 2), frame, (hi - lo) / 2)
    if hold != "one":
        raise ValueError(f"hold must be 'all' or 'one', got {hold!r}")
    box = gravity_aligned_obb(local)
    return canonical(frame @ box.center, frame @ box.R, box.extent)


def aligned_boxes(clouds: list, tolerance: float = 0.1) -> list[OBB]:
    """Every part's :func:`part_obb`, then each part other than the largest refitted in the
    largest part's frame where that costs little volume: all three axes held when the box
    grows by at most ``tolerance``, else one axis held (a door swung about a hinge parallel
    to the carcass's edges), else the part's own box.

    Furniture is built square: drawers slide along the carcass's depth, hinges run along
    its edges. A part segmented with a few wrong points at its border gets an own box
    turned by a few degrees, and the joint read off that box inherits the turn; in the
    carcass's frame it does not. Boxes of exact parts are unchanged (the frame fit is then
    no larger than the own one)."""
    boxes = [part_obb(c) for c in clouds]
    if len(boxes) < 2:
        return boxes
    root = int(np.argmax([b.volume for b in boxes]))
    frame = boxes[root].R
    out = []
    for i, (cloud, own) in enumerate(zip(clouds, boxes, strict=True)):
        if i == root:
            out.append(own)
            continue
        limit = (1.0 + tolerance) * own.volume
        square = frame_aligned_obb(cloud, frame, "all")
        if square.volume <= limit:
            out.append(square)
            continue
        held = frame_aligned_obb(cloud, frame, "one")
        out.append(held if held.volume <= limit else own)
    return out
