"""Ground-truth occupancy of a part: inside any of its convex pieces.

Procedural parts are unions of convex solids (boxes and prisms), kept as the part's
collision pieces, so "inside" is exact: all of a piece's face planes have the point behind
them (scipy's ``ConvexHull`` gives the planes). No ray-parity test on the concatenated
visual mesh, which overlapping pieces would fool.
"""

from __future__ import annotations

import numpy as np


def piece_planes(pieces: list) -> list[np.ndarray]:
    """(F, 4) plane equations ``n . x + d <= 0`` inside, one array per convex piece."""
    from scipy.spatial import ConvexHull

    return [ConvexHull(np.asarray(p.vertices, float)).equations for p in pieces]


def inside(planes: list[np.ndarray], points: np.ndarray, tol: float = 0.0) -> np.ndarray:
    """Whether each point lies inside at least one piece."""
    points = np.asarray(points, float)
    occupied = np.zeros(len(points), dtype=bool)
    for eq in planes:
        occupied |= np.all(points @ eq[:, :3].T + eq[:, 3] <= tol, axis=1)
    return occupied


def query_points(surface: np.ndarray, n: int, rng: np.random.Generator,
                 near: float = 0.5, sigma: tuple[float, float] = (0.01, 0.04)) -> np.ndarray:
    """Training queries in the unit cube: ``near`` of them beside the surface (unit-frame
    surface samples moved by Gaussian noise of one of two widths, for sharp boundaries and
    a smooth field), the rest uniform."""
    n_near = int(round(near * n))
    picks = surface[rng.integers(0, len(surface), n_near)]
    scale = np.where(rng.random(n_near) < 0.5, sigma[0], sigma[1])[:, None]
    close = picks + rng.normal(size=picks.shape) * scale
    uniform = rng.uniform(-0.5, 0.5, (n - n_near, 3))
    return np.clip(np.concatenate([close, uniform]), -0.5, 0.5)
