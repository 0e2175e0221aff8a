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
3. what is left, fused over the views, falls into clusters (open3d's DBSCAN): the object is
   the cluster with most points in its region, with any other cluster mostly inside the
   object's box (a part cut off by a gap); clutter and the rest go.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from real2code_export.errors import InputError

from .capture import Capture, Frame


@dataclass(frozen=True)
class IsolationOptions:
    max_planes: int = 8  # planes looked for per frame
    min_plane_share: float = 0.03  # of a frame's points: a smaller plane ends the search
    scenery_share: float = 0.25  # of a plane's points outside the region: floor or wall
    plane_rel: float = 0.004  # plane inlier distance, relative to depth (clean depth) ...
    plane_sigmas: float = 4.0  # ... or this many times the frame's relative noise
    ransac_points: int = 5000  # a frame's points the RANSAC draws from
    ransac_iterations: int = 300
    voxel_rel: float = 0.012  # fusion voxel, of the region's radius
    cluster_voxels: float = 3.0  # DBSCAN's neighbourhood, in voxels, and at least ...
    cluster_pixels: float = 2.5  # ... this many pixels' width at the object's depth
    far_tolerance: float = 3.0  # a room plane's inlier distance outside the region, x
    region_margin: float = 1.1  # the sphere every view holds, grown (an aim a little off)
    box_margin: float = 0.05  # a given box grows by this share of its diagonal
    broad_rel: float = 0.1  # a room plane's points outside the region spread this much (of
    # the region's size, standard deviation across its narrower direction)


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


def scenery_planes(points: np.ndarray, depth: np.ndarray, region: Region, noise_rel: float,
                   rng: np.random.Generator, options: IsolationOptions = IsolationOptions(),
                   ) -> np.ndarray:
    """Which of one frame's world ``points`` (at camera ``depth``) lie on the room's planes."""
    import open3d as o3d

    scenery = np.zeros(len(points), bool)
    searched = np.ones(len(points), bool)  # not yet a plane's
    rel = max(options.plane_rel, options.plane_sigmas * noise_rel)
    tolerance = rel * depth
    inside = region.contains(points)
    # a room plane takes more about it outside the region: far off, a sensor's noise grows
    # faster than the object's noise says (what is left of a floor must not pair up with a
    # face of the object into a plane)
    wide = np.where(inside, 1.0, options.far_tolerance) * tolerance
    for _ in range(options.max_planes):
        pool = np.nonzero(searched)[0]
        if len(pool) < max(50, options.min_plane_share * len(points)):
            break
        sample = pool if len(pool) <= options.ransac_points else \
            rng.choice(pool, options.ransac_points, replace=False)
        cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points[sample]))
        model, _ = cloud.segment_plane(float(np.median(tolerance[sample])), 3,
                                       options.ransac_iterations)
        normal, offset = np.asarray(model[:3]), float(model[3])
        normal_len = np.linalg.norm(normal)
        if normal_len == 0:
            break
        distance = np.abs(points @ normal + offset) / normal_len
        on_plane = searched & (distance <= tolerance)
        if on_plane.sum() < options.min_plane_share * len(points):
            break
        outside = on_plane & ~inside
        if outside.sum() >= options.scenery_share * on_plane.sum() and \
                _broad(points[outside], region, options):
            room = searched & (distance <= wide)
            scenery |= room
            searched &= ~room
        else:  # a face of the object: set aside; what of it lies outside, searched on
            searched &= ~(on_plane & ~outside)
    return scenery


def _broad(points: np.ndarray, region: Region, options: IsolationOptions) -> bool:
    """Whether ``points`` (of one plane) spread in both of its directions: a floor or a wall
    does, where the band in which an object's face's plane cuts them is narrow."""
    if len(points) < 10:
        return False
    spread = np.linalg.svd(points - points.mean(0), compute_uv=False) / np.sqrt(len(points))
    return bool(spread[1] >= options.broad_rel * region.size())


def _object_points(points: np.ndarray, region: Region, boxed: bool, footprint: float,
                   options: IsolationOptions) -> tuple[np.ndarray, np.ndarray, float]:
    """The fused points (voxel down-sampled) that are the object, those that are other
    things (other clusters), and the distance within which a pixel's point belongs to them.
    ``footprint``: a pixel's width on the object (in a small image, its points lie further
    apart than the voxel)."""
    import open3d as o3d

    voxel = options.voxel_rel * region.size()
    eps = max(options.cluster_voxels * voxel, options.cluster_pixels * footprint)
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points)).voxel_down_sample(voxel)
    fused = np.asarray(cloud.points)
    if boxed:
        inside = region.contains(fused)
        return fused[inside], fused[~inside], eps
    labels = np.asarray(cloud.cluster_dbscan(eps=eps, min_points=4))
    inside = region.contains(fused)
    found = [k for k in np.unique(labels) if k >= 0]
    if not found:
        raise InputError("found no object in the capture: no cluster of points near where "
                         "the cameras look (give its extent with --box)")
    main = max(found, key=lambda k: int(np.sum(inside & (labels == k))))
    keep = labels == main
    lo, hi = fused[keep].min(0) - eps, fused[keep].max(0) + eps
    for k in found:
        if k != main:
            member = labels == k
            within = np.all((fused[member] >= lo) & (fused[member] <= hi), axis=1)
            if within.mean() >= 0.5:
                keep |= member
    return fused[keep], fused[~keep & (labels >= 0)], eps


def _belongs(points: np.ndarray, obj, others, eps: float) -> np.ndarray:
    """Which ``points`` are the object's: near its fused points, or a little further off
    (a speck DBSCAN left alone) and nearer them than anything else."""
    to_obj = obj.query(points, distance_upper_bound=4 * eps)[0]
    to_other = np.full(len(points), np.inf) if others is None else \
        others.query(points, distance_upper_bound=4 * eps)[0]
    return (to_obj <= 1.5 * eps) | (np.isfinite(to_obj) & (to_obj < to_other))


def isolate_object(capture: Capture, box: tuple[np.ndarray, np.ndarray] | None = None,
                   options: IsolationOptions = IsolationOptions()) -> tuple[Capture, dict]:
    """``capture`` with depth left only on the object's pixels (a new capture unless nothing
    was dropped) and a summary: pixels dropped as room planes and as other things, and the
    object's box. ``box``: the object's world extent (lo, hi) when the user knows it."""
    from scipy.spatial import cKDTree

    from .depth_cleanup import noise_level

    if "object_isolation" in capture.extra:
        return capture, capture.extra["object_isolation"]
    import open3d as o3d

    region = object_region(capture, box, options)
    rng = np.random.default_rng(0)
    o3d.utility.random.seed(0)  # its RANSAC draws: the same capture, the same result
    per_frame, kept_points = [], []
    for frame in capture.frames:
        rows, cols, world = _frame_points(frame)
        near = np.zeros_like(frame.depth)  # the noise on the object, not on a far floor
        inside = region.contains(world)
        near[rows[inside], cols[inside]] = frame.depth[rows[inside], cols[inside]]
        plane = scenery_planes(world, frame.depth[rows, cols], region, noise_level(near),
                               rng, options)
        per_frame.append((rows, cols, world, plane))
        kept_points.append(world[~plane])
    everything = np.concatenate(kept_points)
    if len(everything) == 0:
        raise InputError("the capture has no depth off the room's planes: no object in it")
    footprint = float(np.median([np.median(f.depth[f.depth > 0]) / f.camera.fl_x
                                 for f in capture.frames if (f.depth > 0).any()]))
    obj, others, eps = _object_points(everything, region, box is not None, footprint, options)
    if len(obj) == 0:
        raise InputError("found no object in the capture: nothing off the room's planes "
                         "inside the given --box")
    tree = cKDTree(obj)
    other_tree = cKDTree(others) if len(others) else None
    frames, planes_dropped, other_dropped = [], 0, 0
    for frame, (rows, cols, world, plane) in zip(capture.frames, per_frame, strict=True):
        near = np.zeros(len(world), bool)
        near[~plane] = _belongs(world[~plane], tree, other_tree, eps)
        drop = ~near
        planes_dropped += int(plane.sum())
        other_dropped += int((drop & ~plane).sum())
        if drop.any():
            depth = frame.depth.copy()
            depth[rows[drop], cols[drop]] = 0.0
            frame = Frame(frame.camera, frame.camera_to_world, frame.rgb, depth, frame.mask,
                          frame.name)
        frames.append(frame)
    summary = {"region": {"centre": np.round(region.centre, 4).tolist(),
                          "radius": round(region.radius, 4), "box_given": box is not None},
               "object_box": [np.round(obj.min(0), 4).tolist(), np.round(obj.max(0), 4).tolist()],
               "plane_pixels_dropped": planes_dropped, "other_pixels_dropped": other_dropped}
    extra = dict(capture.extra) | {"object_isolation": summary}
    return Capture(frames, list(capture.parts), extra, capture.path), summary
