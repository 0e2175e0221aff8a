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

from real2code_export.errors import InputError


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
        raise InputError(f"need at least 4 finite points to fit a box, got {len(pts)}")
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
        raise InputError(f"hold must be 'all' or 'one', got {hold!r}")
    box = gravity_aligned_obb(local)
    return canonical(frame @ box.center, frame @ box.R, box.extent)


@dataclass(frozen=True, eq=False)
class Surface:
    """What a part's frame is read from: the unit normals and weights of its points that
    lie on a locally flat piece of surface."""

    normals: np.ndarray  # (M, 3)
    weights: np.ndarray  # (M,)

    @classmethod
    def of(cls, part, neighbours: int = 8, flatness: float = 0.05,
           agreement: float = 0.9) -> Surface:
        """From measured points with their normals (a ``(points, normals)`` pair, normals
        scaled by how well the views agree, as :func:`pipeline.fuse.oriented_part_clouds`
        gives them: those of at least ``agreement`` are kept), else from a mesh's vertices
        or an (N, 3) array: each point's normal is then the least direction of its
        ``neighbours`` nearest points (PCA), kept where the neighbourhood is flat (least
        over middle variance at most ``flatness``; edges, corners and noise are not).
        Points, not faces: a segment-only mesh's faces (an alpha shape) bridge between
        panels and face anywhere, while its vertices are the measured points. Measured
        normals where there are some: the neighbours of a point on a panel thinner than
        two point spacings lie on both its faces, and no plane fits them."""
        from scipy.spatial import cKDTree

        if isinstance(part, tuple):
            normals = np.asarray(part[1], float).reshape(-1, 3)
            length = np.linalg.norm(normals, axis=1)
            keep = length >= agreement
            return cls(normals[keep] / length[keep, None], np.ones(int(keep.sum())))
        pts = _points(part.vertices if hasattr(part, "vertices") else part)
        if len(pts) <= neighbours:
            return cls(np.zeros((0, 3)), np.zeros(0))
        _, near = cKDTree(pts).query(pts, neighbours + 1)
        local = pts[near] - pts[near].mean(axis=1, keepdims=True)
        values, vectors = np.linalg.eigh(np.einsum("nki,nkj->nij", local, local))
        flat = values[:, 0] <= flatness * np.maximum(values[:, 1], 1e-30)
        return cls(vectors[flat, :, 0], np.ones(int(flat.sum())))


SQUARE_DEG = 4.0  # a face is square to a frame when its normal is this close to an axis


def alignment(surface: Surface, frame: np.ndarray, sigma_deg: float = SQUARE_DEG) -> float:
    """How square ``surface`` is to ``frame``'s axes: the weighted mean over its flat points
    of exp(-a^2 / 2 sigma^2), a the angle from the point's normal to the nearest axis (1 for
    a box in that frame; NaN with no flat point)."""
    if len(surface.weights) == 0 or surface.weights.sum() <= 0:
        return float("nan")
    cos = np.clip(np.abs(surface.normals @ frame).max(axis=1), 0.0, 1.0)
    angle = np.arccos(cos)
    score = np.exp(-0.5 * (angle / np.radians(sigma_deg)) ** 2)
    return float(score @ surface.weights / surface.weights.sum())


def _turned(frame: np.ndarray, axis: int, deg: float) -> np.ndarray:
    """``frame`` turned by ``deg`` about its own column ``axis``."""
    a = np.radians(deg)
    i, j = [k for k in range(3) if k != axis]
    out = frame.copy()
    out[:, i] = np.cos(a) * frame[:, i] + np.sin(a) * frame[:, j]
    out[:, j] = -np.sin(a) * frame[:, i] + np.cos(a) * frame[:, j]
    return out


def best_turn(surface: Surface, frame: np.ndarray, axis: int, span_deg: float = 45.0,
              min_gain: float = 0.01) -> tuple[float, np.ndarray]:
    """The turn of ``frame`` about its column ``axis`` (within +-``span_deg``) that squares
    ``surface`` best: a 1-degree scan, then a golden-section search to 0.01 degree; no turn
    unless it raises the alignment by ``min_gain`` (the normals of an exact box scatter a
    little at its edges, and must not move its frame)."""
    scan = np.arange(-span_deg, span_deg + 1e-9, 1.0)
    scores = [alignment(surface, _turned(frame, axis, d)) for d in scan]
    k = int(np.argmax(scores))
    lo, hi = scan[k] - 1.0, scan[k] + 1.0
    g = (np.sqrt(5) - 1) / 2
    a, b = hi - g * (hi - lo), lo + g * (hi - lo)
    fa, fb = (alignment(surface, _turned(frame, axis, d)) for d in (a, b))
    while hi - lo > 0.01:
        if fa >= fb:
            hi, b, fb = b, a, fa
            a = hi - g * (hi - lo)
            fa = alignment(surface, _turned(frame, axis, a))
        else:
            lo, a, fa = a, b, fb
            b = lo + g * (hi - lo)
            fb = alignment(surface, _turned(frame, axis, b))
    best = (lo + hi) / 2
    if alignment(surface, frame) >= alignment(surface, _turned(frame, axis, best)) - min_gain:
        return 0.0, frame.copy()
    return best, _turned(frame, axis, best)


def fitted_frame(surface: Surface, frame: np.ndarray, span_deg: float = 10.0,
                 min_gain: float = 0.01, rounds: int = 3) -> np.ndarray:
    """``frame`` turned onto its faces all at once: each axis to the mean of the normals
    within ``span_deg`` of it (sign-matched), the rotation nearest those three (orthogonal
    Procrustes), repeated ``rounds`` times; kept only where it raises the alignment by
    ``min_gain`` and turns no axis past ``span_deg``. A frame tilted a little about two axes
    at once, on noisy normals, gains too little from either turn alone (:func:`best_turn`
    keeps none) but enough from both: on phone-LiDAR views a refrigerator's body, no box
    (its smallest box tilted 2 degrees), gained 0.007 and 0.009 from its two turns, 0.016
    from the fit."""
    fit = frame.copy()
    for _ in range(rounds):
        sums = []
        for a in range(3):
            cos = surface.normals @ fit[:, a]
            near = np.abs(cos) >= np.cos(np.radians(span_deg))
            sums.append((surface.weights[near, None] * surface.normals[near]
                         * np.sign(cos[near])[:, None]).sum(axis=0))
        target = np.stack(sums, axis=1)
        if np.linalg.matrix_rank(target) < 3:
            return frame.copy()
        u, _, vt = np.linalg.svd(target)
        fit = u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))]) @ vt
    turn = np.degrees(np.arccos(np.clip(np.abs(np.sum(fit * frame, axis=0)), 0.0, 1.0)))
    if turn.max() > span_deg or \
            alignment(surface, fit) < alignment(surface, frame) + min_gain:
        return frame.copy()
    return fit


MIN_SQUARE = 0.4  # below this alignment in every frame a part is not boxy: volumes decide
SQUARE_MARGIN = 0.05  # the carcass's frame wins unless the part's own is this much squarer


def aligned_boxes(parts: list, tolerance: float = 0.1, observed: list | None = None,
                  ) -> list[OBB]:
    """Boxes for parts cut from a scan by an imperfect segmentation: furniture is built
    square, so each part's box is taken in the largest part's frame, or in that frame
    turned about one of its axes (a door swung about a hinge parallel to the carcass's
    edges, a lid about its hinge), when that is as square to the part's surface as its own
    box is; else the part keeps its own box (:func:`part_obb`).

    Why: a part segmented with some wrong points at its border, or seen only in part, gets
    an own box turned by a few degrees, and the joint read off it inherits the turn, while
    its faces (a drawer's front, a door's panel) still face the way the part does.

    ``parts`` are meshes or point clouds; each box fits their points. The normals of
    ``observed`` (what each part was measured at: points, or ``(points, normals)`` pairs;
    default the parts' own points) decide the frames (:func:`alignment`, within
    ``SQUARE_MARGIN``): measured points where there are some, since a completed mesh is
    marched on a grid in its part's own box and its faces follow that grid, right or wrong.
    For a part with too few points to tell, volumes decide (the carcass's frame when the box
    grows by at most ``tolerance``, else one axis held). The largest part's own frame is
    first squared to its faces the same way (a turn of at most 10 degrees about each axis),
    then to all of them at once (:func:`fitted_frame`), where the frame so turned is boxy
    (``MIN_SQUARE``): a carcass square in cross-section has a smallest box free to turn
    about its long axis (on a phone-LiDAR ring in a room a table's turned 7.4 degrees; its
    faces scored 0.27 in it, 0.66 turned back), and one of its drawers then read as a hinge.
    Boxes of exact, square parts are unchanged."""
    points = [_points(p.vertices if hasattr(p, "vertices") else p) for p in parts]
    surfaces = [Surface.of(p) for p in (observed if observed is not None else points)]
    boxes = [part_obb(p) for p in points]
    if len(boxes) < 2:
        return boxes
    root = int(np.argmax([b.volume for b in boxes]))
    frame = turned = boxes[root].R
    for axis in range(3):
        turned = best_turn(surfaces[root], turned, axis, span_deg=10.0)[1]
    turned = fitted_frame(surfaces[root], turned)
    # judged boxy once turned: a carcass whose cross-section is square has a smallest box
    # free to turn about its axis, and a few degrees off its faces its own frame scores low
    if alignment(surfaces[root], turned) >= MIN_SQUARE:
        frame = turned
    out = []
    for i, (pts, surface, own) in enumerate(zip(points, surfaces, boxes, strict=True)):
        if i == root:
            square = frame_aligned_obb(pts, frame, "all")
            out.append(square if square.volume <= (1.0 + tolerance) * own.volume else own)
            continue
        out.append(_aligned_box(pts, surface, own, frame, tolerance))
    return out


def _aligned_box(points: np.ndarray, surface: Surface, own: OBB, frame: np.ndarray,
                 tolerance: float) -> OBB:
    square = frame_aligned_obb(points, frame, "all")
    own_score = alignment(surface, own.R)
    if np.isnan(own_score):  # no flat piece to read: volumes decide
        limit = (1.0 + tolerance) * own.volume
        if square.volume <= limit:
            return square
        held = frame_aligned_obb(points, frame, "one")
        return held if held.volume <= limit else own
    square_score = alignment(surface, frame)
    turns = [best_turn(surface, frame, axis) for axis in range(3)]
    turn_scores = [alignment(surface, f) for _, f in turns]
    best = int(np.argmax(turn_scores))
    if (max(square_score, turn_scores[best], own_score) < MIN_SQUARE
            and max(square_score, turn_scores[best]) < own_score + SQUARE_MARGIN):
        # not boxy (a round top, a blob): no frame is better founded than its own. Noisy
        # normals lower every frame's score alike, so a frame far squarer than the part's
        # own still wins: on hand-held phone-LiDAR views a drawer's own box, turned 19
        # degrees about its slide, scored 0.03 against the carcass's frame's 0.37, was kept
        # and read as a hinge
        return own
    if square_score >= max(own_score, turn_scores[best]) - SQUARE_MARGIN:
        return square
    if turn_scores[best] >= own_score - SQUARE_MARGIN:
        return frame_aligned_obb(points, turns[best][1], "all")
    return own
