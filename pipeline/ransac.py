"""A plane found by RANSAC, repeatable: the same points and generator give the same plane.

open3d's ``PointCloud.segment_plane`` returned other planes from run to run with its seed set
(its RANSAC runs in parallel): the hand-held phone-LiDAR room test failed 3 of 12 runs.
This is plain RANSAC in numpy over one seeded generator: the best of ``iterations``
three-point planes by inlier count, refitted to its inliers by least squares."""

from __future__ import annotations

import numpy as np


def fit_plane(points: np.ndarray, threshold: float, iterations: int,
              rng: np.random.Generator) -> tuple[np.ndarray, float, np.ndarray]:
    """The plane through most of ``points`` (n, 3) within ``threshold``: its unit normal,
    its offset d (n . x + d = 0) and the indices of its inliers. A zero normal where no
    three points span a plane."""
    n = len(points)
    if n < 3:
        return np.zeros(3), 0.0, np.zeros(0, int)
    picks = rng.integers(0, n, size=(iterations, 3))
    a, b, c = points[picks[:, 0]], points[picks[:, 1]], points[picks[:, 2]]
    normals = np.cross(b - a, c - a)
    lengths = np.linalg.norm(normals, axis=1)
    valid = lengths > 1e-12
    if not valid.any():
        return np.zeros(3), 0.0, np.zeros(0, int)
    normals = normals[valid] / lengths[valid, None]
    offsets = -np.einsum("ij,ij->i", normals, a[valid])
    counts = (np.abs(points @ normals.T + offsets) <= threshold).sum(axis=0)
    best = int(np.argmax(counts))  # the first of equals: the draw order decides, not threads
    inliers = np.nonzero(np.abs(points @ normals[best] + offsets[best]) <= threshold)[0]
    centre = points[inliers].mean(axis=0)
    normal = np.linalg.svd(points[inliers] - centre, full_matrices=False)[2][-1]
    return normal, float(-normal @ centre), inliers
