"""Partial views of an object's parts, as a posed RGB-D capture would give them.

Cameras (12 by default, like the paper's renders) stand around the object, a little above
it and looking at its centre: on a full ring, or on an arc in front of the object as the
capture renderer (``pipeline.render``) places them, so backs are then unseen. Every camera casts one ray per pixel into all
parts at once (open3d's ``RaycastingScene`` on the CPU), so a part is seen only where no
other part is in front of it: the insides of drawers and the backs of doors stay hidden, as
in fused depth. Depth is quantised and noisy like a 16-bit depth PNG, and pixels on the
border between two parts may take their neighbour's label, as predicted masks do.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ViewSettings:
    views: int = 12
    arc_deg: float = 360.0  # the azimuth span, centred on the object's front
    sizes: tuple[int, ...] = (128, 160, 192, 256)  # square images, one size drawn per object
    elevation_deg: tuple[float, float] = (10.0, 50.0)
    distance: tuple[float, float] = (2.0, 3.0)  # in bounding-sphere radii
    fov_deg: float = 50.0
    depth_noise: float = 0.002  # m, Gaussian along the ray
    depth_step: float = 0.001  # m, the quantisation of a 16-bit millimetre depth PNG
    border_swap: float = 0.3  # chance that a pixel next to another part takes its label


DEFAULT_VIEWS = ViewSettings()


def ring_cameras(center: np.ndarray, radius: float, settings: ViewSettings,
                 rng: np.random.Generator, front=(1.0, 0.0, 0.0)) -> np.ndarray:
    """Eye positions (views, 3): evenly spaced azimuths (a full ring from a random start, or
    an arc centred on ``front``), each at its own random elevation and distance."""
    n = settings.views
    if settings.arc_deg >= 360.0:
        azimuth = rng.uniform(0, 2 * np.pi) + 2 * np.pi * np.arange(n) / n
    else:
        azimuth = (np.arctan2(front[1], front[0])
                   + np.radians(settings.arc_deg) * np.linspace(-0.5, 0.5, n))
    elevation = np.radians(rng.uniform(*settings.elevation_deg, n))
    distance = radius * rng.uniform(*settings.distance, n)
    direction = np.stack([np.cos(elevation) * np.cos(azimuth),
                          np.cos(elevation) * np.sin(azimuth), np.sin(elevation)], axis=1)
    return np.asarray(center) + distance[:, None] * direction


def _border(labels: np.ndarray) -> np.ndarray:
    """Pixels with a 4-neighbour of another label (background included)."""
    border = np.zeros(labels.shape, dtype=bool)
    for axis in (0, 1):
        diff = np.diff(labels, axis=axis) != 0
        lo = [slice(None)] * 2
        hi = [slice(None)] * 2
        lo[axis], hi[axis] = slice(None, -1), slice(1, None)
        border[tuple(lo)] |= diff
        border[tuple(hi)] |= diff
    return border


def cast_views(meshes: list, rng: np.random.Generator, settings: ViewSettings = DEFAULT_VIEWS,
               threads: int = 0, front=(1.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """World points seen by the cameras and the index of the part each was labelled with.

    ``meshes``: the parts in the world frame (anything with ``vertices`` and ``faces``).
    Returns ``(points (N, 3), labels (N,))`` over all views together. ``threads``: for the
    ray caster (0: all cores; data workers use 1 each). ``front``: the world direction the
    object faces, the centre of an arc of cameras.
    """
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene(nthreads=threads)
    for m in meshes:
        scene.add_triangles(o3d.core.Tensor(np.asarray(m.vertices, dtype=np.float32)),
                            o3d.core.Tensor(np.asarray(m.faces, dtype=np.uint32)))
    corners = np.concatenate([np.asarray(m.vertices) for m in meshes])
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    center, radius = (lo + hi) / 2, float(np.linalg.norm(hi - lo) / 2)
    size = int(rng.choice(settings.sizes))
    points, labels = [], []
    for eye in ring_cameras(center, radius, settings, rng, front):
        rays = o3d.t.geometry.RaycastingScene.create_rays_pinhole(
            fov_deg=settings.fov_deg, center=center.tolist(), eye=eye.tolist(),
            up=[0.0, 0.0, 1.0], width_px=size, height_px=size)
        hit = scene.cast_rays(rays, nthreads=threads)
        t = hit["t_hit"].numpy()
        ids = hit["geometry_ids"].numpy().astype(np.int64)
        seen = np.isfinite(t)
        label = np.where(seen, ids, -1)
        swap = _border(label) & seen & (rng.random(label.shape) < settings.border_swap)
        if swap.any():  # a border pixel takes the label of a random seen 4-neighbour
            padded = np.pad(label, 1, constant_values=-1)
            shifts = [(0, 1), (2, 1), (1, 0), (1, 2)]
            pick = rng.integers(0, 4, label.shape)
            neighbour = np.choose(pick, [padded[r:r + size, c:c + size] for r, c in shifts])
            label = np.where(swap & (neighbour >= 0), neighbour, label)
        r = rays.numpy()[seen]
        direction = r[:, 3:] / np.linalg.norm(r[:, 3:], axis=1, keepdims=True)
        distance = t[seen] * np.linalg.norm(r[:, 3:], axis=1)
        distance = distance + rng.normal(0.0, settings.depth_noise, distance.shape)
        if settings.depth_step > 0:
            distance = np.round(distance / settings.depth_step) * settings.depth_step
        points.append(r[:, :3] + direction * distance[:, None])
        labels.append(label[seen])
    return np.concatenate(points), np.concatenate(labels)


def partial_clouds(meshes: list, rng: np.random.Generator, settings: ViewSettings = DEFAULT_VIEWS,
                   threads: int = 0, front=(1.0, 0.0, 0.0)) -> list[np.ndarray]:
    """One world-frame point cloud per part (possibly empty), from the same views."""
    points, labels = cast_views(meshes, rng, settings, threads, front)
    return [points[labels == k] for k in range(len(meshes))]
