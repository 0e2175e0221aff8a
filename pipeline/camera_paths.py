"""Where the cameras of a capture stand: paths that know nothing of the object's joints.

A person scanning an object walks around it (a full ring), stands on one side of it (a half
ring from wherever they happen to start) or holds the phone unevenly (a hand-held path:
uneven steps in azimuth, height that wanders, the aim a little off the centre and a little
roll). ``front-arc`` is the old renderer's arc centred on the direction the object's parts
open, which only a capture that knows the ground truth can choose: an explicit option for
comparison, never a default.

Every path looks (about) at the object's centre from far enough to keep a sphere of the
object's radius in view, times a distance factor (``near``, ``mid``, ``far``). Seeded: the
same generator state gives the same cameras.
"""

from __future__ import annotations

import numpy as np

from real2code_export.errors import InputError

from .capture import Camera

PATHS = ("ring", "half-ring", "handheld", "front-arc")
DEFAULT_PATH = "ring"
# Distance from the object's centre, in multiples of the distance that just fits its
# bounding sphere in view (near: it fills the image; far: a quarter of the image or so).
DISTANCES = {"near": (1.0, 1.08), "mid": (1.02, 1.2), "far": (1.6, 2.2)}
DEFAULT_DISTANCE = "mid"
ELEVATION_DEG = (10.0, 50.0)  # above the horizontal through the centre
FRONT_ARC_DEG = 120.0


def look_at(eye: np.ndarray, target: np.ndarray, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Camera-to-world transform (OpenGL axes: looking down -z, y up) at ``eye``."""
    z = np.asarray(eye, float) - np.asarray(target, float)
    z /= np.linalg.norm(z)
    x = np.cross(up, z)
    if np.linalg.norm(x) < 1e-9:  # looking straight down: any horizontal x
        x = np.cross([0.0, 1.0, 0.0], z)
    x /= np.linalg.norm(x)
    out = np.eye(4)
    out[:3, 0], out[:3, 1], out[:3, 2], out[:3, 3] = x, np.cross(z, x), z, eye
    return out


def _rolled(pose: np.ndarray, roll: float) -> np.ndarray:
    """``pose`` turned by ``roll`` radians about its viewing axis."""
    c, s = np.cos(roll), np.sin(roll)
    out = pose.copy()
    out[:3, 0] = c * pose[:3, 0] + s * pose[:3, 1]
    out[:3, 1] = -s * pose[:3, 0] + c * pose[:3, 1]
    return out


def _azimuths(path: str, n: int, rng: np.random.Generator) -> np.ndarray:
    start = rng.uniform(0.0, 2 * np.pi)
    if path == "ring":
        return start + 2 * np.pi * np.arange(n) / n
    if path == "half-ring":
        return start + np.pi * np.linspace(0.0, 1.0, n)
    if path == "handheld":
        # a sweep of 200-360 degrees in steps of uneven length (a Dirichlet split)
        sweep = np.radians(rng.uniform(200.0, 360.0))
        steps = rng.dirichlet(np.full(n, 1.5)) * sweep
        return start + np.concatenate([[0.0], np.cumsum(steps[:-1])])
    raise InputError(f"unknown camera path {path!r}")


def _front_arc(center: np.ndarray, fit: float, front: np.ndarray | None, n: int,
               rng: np.random.Generator, distance: tuple[float, float]) -> list[np.ndarray]:
    """The old renderer's arc, draw for draw as it was (the shipped mask network's training
    views were taken on it): evenly over the arc, each jittered, at a random elevation."""
    if front is None:
        raise InputError("the front-arc camera path needs the object's opening direction")
    base_az = np.arctan2(front[1], front[0])
    offsets = np.linspace(-0.5, 0.5, n) * np.radians(FRONT_ARC_DEG) if n > 1 else np.zeros(1)
    step = np.radians(FRONT_ARC_DEG) / max(1, n - 1)
    poses = []
    for off in offsets:
        az = base_az + off + rng.uniform(-0.3, 0.3) * step
        el = np.radians(rng.uniform(*ELEVATION_DEG))
        d = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
        poses.append(look_at(center + fit * rng.uniform(*distance) * d, center))
    return poses


def _elevations(path: str, n: int, rng: np.random.Generator) -> np.ndarray:
    lo, hi = np.radians(ELEVATION_DEG)
    if path != "handheld":
        return rng.uniform(lo, hi, n)
    # a hand's height wanders: a random walk, kept within the band
    walk = np.cumsum(rng.normal(0.0, 0.25 * (hi - lo), n)) + rng.uniform(lo, hi)
    return np.clip(walk, lo - np.radians(5.0), hi)


def camera_path(path: str, center: np.ndarray, radius: float, camera: Camera, n_views: int,
                rng: np.random.Generator, *, distance: str = DEFAULT_DISTANCE,
                front: np.ndarray | None = None) -> list[np.ndarray]:
    """``n_views`` camera-to-world poses on ``path`` (one of :data:`PATHS`) around a sphere
    of ``radius`` at ``center``. ``front`` (the opening direction) only for ``front-arc``."""
    if path not in PATHS:
        raise InputError(f"unknown camera path {path!r}; choose from {list(PATHS)}")
    if distance not in DISTANCES:
        raise InputError(f"unknown camera distance {distance!r}; choose from "
                         f"{list(DISTANCES)}")
    if n_views < 1:
        raise InputError(f"need at least one view, got {n_views}")
    half_fov = np.arctan(0.5 * min(camera.width / camera.fl_x, camera.height / camera.fl_y))
    fit = radius / np.sin(half_fov)
    if path == "front-arc":
        return _front_arc(center, fit, front, n_views, rng, DISTANCES[distance])
    azimuth = _azimuths(path, n_views, rng)
    elevation = _elevations(path, n_views, rng)
    factor = rng.uniform(*DISTANCES[distance], n_views)
    poses = []
    for az, el, f in zip(azimuth, elevation, factor, strict=True):
        d = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
        target = np.asarray(center, float)
        if path == "handheld":  # aimed by eye: a little off the centre, a little rolled
            target = target + rng.normal(0.0, 0.05 * radius, 3)
            f = f * 1.05  # room for the aim being off
        pose = look_at(target + f * fit * d, target)
        if path == "handheld":
            pose = _rolled(pose, np.radians(rng.normal(0.0, 3.0)))
        poses.append(pose)
    return poses
