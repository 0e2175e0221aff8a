"""From posed depth images to world-frame point clouds: every pixel back-projected, the
foreground of all views fused, and one cloud per part from per-view part labels.

Clouds are thinned on a voxel grid (open3d) so that parts seen in many views do not
outweigh the rest, and so later stages get a bounded number of points.
"""

from __future__ import annotations

import numpy as np

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


def voxel_downsample(points: np.ndarray, voxel: float) -> np.ndarray:
    """One point (the centroid) per occupied voxel of size ``voxel``."""
    if len(points) == 0 or voxel <= 0:
        return points
    import open3d as o3d

    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points.astype(np.float64)))
    return np.asarray(cloud.voxel_down_sample(voxel).points)


def remove_outliers(points: np.ndarray, neighbours: int = 16, std_ratio: float = 2.5,
                    ) -> np.ndarray:
    """Drop stray points (mislabelled pixels at part borders), by open3d's statistical test."""
    if len(points) <= neighbours:
        return points
    import open3d as o3d

    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points.astype(np.float64)))
    _, keep = cloud.remove_statistical_outlier(neighbours, std_ratio)
    return points[np.asarray(keep, dtype=int)]


def object_diagonal(capture: Capture) -> float:
    """Diagonal of the box around every measured point (the scale later stages work at)."""
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for frame in capture.frames:
        pts, valid = point_map(frame)
        if valid.any():
            lo = np.minimum(lo, pts[valid].min(0))
            hi = np.maximum(hi, pts[valid].max(0))
    if not np.all(np.isfinite(lo)):
        raise ValueError("the capture has no depth: nothing to reconstruct")
    return float(np.linalg.norm(hi - lo))


def foreground_cloud(capture: Capture, voxel: float | None = None) -> np.ndarray:
    """Every measured point of every view, fused and thinned (``voxel`` default: 1/150 of
    the object's diagonal). Background pixels carry no depth in a capture of an object."""
    voxel = object_diagonal(capture) / 150 if voxel is None else voxel
    points = [point_map(f)[0][f.depth > 0] for f in capture.frames]
    return voxel_downsample(np.concatenate(points), voxel)


def part_clouds(capture: Capture, labels: list[np.ndarray] | None = None,
                voxel: float | None = None, clean: bool = False) -> dict[int, np.ndarray]:
    """World points of each part label (> 0) over all views. ``labels`` are per-frame
    (H, W) label images (default: the capture's ground-truth masks)."""
    if labels is None:
        if not capture.has_masks:
            raise ValueError("the capture has no masks; pass labels")
        labels = [f.mask for f in capture.frames]
    voxel = object_diagonal(capture) / 150 if voxel is None else voxel
    gathered: dict[int, list[np.ndarray]] = {}
    for frame, lab in zip(capture.frames, labels, strict=True):
        pts, valid = point_map(frame)
        for k in np.unique(lab[valid]):
            if k > 0:
                gathered.setdefault(int(k), []).append(pts[valid & (lab == k)])
    out = {}
    for k in sorted(gathered):
        cloud = voxel_downsample(np.concatenate(gathered[k]), voxel)
        out[k] = remove_outliers(cloud) if clean else cloud
    return out
