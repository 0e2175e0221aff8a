"""From posed depth images to world-frame point clouds: every pixel back-projected, the
foreground of all views fused, and one cloud per part from per-view part labels.

Clouds are thinned on a voxel grid (open3d) so that parts seen in many views do not
outweigh the rest, and so later stages get a bounded number of points. Each point can
carry the surface normal its views measured: from each depth map on its own (central
differences of the back-projected pixels), so the two faces of a thin panel, seen from
either side, never blur into one another as they do in a normal fitted to the fused
points' neighbours.
"""

from __future__ import annotations

import numpy as np

from real2code_export.errors import InputError

from .capture import Capture, Frame


def point_map(frame: Frame) -> tuple[np.ndarray, np.ndarray]:
    """(H, W, 3) world point of every pixel and the (H, W) mask of pixels with depth."""
    dirs = frame.camera.pixel_directions()  # z = -1: scaling by the z-depth lands on the hit
    cam = dirs * frame.depth[..., None]
    world = cam @ frame.camera_to_world[:3, :3].T + frame.camera_to_world[:3, 3]
    return world, frame.depth > 0


def project(frame: Frame, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixel coordinates (N, 2: u, v, continuous) and z-depth of world points in ``frame``."""
    w2c = frame.world_to_camera()
    cam = points @ w2c[:3, :3].T + w2c[:3, 3]
    return frame.camera.project(cam)


def visible(frame: Frame, points: np.ndarray, tolerance: float = 0.01,
            ) -> tuple[np.ndarray, np.ndarray]:
    """Which world points ``frame`` sees (inside the image, in front of the camera and not
    hidden: their depth within ``tolerance`` metres of the measured one), and their integer
    pixel (N, 2: row, column)."""
    uv, z = project(frame, points)
    h, w = frame.depth.shape
    inside = np.isfinite(uv).all(axis=1) & (z > 0)
    inside &= (uv[:, 0] >= 0) & (uv[:, 0] < w) & (uv[:, 1] >= 0) & (uv[:, 1] < h)
    col = np.clip(np.floor(np.nan_to_num(uv[:, 0])).astype(int), 0, w - 1)
    row = np.clip(np.floor(np.nan_to_num(uv[:, 1])).astype(int), 0, h - 1)
    measured = frame.depth[row, col]
    seen = inside & (measured > 0) & (np.abs(measured - z) <= tolerance)
    return seen, np.stack([row, col], axis=1)


def normals_from_points(points: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Unit normals (camera frame, facing the camera) of a camera-frame point grid by
    central differences; 0 where a neighbour is missing or across a depth jump."""
    n = np.zeros_like(points)
    dx = points[1:-1, 2:] - points[1:-1, :-2]
    dy = points[2:, 1:-1] - points[:-2, 1:-1]
    cross = np.cross(dx, dy)
    norm = np.linalg.norm(cross, axis=-1, keepdims=True)
    depth = -points[..., 2]
    ok = valid[1:-1, 1:-1] & valid[1:-1, 2:] & valid[1:-1, :-2] & valid[2:, 1:-1] & valid[:-2, 1:-1]
    jump = np.maximum(np.abs(dx[..., 2]), np.abs(dy[..., 2])) > 0.1 * depth[1:-1, 1:-1]
    ok &= ~jump & (norm[..., 0] > 1e-12)
    unit = cross / np.where(norm > 0, norm, 1.0)
    facing = np.sign(np.sum(unit * -points[1:-1, 1:-1], axis=-1, keepdims=True))
    n[1:-1, 1:-1] = np.where(ok[..., None], unit * np.where(facing == 0, 1, facing), 0.0)
    return n


def flat_pixels(points: np.ndarray, tolerance: float = 0.1) -> np.ndarray:
    """(H, W) mask of the pixels whose 3 x 3 stencil lies on one plane: the steps to the
    left and to the right (and up and down) agree within ``tolerance`` of their length.
    Central differences across an edge or a small step (a drawer's rim, a door's trim) give
    a normal between the two faces'."""
    out = np.zeros(points.shape[:2], dtype=bool)
    c = points[1:-1, 1:-1]
    ok = np.ones(c.shape[:2], dtype=bool)
    steps = ((points[1:-1, :-2], points[1:-1, 2:]), (points[:-2, 1:-1], points[2:, 1:-1]))
    for before, after in steps:
        back, ahead = c - before, after - c
        scale = np.linalg.norm(back, axis=-1) + np.linalg.norm(ahead, axis=-1)
        ok &= np.linalg.norm(ahead - back, axis=-1) <= tolerance * scale
    out[1:-1, 1:-1] = ok
    return out


def normal_map(frame: Frame) -> np.ndarray:
    """(H, W, 3) world-frame unit normal of the surface under every pixel, from the depth
    map alone; 0 where it cannot tell (no depth, a missing neighbour, a depth jump, an
    edge: :func:`flat_pixels`)."""
    points = frame.camera.pixel_directions() * frame.depth[..., None]
    normals = normals_from_points(points, frame.depth > 0)
    normals[~flat_pixels(points)] = 0.0
    return normals @ frame.camera_to_world[:3, :3].T


def axis_mean(samples: np.ndarray, points: np.ndarray, normals: np.ndarray,
              neighbours: int = 8) -> np.ndarray:
    """The normal at each of ``samples``: the sign-free mean (principal axis of the scatter
    n n^T) of the normals of its ``neighbours`` nearest ``points``, scaled by how well they
    agree (1 when all are parallel, about 1/3 when they point every way). Sign-free: a
    panel's two faces, measured from either side, point opposite ways along one axis."""
    from scipy.spatial import cKDTree

    known = np.linalg.norm(normals, axis=1) > 0.5
    if known.sum() == 0 or len(samples) == 0:
        return np.zeros_like(samples)
    k = min(neighbours, int(known.sum()))
    _, near = cKDTree(points[known]).query(samples, k)
    n = normals[known][near.reshape(len(samples), k)]
    values, vectors = np.linalg.eigh(np.einsum("mki,mkj->mij", n, n) / k)
    return vectors[:, :, 2] * values[:, 2:3]


def voxel_downsample(points: np.ndarray, voxel: float) -> np.ndarray:
    """One point (the centroid) per occupied voxel of size ``voxel``."""
    if len(points) == 0 or voxel <= 0:
        return points
    import open3d as o3d

    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points.astype(np.float64)))
    return np.asarray(cloud.voxel_down_sample(voxel).points)


def inliers(points: np.ndarray, neighbours: int = 16, std_ratio: float = 2.5,
            ) -> np.ndarray:
    """Indices of the points that are not strays (mislabelled pixels at part borders), by
    open3d's statistical test."""
    if len(points) <= neighbours:
        return np.arange(len(points))
    import open3d as o3d

    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points.astype(np.float64)))
    _, keep = cloud.remove_statistical_outlier(neighbours, std_ratio)
    return np.asarray(keep, dtype=int)


def object_diagonal(capture: Capture) -> float:
    """Diagonal of the box around every measured point (the scale later stages work at)."""
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for frame in capture.frames:
        pts, valid = point_map(frame)
        if valid.any():
            lo = np.minimum(lo, pts[valid].min(0))
            hi = np.maximum(hi, pts[valid].max(0))
    if not np.all(np.isfinite(lo)):
        raise InputError("the capture has no depth: nothing to reconstruct")
    return float(np.linalg.norm(hi - lo))


def oriented_part_clouds(capture: Capture, labels: list[np.ndarray] | None = None,
                         voxel: float | None = None, clean: bool = False,
                         ) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """World points of each part label (> 0) over all views, and at each point the normal
    its views measured (:func:`axis_mean`; unit length times agreement). ``labels`` are
    per-frame (H, W) label images (default: the capture's ground-truth masks); ``clean``
    drops stray points."""
    if labels is None:
        if not capture.has_masks:
            raise InputError("the capture has no masks; pass labels")
        labels = [f.mask for f in capture.frames]
    voxel = object_diagonal(capture) / 150 if voxel is None else voxel
    gathered: dict[int, list[tuple[np.ndarray, np.ndarray]]] = {}
    for frame, lab in zip(capture.frames, labels, strict=True):
        pts, valid = point_map(frame)
        normals = normal_map(frame)
        for k in np.unique(lab[valid]):
            if k > 0:
                where = valid & (lab == k)
                gathered.setdefault(int(k), []).append((pts[where], normals[where]))
    out = {}
    for k in sorted(gathered):
        points = np.concatenate([p for p, _ in gathered[k]])
        cloud = voxel_downsample(points, voxel)
        if clean:
            cloud = cloud[inliers(cloud)]
        out[k] = (cloud, axis_mean(cloud, points, np.concatenate([n for _, n in gathered[k]])))
    return out


def part_clouds(capture: Capture, labels: list[np.ndarray] | None = None,
                voxel: float | None = None, clean: bool = False) -> dict[int, np.ndarray]:
    """World points of each part label (> 0) over all views (:func:`oriented_part_clouds`
    without the normals)."""
    return {k: pts for k, (pts, _) in
            oriented_part_clouds(capture, labels, voxel, clean).items()}
