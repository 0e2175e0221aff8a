"""Closed state and range of a predicted joint, from the part meshes and boxes.

Real2Code predicts a joint's type, axis and position and nothing else. Exports need q = 0
(the door shut, the drawer in) and a range. The observed opening of a hinge is the turn
that lays the child's mesh flat against a face of its parent's box, preferring the face
where the parent is open (a door shuts over an opening, not against a side panel); a
slide's is how far the child's front panel (not its handle) stands out of its parent. The
range is found by sweeping the joint open until the child's box runs into its parent's,
capped by a typical bound for the joint kind when nothing stops it. The geometric
predictor still uses the box-only hinge estimate to choose a hinge's sign.
"""

from __future__ import annotations

import numpy as np

from real2code_export.transforms import axis_angle_matrix

from .obb import OBB

# Typical upper bounds when nothing stops the sweep: cabinet and fridge doors open a bit
# past square, lids and laptop screens (shut on top of their parent) well past it, flaps on
# a front face to about square; drawers on the classic three-quarter-extension slides pull
# out to ~75 % of their depth.
VERTICAL_HINGE_BOUND = np.radians(105.0)
LID_HINGE_BOUND = np.radians(120.0)
FLAP_HINGE_BOUND = np.radians(85.0)
SLIDE_FRACTION = 0.75
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


SWEEP_GRID = np.radians(np.arange(-180.0, 180.0, 1.0))
FLUSH_MARGIN = 0.03  # candidates within this (relative) of the flattest are all plausible
COVER_DEPTH = 0.05  # how deep behind a face (fraction of the parent's size) a panel counts
COVER_WEIGHT = 0.5  # an open face beats a covered one unless it is clearly less flush
FRONT_SHARE = 0.05  # a drawer's front panel holds at least this share of its surface


def _rotate(points: np.ndarray, axis: np.ndarray, point: np.ndarray, angles: np.ndarray
            ) -> np.ndarray:
    """``points`` (M, 3) turned about (axis, point) by each angle: (A, M, 3) (Rodrigues)."""
    p = points - point
    c, s = np.cos(angles)[:, None, None], np.sin(angles)[:, None, None]
    along = (p @ axis)[None, :, None] * axis
    return point + p * c + np.cross(axis, p)[None] * s + along * (1.0 - c)


def _faces_across(parent: OBB, axis: np.ndarray) -> list[tuple[int, float]]:
    """The parent's box faces a hinge about ``axis`` can shut a part against."""
    return [(k, s) for k in range(3) if abs(parent.R[:, k] @ axis) < 0.5 for s in (1.0, -1.0)]


def _flatness(parent: OBB, local: np.ndarray, k: int, s: float) -> np.ndarray:
    """How far child points (A, M, 3, in the parent box frame) are from lying flat against
    face (k, s): a gap between the child and the face plane (in front of it, or the whole
    child sunk behind it; a part may reach in through an opening, as a fridge door's bins
    do), the child's thickness across the face, and its overhang past the face's edges
    (m, per angle)."""
    x = s * local[..., k]
    near, far = x.min(axis=-1), x.max(axis=-1)
    gap = np.maximum(0.0, near - parent.extent[k]) + np.maximum(0.0, parent.extent[k] - far)
    others = [i for i in range(3) if i != k]
    overhang = np.maximum(0.0, np.abs(local[..., others]).max(axis=-2) - parent.extent[others])
    return gap + (far - near) + overhang.sum(axis=-1)


def face_cover(parent: OBB, parent_points: np.ndarray, footprint: np.ndarray, k: int,
               s: float, cells: int = 6) -> float:
    """The fraction of a footprint on face (k, s) backed by the parent's own surface just
    behind the face: ~1 against a side panel, low over an opening (a frame at most).
    ``footprint``: the child's points in the parent box frame."""
    others = [i for i in range(3) if i != k]
    lo, hi = footprint[:, others].min(axis=0), footprint[:, others].max(axis=0)
    span = np.maximum(hi - lo, 1e-9)
    depth = COVER_DEPTH * 2.0 * float(parent.extent.max())
    x = s * parent_points[:, k]
    near = parent_points[(x > parent.extent[k] - depth) & (x <= parent.extent[k] + depth)]
    cell = np.floor((near[:, others] - lo) / span * cells).astype(int)
    inside = np.all((cell >= 0) & (cell < cells), axis=1)
    occupied = {tuple(c) for c in cell[inside]}
    return len(occupied) / cells**2


def hinge_opening_from_mesh(parent: OBB, child_points: np.ndarray, axis: np.ndarray,
                            point: np.ndarray, parent_points: np.ndarray | None = None,
                            others: list[np.ndarray] | None = None) -> float:
    """The observed opening about +axis (positive: open) from the child's points (its
    convex hull's vertices suffice: only extremes are measured). Every turn is tried
    (1 degree, then refined); among those that lay the child flat against a face of the
    parent's box, the face the parent leaves open wins (``parent_points``: samples of the
    parent's surface), then the place no other part holds (``others``: samples of each
    other part's surface as seen), then the smaller turn. Unlike the box estimate this
    needs no box axis to follow the part, so a tilted screen or a half-open door closes
    right."""
    from scipy.optimize import minimize_scalar

    axis = axis / np.linalg.norm(axis)
    scale = float(np.ptp(child_points, axis=0).max()) or 1.0
    turned = _rotate(child_points, axis, point, SWEEP_GRID)
    local = (turned - parent.center) @ parent.R
    faces = _faces_across(parent, axis)
    if not faces:
        return 0.0
    flat = np.stack([_flatness(parent, local, k, s) for k, s in faces]) / scale  # (F, A)
    floor = flat.min(axis=1, keepdims=True).min()
    best, best_key = 0.0, np.inf
    for f, (k, s) in enumerate(faces):
        row = flat[f]
        minima = np.flatnonzero((row <= np.roll(row, 1)) & (row <= np.roll(row, -1))
                                & (row <= floor + FLUSH_MARGIN))
        for a in minima:
            def score(t: float, k=k, s=s) -> float:
                loc = (_rotate(child_points, axis, point, np.array([t])) - parent.center) @ parent.R
                return float(_flatness(parent, loc, k, s)[0]) / scale

            step = SWEEP_GRID[1] - SWEEP_GRID[0]
            res = minimize_scalar(score, bounds=(SWEEP_GRID[a] - step, SWEEP_GRID[a] + step),
                                  method="bounded", options={"xatol": 1e-5})
            angle = float(res.x)
            cover = 0.0
            if parent_points is not None:
                closed = (_rotate(child_points, axis, point, np.array([angle]))[0]
                          - parent.center) @ parent.R
                cover = face_cover(parent, (parent_points - parent.center) @ parent.R,
                                   closed, k, s)
            taken = 0.0
            if others:
                taken = place_taken(_rotate(child_points, axis, point, np.array([angle]))[0],
                                    others)
            key = float(res.fun) + COVER_WEIGHT * cover + TAKEN_WEIGHT * taken + 0.01 * abs(angle)
            if key < best_key:
                best, best_key = angle, key
    return -best


TAKEN_WEIGHT = 1.0  # a place another part holds loses to any flush free one


def place_taken(closed_hull: np.ndarray, others: list[np.ndarray]) -> float:
    """How much of the place a part would close onto another part holds: the largest share
    of any other part's surface samples inside the closed part's convex hull. Two flaps
    hinged on one rail both lie flush on the face whichever way each shuts; only one of the
    two places is each one's (on the demo capture a flap shut onto its neighbour's, 51 mm
    deep)."""
    from scipy.spatial import Delaunay, QhullError

    try:
        hull = Delaunay(closed_hull)
    except (QhullError, ValueError):  # flat: holds nothing
        return 0.0
    return max((float(np.mean(hull.find_simplex(o) >= 0)) for o in others if len(o)),
               default=0.0)


def slide_opening_from_mesh(parent: OBB, child_samples: np.ndarray, axis: np.ndarray,
                            clearance: float = float("inf"),
                            parent_samples: tuple[np.ndarray, np.ndarray] | None = None) -> float:
    """The observed opening of a slide: how far the child's front panel stands out of the
    frame around it (a handle or knob in front of the panel does not count), but never
    more than it can slide back before meeting its parent (``clearance``, see
    :func:`slide_clearance`: an overlay front stops on the frame). The frame is the plane
    facing out along +axis that holds most of the parent's surface just around the
    child's cross-section (``parent_samples``: points and normals); without one, the
    parent box's front face (which a table top overhanging its drawers would mislead).
    ``child_samples``: points spread evenly over the child's surface."""
    frame = None
    if parent_samples is not None:
        frame = frame_plane(*parent_samples, child_samples, axis)
    if frame is None:
        frame = float(parent.center @ axis + np.abs(parent.R.T @ axis) @ parent.extent)
    return float(max(0.0, min(front_plane(child_samples, axis) - frame, clearance)))


FRAME_MARGIN = 0.015  # m around a drawer's cross-section where its frame is looked for
FRAME_FLAT = 0.002  # m: a frame's front is flat to within this


def frame_plane(points: np.ndarray, normals: np.ndarray, child_samples: np.ndarray,
                axis: np.ndarray) -> float | None:
    """Where along ``axis`` the parent's frame around the child lies: among the parent's
    surface facing +axis within a margin around the child's cross-section (not inside it:
    that is the cavity), the frontmost plane that borders the cross-section on at least
    two of its four sides (a table top overhanging a drawer borders it on one; the
    carcass's back, seen past the edges, lies behind the frame)."""
    u = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    basis = np.column_stack([u, v])
    cross = child_samples @ basis
    lo, hi = cross.min(axis=0), cross.max(axis=0)
    where = points @ basis
    near = np.all((where > lo - FRAME_MARGIN) & (where < hi + FRAME_MARGIN), axis=1)
    inside = np.all((where > lo) & (where < hi), axis=1)
    keep = near & ~inside & (normals @ axis > 0.9)
    proj, where = points[keep] @ axis, where[keep]
    if len(proj) < 5:
        return None
    within = (where > lo) & (where < hi)  # corners of the ring border no side
    side = np.column_stack([(where[:, 0] <= lo[0]) & within[:, 1],
                            (where[:, 0] >= hi[0]) & within[:, 1],
                            (where[:, 1] <= lo[1]) & within[:, 0],
                            (where[:, 1] >= hi[1]) & within[:, 0]])
    slab = np.floor((proj.max() - proj) / FRAME_FLAT).astype(int)
    for k in range(int(slab.max()) + 1):  # front to back
        plane = (slab == k) | (slab == k + 1)
        if (side[plane].sum(axis=0) >= 2).sum() >= 2:
            return float(np.median(proj[plane]))
    return None


def slide_clearance(parent_vertices: np.ndarray, parent_faces: np.ndarray,
                    child_samples: np.ndarray, child_normals: np.ndarray,
                    axis: np.ndarray, share: float = 0.0) -> float:
    """How far the child can slide back along -axis before its surface meets its parent's
    (rays from its surface samples; inf when nothing is behind it): where an overlay
    drawer's front meets the frame, or a drawer's back meets the carcass. A stop is faces
    meeting across an area: only the child's surface facing back (``child_normals``)
    against the parent's faces across the motion counts (contacts the motion slides along
    do not), and the slide stops where ``share`` of that surface has met the parent: on
    exact meshes (0) the first contact, since a real stop can be small (an overlay
    front's rim on its frame: ~1 % of that surface on PartNet-Mobility); on scanned parts
    (:data:`SCAN_STOP_SHARE`) a share, since specks of the frame left on a drawer's sides
    and a carcass's hidden surfaces guessed by the completion would otherwise stop it
    where it stands (~1-3 % of that surface on a phone-LiDAR capture). Parent surface inside
    the cross-section of the child's own body behind it is no stop: the child already
    passes through there (a scan's completion closes a carcass's opening behind the
    drawer's front with a membrane the drawer's box pierces)."""
    import open3d as o3d  # its ray caster: thousands of rays against a scan in milliseconds

    facing = child_normals @ -axis > STOP_FACING
    if not facing.any():
        return float("inf")
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(np.asarray(parent_vertices, dtype=np.float32)),
                        o3d.core.Tensor(np.asarray(parent_faces, dtype=np.uint32)))
    starts = child_samples[facing]
    rays = np.hstack([starts, np.broadcast_to(-axis, starts.shape)])
    cast = scene.cast_rays(o3d.core.Tensor(rays.astype(np.float32)))
    hit, across = cast["t_hit"].numpy(), np.abs(cast["primitive_normals"].numpy() @ axis)
    met = np.isfinite(hit) & (hit > CONTACT) & (across > STOP_FACING)
    met[met] = ~_within_child(child_samples, axis, starts[met], hit[met])
    hit = np.sort(hit[met])
    needed = max(1, int(np.ceil(share * len(starts))))
    return float(hit[needed - 1]) if len(hit) >= needed else float("inf")


def _within_child(child_samples: np.ndarray, axis: np.ndarray, starts: np.ndarray,
                  travel: np.ndarray) -> np.ndarray:
    """Whether each contact (``starts`` moved ``travel`` along -axis) lies inside the
    cross-section of the child's samples behind it, shrunk by a margin for a scan's
    noisy walls (the box of that cross-section: a drawer's open top counts as inside)."""
    u = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    basis = np.column_stack([u, np.cross(axis, u)])
    proj = child_samples @ axis
    order = np.argsort(proj)
    cross = (child_samples @ basis)[order]
    lo, hi = np.minimum.accumulate(cross, axis=0), np.maximum.accumulate(cross, axis=0)
    behind = np.searchsorted(proj[order], starts @ axis - travel)  # samples behind the contact
    where, k = starts @ basis, np.maximum(behind - 1, 0)
    inside = np.all((where > lo[k] + FRAME_MARGIN) & (where < hi[k] - FRAME_MARGIN), axis=1)
    return inside & (behind > 0)


STOP_FACING = 0.7  # |cos| to the axis of faces that meet head-on (within ~45 degrees)
SCAN_STOP_SHARE = 0.05  # of a scanned child's back-facing surface: faces meeting, not specks
CONTACT = 1e-4  # m: surfaces this close already touch


def front_plane(samples: np.ndarray, axis: np.ndarray) -> float:
    """Where along ``axis`` a part's front panel lies: the outermost plane holding a real
    share of its surface (a handle or knob in front of it does not count)."""
    proj = samples @ axis
    top = float(proj.max())
    width = 0.005 * float(np.ptp(proj) or 1.0) + 1e-4  # a panel is flat to within this
    # slabs from the front backwards; a panel split by a slab boundary counts in both pairs
    slab = np.floor((top - proj) / width).astype(int)
    share = np.bincount(slab) / len(proj)
    pairs = share + np.append(share[1:], 0.0)
    first = int(np.flatnonzero(pairs >= FRONT_SHARE)[0]) if (pairs >= FRONT_SHARE).any() else 0
    return float(proj[slab >= first].max())


def penetration(a: OBB, b: OBB) -> float:
    """How deep the boxes interpenetrate (m; negative: the gap between them), by the
    separating-axis theorem: the smallest overlap over the 15 candidate axes."""
    axes = [a.R[:, i] for i in range(3)] + [b.R[:, i] for i in range(3)]
    axes += [np.cross(a.R[:, i], b.R[:, j]) for i in range(3) for j in range(3)]
    d = b.center - a.center
    depth = np.inf
    for ax in axes:
        n = np.linalg.norm(ax)
        if n < 1e-9:
            continue
        ax = ax / n
        ra = np.abs(a.R.T @ ax) @ a.extent
        rb = np.abs(b.R.T @ ax) @ b.extent
        depth = min(depth, ra + rb - abs(d @ ax))
    return float(depth)


def boxes_overlap(a: OBB, b: OBB, tolerance: float = 0.0) -> bool:
    """True when the boxes interpenetrate by more than ``tolerance``."""
    return penetration(a, b) > tolerance


def hinge_upper(parent: OBB, closed_child: OBB, axis: np.ndarray, point: np.ndarray,
                observed: float) -> float:
    """Sweep the closed child open about (axis, point) until it runs into the parent; cap
    at the typical bound; never below the observed opening. A door set into its frame
    already overlaps the parent's box when shut: only overlap beyond that counts."""
    bound = hinge_bound(parent, closed_child, axis)
    tolerance = max(0.0, penetration(parent, closed_child)) + 0.5 * float(closed_child.extent.min())
    angle = SWEEP_STEP
    limit = max(bound, observed)
    while angle <= limit:
        if angle > observed and boxes_overlap(parent, rotated_box(closed_child, axis, point, angle),
                                              tolerance):
            return max(observed, angle - SWEEP_STEP)
        angle += SWEEP_STEP
    return float(limit)


def hinge_bound(parent: OBB, closed_child: OBB, axis: np.ndarray) -> float:
    """The typical opening of a hinged part: a door (vertical axis), a lid or screen (shut
    on its parent's top), or a flap (a horizontal axis on a side face)."""
    if abs(axis[2]) > 0.7:
        return float(VERTICAL_HINGE_BOUND)
    parent_top = parent.center[2] + np.abs(parent.R[2]) @ parent.extent
    child_low = closed_child.center[2] - np.abs(closed_child.R[2]) @ closed_child.extent
    lid = child_low >= parent_top - 0.5 * float(closed_child.extent.min()) - 1e-6
    return float(LID_HINGE_BOUND if lid else FLAP_HINGE_BOUND)


def slide_upper(depth: float, observed: float) -> float:
    """A drawer's travel from its depth (front panel to back)."""
    return max(observed, SLIDE_FRACTION * depth)
