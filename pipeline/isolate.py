"""Find the object in a capture of a room: the first reconstruction stage.

A real capture holds the floor the object stands on, a wall behind it and things nearby;
every later stage takes the pixels with depth for the object, so this stage leaves depth on
the object's pixels alone (a capture of the object alone passes through unchanged):

1. where the object is: the point the cameras look at (the least-squares meeting point of
   their viewing axes: a person aims at what they scan) and the largest sphere about it
   that every view holds whole — the object lies inside it — or the box the user gives
   (``--box``);
2. the room's planes, frame by frame (each frame's own points, so pose error does not
   blur them): open3d's RANSAC plane segmentation, again and again; a plane a good share
   of whose points lie outside the object's region is the floor or a wall, and its points
   go; a plane within it is a face of the object, kept (and set aside for the next search);
3. what is left, fused over the views, falls into clusters (points in touching grid cells
   a few voxels wide, :func:`grid_clusters`): the object is the cluster with most points in
   its region, with any small cluster mostly inside the object's box (a piece cut off by a
   gap) and any cluster mostly above or below it (a table's body under its top, seen apart
   from it past the top's overhang); clutter and the rest go.
4. the object's foot: what of it lies within a room plane's inlier distance (the bottom
   centimetre of a cabinet's faces, a refrigerator's base plate on the floor) went with the
   plane. Geometry cannot tell it from the floor; colour can, where the object's differs:
   a plane pixel inside the region whose colour is off the plane's (fitted, frame by
   frame, on its pixels outside the region, shading across it included), joined in the
   image to the object's pixels, is the object's again.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from real2code_export.errors import InputError

from .capture import Capture, Frame
from .ransac import fit_plane


@dataclass(frozen=True)
class IsolationOptions:
    max_planes: int = 8  # planes looked for per frame
    min_plane_share: float = 0.03  # of a frame's points: a smaller plane ends the search
    scenery_share: float = 0.25  # of a plane's points outside the region: floor or wall
    plane_rel: float = 0.004  # plane inlier distance, relative to depth (clean depth) ...
    plane_sigmas: float = 3.0  # ... or this many times the frame's relative noise ...
    max_plane_rel: float = 0.03  # ... but at most this share of the region's radius
    ransac_points: int = 3000  # a frame's points the RANSAC draws from
    ransac_iterations: int = 200
    voxel_rel: float = 0.012  # a voxel, of the region's radius
    cluster_voxels: float = 3.0  # the clusters' grid cell, in voxels, and at least ...
    cluster_pixels: float = 2.5  # ... this many pixels' width at the object's depth
    piece_share: float = 0.05  # a cluster in the object's box this small is a piece of it
    far_tolerance: float = 3.0  # a room plane's inlier distance outside the region, x
    agree_share: float = 0.25  # a room plane found in this share of the frames ...
    agree_deg: float = 3.0  # ... (the same within this angle and the inlier distance) is
    # taken in every frame
    region_margin: float = 1.1  # the sphere every view holds, grown (an aim a little off)
    box_margin: float = 0.05  # a given box grows by this share of its diagonal
    broad_rel: float = 0.1  # a room plane's points outside the region spread this much (of
    # the region's size, standard deviation across its narrower direction)
    stacked_share: float = 0.5  # a cluster with this share of its points above or below the
    stacked_min: float = 0.005  # object (inside its outline seen from above), and at least
    # this share of the object's size (not a speck of the floor's noise), is the object's
    upright: float = 0.5  # the views' mean up axis at least this long: they agree on up
    foot_colour: float = 12.0  # a plane pixel this far (8-bit RGB) from its plane's colour ...
    foot_sigmas: float = 4.0  # ... and this many times its spread there is the object's
    foot_reference: int = 30  # a plane's pixels outside the region its colour is taken from
    foot_step_px: float = 4.0  # a foot pixel lies within the plane's inlier distance of its
    # neighbour on the way to the object, or within this many pixels' width at its depth (a
    # face seen obliquely), whichever is more


@dataclass(frozen=True)
class Region:
    """Where the object is: a sphere (``radius`` > 0) or a box ``lo`` .. ``hi``."""

    centre: np.ndarray
    radius: float = 0.0
    lo: np.ndarray | None = None
    hi: np.ndarray | None = None

    def size(self) -> float:
        """The region's radius (a box's: half its diagonal)."""
        return self.radius if self.lo is None else 0.5 * float(np.linalg.norm(self.hi - self.lo))

    def contains(self, points: np.ndarray) -> np.ndarray:
        if self.lo is not None:
            return np.all((points >= self.lo) & (points <= self.hi), axis=1)
        return np.linalg.norm(points - self.centre, axis=1) <= self.radius


def parse_box(text: str) -> tuple[np.ndarray, np.ndarray]:
    """``xmin,ymin,zmin,xmax,ymax,zmax`` (world frame, metres) -> (lo, hi)."""
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != 6 or not all(np.isfinite(values)):
        raise InputError(f"--box: expected six numbers xmin,ymin,zmin,xmax,ymax,zmax, "
                         f"got {text!r}")
    lo, hi = np.array(values[:3]), np.array(values[3:])
    if np.any(hi <= lo):
        raise InputError(f"--box: every max must exceed its min, got {text!r}")
    return lo, hi


def look_at_point(frames: list[Frame]) -> np.ndarray | None:
    """The point nearest every camera's viewing axis (least squares), or None when the axes
    are (nearly) parallel."""
    a, b = np.zeros((3, 3)), np.zeros(3)
    for f in frames:
        d = -f.camera_to_world[:3, 2]  # OpenGL: the camera looks down -z
        p = np.eye(3) - np.outer(d, d)
        a += p
        b += p @ f.camera_to_world[:3, 3]
    if len(frames) < 2 or np.linalg.cond(a) > 1e6:
        return None
    return np.linalg.solve(a, b)


def object_region(capture: Capture, box: tuple[np.ndarray, np.ndarray] | None = None,
                  options: IsolationOptions = IsolationOptions()) -> Region:
    """The user's box (grown a little), or the sphere about the cameras' meeting point that
    every view holds whole."""
    if box is not None:
        lo, hi = (np.asarray(v, float) for v in box)
        grow = options.box_margin * float(np.linalg.norm(hi - lo))
        return Region((lo + hi) / 2, 0.0, lo - grow, hi + grow)
    centre = look_at_point(capture.frames)
    if centre is None:
        raise InputError("cannot tell where the object is: the cameras' viewing axes do not "
                         "meet (give the object's extent with --box)")
    radius = np.inf
    for f in capture.frames:
        c = f.camera
        half = np.arctan(0.5 * min(c.width / c.fl_x, c.height / c.fl_y))
        radius = min(radius, np.linalg.norm(f.camera_to_world[:3, 3] - centre) * np.sin(half))
    return Region(centre, float(radius) * options.region_margin)


def _frame_points(frame: Frame) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The frame's pixels with depth: (rows, cols) and world points."""
    rows, cols = np.nonzero(frame.depth > 0)
    dirs = frame.camera.pixel_directions()[rows, cols]
    cam = dirs * frame.depth[rows, cols, None]
    world = cam @ frame.camera_to_world[:3, :3].T + frame.camera_to_world[:3, 3]
    return rows, cols, world


def plane_tolerance(depth: np.ndarray, inside: np.ndarray, noise_rel: float, region: Region,
                    options: IsolationOptions = IsolationOptions(),
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Per point, how far off a plane its points may lie: for finding it (at most a small
    share of the object's size: a thicker slab would take the object's faces with the
    floor), and for taking the room's: more outside the region, where a sensor's noise
    grows faster than the object's noise says (what is left of a floor must not pair up
    with a face of the object into a plane)."""
    tolerance = np.minimum(max(options.plane_rel, options.plane_sigmas * noise_rel) * depth,
                           options.max_plane_rel * region.size())
    return tolerance, np.where(inside, 1.0, options.far_tolerance) * tolerance


def scenery_planes(points: np.ndarray, tolerance: np.ndarray, wide: np.ndarray,
                   inside: np.ndarray, region: Region, rng: np.random.Generator,
                   options: IsolationOptions = IsolationOptions(),
                   ) -> tuple[np.ndarray, list[tuple[np.ndarray, float]]]:
    """Which of one frame's world ``points`` lie on the room's planes, and those planes
    (unit normal, offset)."""
    scenery = np.zeros(len(points), bool)
    searched = np.ones(len(points), bool)  # not yet a plane's
    planes = []
    for _ in range(options.max_planes):
        pool = np.nonzero(searched)[0]
        if len(pool) < max(50, options.min_plane_share * len(points)):
            break
        sample = pool if len(pool) <= options.ransac_points else \
            rng.choice(pool, options.ransac_points, replace=False)
        normal, offset, _ = fit_plane(points[sample], float(np.median(tolerance[sample])),
                                      options.ransac_iterations, rng)
        if not normal.any():
            break
        distance = np.abs(points @ normal + offset)
        on_plane = searched & (distance <= tolerance)
        if on_plane.sum() < options.min_plane_share * len(points):
            break
        outside = on_plane & ~inside
        if outside.sum() >= options.scenery_share * on_plane.sum() and \
                _broad(points[outside], region, options):
            room = distance <= wide  # with what was set aside as a face: coplanar
            scenery |= room
            searched &= ~room
            planes.append((normal, offset))
        else:  # a face of the object: set aside; what of it lies outside, searched on
            searched &= ~(on_plane & ~outside)
    return scenery, planes


def agreed_planes(per_frame: list[list[tuple[np.ndarray, float]]], tolerance: float,
                  options: IsolationOptions = IsolationOptions(),
                  ) -> list[tuple[np.ndarray, float]]:
    """The room planes found in at least ``agree_share`` of the frames (and two): the same
    normal within ``agree_deg`` and offset within ``tolerance``; one per group."""
    flat = [(k, n, d) for k, planes in enumerate(per_frame) for n, d in planes]
    need = max(2, int(np.ceil(options.agree_share * len(per_frame))))
    cos = np.cos(np.radians(options.agree_deg))
    out: list[tuple[np.ndarray, float]] = []
    for _, n, d in flat:
        if any(n @ m >= cos and abs(d - e) <= tolerance for m, e in out):
            continue
        frames = {k for k, m, e in flat if n @ m >= cos and abs(d - e) <= tolerance}
        if len(frames) >= need:
            out.append((n, d))
    return out


def _broad(points: np.ndarray, region: Region, options: IsolationOptions) -> bool:
    """Whether ``points`` (of one plane) spread in both of its directions: a floor or a wall
    does, where the band in which an object's face's plane cuts them is narrow."""
    if len(points) < 10:
        return False
    spread = np.linalg.svd(points - points.mean(0), compute_uv=False) / np.sqrt(len(points))
    return bool(spread[1] >= options.broad_rel * region.size())


def grid_clusters(points: np.ndarray, cell: float) -> np.ndarray:
    """A cluster label per point: points in grid cells of side ``cell`` that touch (26
    neighbours) are one cluster. Single linkage at about ``cell``, as DBSCAN with a minimum
    of one point, in O(N log N) (open3d's DBSCAN took seconds on a capture's points)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    ijk = np.floor(points / cell).astype(np.int64)
    ijk -= ijk.min(0) - 1  # a free cell on every side: neighbours never wrap
    dims = ijk.max(0) + 2
    keys = (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]
    cells, inverse = np.unique(keys, return_inverse=True)
    rows, cols = [], []
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            for dk in (-1, 0, 1):
                step = (di * dims[1] + dj) * dims[2] + dk
                if step <= 0:
                    continue  # each pair once
                at = np.searchsorted(cells, cells + step)
                found = (at < len(cells)) & (cells[np.minimum(at, len(cells) - 1)] ==
                                             cells + step)
                rows.append(np.nonzero(found)[0])
                cols.append(at[found])
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(cells), len(cells)))
    return connected_components(graph, directed=False)[1][inverse]


def views_up(frames: list[Frame], options: IsolationOptions = IsolationOptions(),
             ) -> np.ndarray | None:
    """Which way is up, from how people hold a camera: upright, give or take a few degrees
    of roll (the mean of the views' up axes), or None where the views disagree (a camera
    held flat over the object, turned as it went round)."""
    up = np.mean([f.camera_to_world[:3, 1] for f in frames], axis=0)  # OpenGL: y up
    length = float(np.linalg.norm(up))
    return up / length if length >= options.upright else None


def _outline(points: np.ndarray, up: np.ndarray):
    """A test of whether points lie above or below ``points`` (inside their convex outline
    seen from above, in the plane across ``up``)."""
    from scipy.spatial import ConvexHull, Delaunay, QhullError

    across = np.linalg.svd(np.eye(3) - np.outer(up, up))[0][:, :2]  # the plane across up
    flat = points @ across
    try:
        hull = Delaunay(flat[ConvexHull(flat).vertices])
    except QhullError:  # the object seen edge-on from above (a thin wall): no outline
        return lambda q: np.zeros(len(q), bool)
    return lambda q: hull.find_simplex(q @ across) >= 0


def _plane_colour(rgb: np.ndarray, rows: np.ndarray, cols: np.ndarray, rounds: int = 3,
                  ) -> tuple[np.ndarray, float]:
    """A room plane's colour in one view as it varies over the image (shading changes
    smoothly across a floor: linear in the pixel coordinates, per channel), fitted on its
    pixels with the outliers (the object's foot, a spot) trimmed; its coefficients (3, 3)
    and the robust spread (8-bit RGB) of the pixels about it."""
    design = np.stack([np.ones(len(rows)), rows / 256.0, cols / 256.0], 1)
    keep = np.ones(len(rows), bool)
    for _ in range(rounds):
        coef = np.linalg.lstsq(design[keep], rgb[keep], rcond=None)[0]
        residual = np.linalg.norm(rgb - design @ coef, axis=1)
        sigma = 1.4826 * float(np.median(residual[keep])) + 1e-6
        keep = residual <= 3.0 * sigma
        if keep.sum() < 10:
            break
    return coef, sigma


def foot_pixels(frame: Frame, rows: np.ndarray, cols: np.ndarray, world: np.ndarray,
                plane: np.ndarray, planes: list[tuple[np.ndarray, float]], kept: np.ndarray,
                inside: np.ndarray, step: np.ndarray | float,
                options: IsolationOptions = IsolationOptions()) -> np.ndarray:
    """Which of one frame's room-plane pixels (``plane``, over its pixels with depth at
    ``rows``, ``cols``; ``planes`` the room's planes in it) are the object's foot: inside
    the region, off their plane's colour in this view (:func:`_plane_colour`, fitted on
    its pixels outside the region, surely the room's) by
    ``foot_colour`` and ``foot_sigmas`` times its spread, and joined in the image to the
    object's ``kept`` pixels through such pixels, neighbours at each step at most ``step``
    (per pixel: the plane's inlier distance; infinite on exact depth, which reads no pixel
    sideways: the image's join) or ``foot_step_px`` pixels' width at their depth apart in
    the world. Where the object's foot has the room's colour, the plane keeps it.

    The foot continues the object's faces down to the floor, one surface; a pixel on the
    object's silhouette that reads the room's depth behind it (a phone's depth map
    upsampled from a coarser one smears depth a pixel or two sideways, a flying pixel)
    has the object's colour too, but lies as far from the object as the room behind:
    on a phone-LiDAR ring in a room, 300 to 1,350 such pixels a capture, 15 cm to a metre
    behind a table's legs and a cabinet's sides, came back as its foot and stretched the
    object's extent by up to 28 % (every later stage's spacing with it); labels held
    strays far outside their parts."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    out = np.zeros(len(plane), bool)
    if not planes or not (plane & inside).any():
        return out
    rgb = frame.rgb[..., :3].astype(np.float64)[rows, cols]
    nearest = np.argmin(np.stack([np.abs(world @ n + d) for n, d in planes]), axis=0)
    off = np.zeros(len(plane), bool)
    for k in range(len(planes)):
        on = plane & (nearest == k)
        room = on & ~inside  # the plane's colour from where it is surely the room's
        if room.sum() < options.foot_reference:
            continue
        coef, sigma = _plane_colour(rgb[room], rows[room], cols[room])
        near = on & inside
        design = np.stack([np.ones(near.sum()), rows[near] / 256.0, cols[near] / 256.0], 1)
        residual = np.linalg.norm(rgb[near] - design @ coef, axis=1)
        off[np.nonzero(near)[0][residual > max(options.foot_colour,
                                               options.foot_sigmas * sigma)]] = True
    candidate = off & inside
    if not candidate.any():
        return out
    h, w = frame.depth.shape
    node = np.full((h, w), -1)  # the object's kept pixels and the candidates, numbered
    members = np.nonzero(kept | candidate)[0]
    node[rows[members], cols[members]] = np.arange(len(members))
    reach = np.maximum(np.broadcast_to(np.asarray(step, float), plane.shape)[members],
                       options.foot_step_px * frame.depth[rows[members], cols[members]]
                       / frame.camera.fl_x)
    first, second = [], []
    for dr, dc in ((0, 1), (1, -1), (1, 0), (1, 1)):  # each 8-neighbour pair once
        a = node[max(0, -dr):h - max(0, dr), max(0, -dc):w - max(0, dc)]
        b = node[max(0, dr):, max(0, dc):][:a.shape[0], :a.shape[1]]
        a, b = a[(a >= 0) & (b >= 0)], b[(a >= 0) & (b >= 0)]
        near = np.linalg.norm(world[members[a]] - world[members[b]], axis=1) \
            <= np.minimum(reach[a], reach[b])
        first.append(a[near])
        second.append(b[near])
    a, b = np.concatenate(first), np.concatenate(second)
    graph = coo_matrix((np.ones(len(a)), (a, b)), shape=(len(members), len(members)))
    _, regions = connected_components(graph, directed=False)
    joined = np.unique(regions[kept[members]])
    out[members] = candidate[members] & np.isin(regions, joined)
    return out


def object_points(points: np.ndarray, region: Region, boxed: bool, footprint: float,
                  options: IsolationOptions = IsolationOptions(),
                  up: np.ndarray | None = None, unsure: np.ndarray | None = None,
                  ) -> np.ndarray:
    """Which of the fused ``points`` (off the room's planes) are the object: those in the
    given box, or the cluster with most points in the region, the small clusters mostly
    inside its box (a piece cut off by a gap, a speck seen through a slit) and, given ``up``,
    the clusters mostly above or below it: a table's top and its body are seen apart where
    the top overhangs (from above, the gap under the overhang is hidden; on a 7-drawer
    table 8 cm between the nearest points, the body 48 % of the object's pixels), while
    clutter stands beside the object. ``footprint``: a pixel's width on the object (in a
    small image its points lie further apart than the voxel).

    ``unsure`` points (their views' depth outliers: flying pixels, a depth map's smear)
    link no clusters: each is what the nearest other point within a cluster cell is, or
    not the object. Noisy depth strews such points along the rays between a silhouette
    and what lies behind it: on a phone-LiDAR ring in a room they bridged a box of clutter
    standing 10 to 20 cm from a cabinet to it, and its 5,000 pixels were kept, segmented
    and given a hinge."""
    inside = region.contains(points)
    if boxed:
        return inside
    voxel = options.voxel_rel * region.size()
    cell = max(options.cluster_voxels * voxel, options.cluster_pixels * footprint)
    if unsure is not None and unsure.any() and not unsure.all():
        from scipy.spatial import cKDTree

        sure = object_points(points[~unsure], region, boxed, footprint, options, up)
        distance, nearest = cKDTree(points[~unsure]).query(points[unsure],
                                                           distance_upper_bound=cell)
        out = np.zeros(len(points), bool)
        out[~unsure] = sure
        out[unsure] = np.isfinite(distance) & sure[np.minimum(nearest, len(sure) - 1)]
        return out
    labels = grid_clusters(points, cell)
    counts = np.bincount(labels, weights=inside, minlength=labels.max() + 1)
    if counts.max() == 0:
        raise InputError("found no object in the capture: no points near where the cameras "
                         "look (give its extent with --box)")
    keep = labels == int(np.argmax(counts))
    lo, hi = points[keep].min(0), points[keep].max(0)
    within = np.all((points >= lo) & (points <= hi), axis=1)
    sizes = np.bincount(labels)
    piece = (np.bincount(labels, weights=within) >= 0.5 * sizes) & \
        (sizes <= options.piece_share * keep.sum())
    if up is not None:
        stacked = _outline(points[keep], up)(points)
        piece |= (np.bincount(labels, weights=stacked) >= options.stacked_share * sizes) & \
            (sizes >= options.stacked_min * keep.sum())
    return keep | piece[labels]


def isolate_object(capture: Capture, box: tuple[np.ndarray, np.ndarray] | None = None,
                   options: IsolationOptions = IsolationOptions()) -> tuple[Capture, dict]:
    """``capture`` with depth left only on the object's pixels (a new capture unless nothing
    was dropped) and a summary: pixels dropped as room planes and as other things, and the
    object's box. ``box``: the object's world extent (lo, hi) when the user knows it."""
    from .depth_cleanup import is_noisy, noise_level, outliers

    if "object_isolation" in capture.extra:
        return capture, capture.extra["object_isolation"]
    region = object_region(capture, box, options)
    rng = np.random.default_rng(0)
    per_frame, kept_points, kept_unsure = [], [], []
    room_planes = []
    for frame in capture.frames:
        rows, cols, world = _frame_points(frame)
        near = np.zeros_like(frame.depth)  # the noise on the object, not on a far floor
        inside = region.contains(world)
        near[rows[inside], cols[inside]] = frame.depth[rows[inside], cols[inside]]
        noise = noise_level(near)
        tolerance, wide = plane_tolerance(frame.depth[rows, cols], inside, noise, region,
                                          options)
        plane, found = scenery_planes(world, tolerance, wide, inside, region, rng, options)
        room_planes.append(found)
        # the cleanup's outliers (it drops them next) link no clusters; exact depth has none,
        # and no smear: its foot is joined in the image alone, as before
        noisy = is_noisy(noise)
        unsure = outliers(frame.depth, noise)[rows, cols] if noisy else \
            np.zeros(len(rows), bool)
        per_frame.append((rows, cols, world, plane, wide, unsure, wide if noisy else np.inf))
    # a room plane that many views saw is the room's in every view (where a view sees
    # little of it outside the region, that view alone would take it for a face)
    shared = agreed_planes(room_planes, float(np.median(np.concatenate(
        [f[4] for f in per_frame]))), options)
    for _, _, world, plane, wide, unsure, _ in per_frame:
        for normal, offset in shared:
            plane |= np.abs(world @ normal + offset) <= wide
        kept_points.append(world[~plane])
        kept_unsure.append(unsure[~plane])
    everything = np.concatenate(kept_points)
    if len(everything) == 0:
        raise InputError("the capture has no depth off the room's planes: no object in it")
    footprint = float(np.median([np.median(f.depth[f.depth > 0]) / f.camera.fl_x
                                 for f in capture.frames if (f.depth > 0).any()]))
    up = views_up(capture.frames, options)
    # in a room (its planes found) the outliers could bridge the object to what stands near
    # it; an object alone keeps them for the cleanup to judge
    in_room = any(room_planes) or bool(shared)
    is_object = object_points(everything, region, box is not None, footprint, options, up,
                              np.concatenate(kept_unsure) if in_room else None)
    if not is_object.any():
        raise InputError("found no object in the capture: nothing off the room's planes "
                         "inside the given --box")
    obj = everything[is_object]
    frames, planes_dropped, other_dropped, returned = [], 0, 0, 0
    start = 0
    for frame, found, (rows, cols, world, plane, *_, step) in zip(capture.frames, room_planes,
                                                                  per_frame, strict=True):
        drop = plane.copy()
        n = int((~plane).sum())
        drop[~plane] = ~is_object[start:start + n]
        start += n
        other_dropped += int((drop & ~plane).sum())
        if plane.any():
            foot = foot_pixels(frame, rows, cols, world, plane, [*found, *shared], ~drop,
                               region.contains(world), step, options)
            drop &= ~foot
            plane = plane & ~foot
            returned += int(foot.sum())
        planes_dropped += int(plane.sum())
        if drop.any():
            depth = frame.depth.copy()
            depth[rows[drop], cols[drop]] = 0.0
            frame = Frame(frame.camera, frame.camera_to_world, frame.rgb, depth, frame.mask,
                          frame.name)
        frames.append(frame)
    summary = {"region": {"centre": np.round(region.centre, 4).tolist(),
                          "radius": round(region.radius, 4), "box_given": box is not None},
               "object_box": [np.round(obj.min(0), 4).tolist(), np.round(obj.max(0), 4).tolist()],
               "plane_pixels_dropped": planes_dropped, "other_pixels_dropped": other_dropped,
               "foot_pixels_kept": returned}
    extra = dict(capture.extra) | {"object_isolation": summary}
    return Capture(frames, list(capture.parts), extra, capture.path), summary
