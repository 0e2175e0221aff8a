"""What a real depth camera does to a capture: one model of the faults, parameters as data.

A :class:`SensorModel` names every fault a consumer RGB-D capture has, each a number (0 turns
it off); :data:`PRESETS` holds the sensors users have, and :func:`load_sensor` reads the
same fields from a JSON file for any other. :func:`degrade` applies a model to an exact
capture (``pipeline.render``'s), seeded:

- depth noise along the ray, growing with range: sigma(z) = a + b (z - z0)^2 + c z
  (Nguyen et al. 2012 measured a = 1.2 mm, b = 1.9 mm, z0 = 0.4 m for structured light);
- lateral noise: each pixel reads the depth a little beside it (sigma in pixels), which
  smears depth across silhouettes;
- missing depth: scattered pixels, holes (blobs), surfaces seen at grazing angles, beyond
  the sensor's range, and pixels on depth edges;
- flying pixels: on depth edges, depths between the near and the far surface;
- quantisation: a fixed step, and a step growing with z^2 (a disparity step);
- pose error: every recorded camera pose off by a random rotation and shift;
- colour: exposure that varies per frame, pixel noise, and motion blur (optional).

Ground-truth masks are left as rendered: they describe the scene, not the sensor.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, fields, replace
from pathlib import Path

import numpy as np

from real2code_export.errors import FormatError, InputError

from .capture import Capture, Frame


@dataclass(frozen=True)
class SensorModel:
    name: str = "clean"
    # depth noise along the ray (m): a + b (z - z0)^2 + c z
    noise_a: float = 0.0
    noise_b: float = 0.0
    noise_z0: float = 0.4
    noise_c: float = 0.0
    lateral_px: float = 0.0  # sigma of where a pixel's depth is read from
    missing: float = 0.0  # share of pixels with no depth, scattered
    holes: float = 0.0  # mean number of holes (blobs with no depth) per frame
    hole_px: float = 4.0  # mean hole radius in pixels
    grazing_deg: float = 90.0  # no depth where the surface is turned further than this
    max_range: float = 0.0  # m; 0: no limit
    edge_drop: float = 0.0  # share of depth-edge pixels with no depth
    flying: float = 0.0  # share of depth-edge pixels given a depth between the surfaces
    edge_jump: float = 0.05  # m: a depth step this large (relative to z) is an edge
    depth_step: float = 0.0  # m, quantisation
    disparity_step: float = 0.0  # 1/m: quantisation step growing with z^2
    pose_deg: float = 0.0  # sigma of each camera's rotation error
    pose_m: float = 0.0  # sigma of each camera's position error (per axis)
    exposure: float = 0.0  # sigma of each frame's log gain
    rgb_noise: float = 0.0  # sigma, in 8-bit levels
    blur_px: float = 0.0  # motion blur length in pixels (0: none)

    def to_json(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}


# The sensors users have. Figures from the sensors' published evaluations, rounded: phone
# LiDAR (ARKit depth, low resolution upsampled: wide lateral smear, edges lost, tracking
# drift), structured light (Kinect-v1-like, Nguyen et al. 2012), time of flight
# (Azure-Kinect-like: little noise, flying pixels at edges, grazing surfaces dark).
PRESETS: dict[str, SensorModel] = {
    "clean": SensorModel(),
    "phone-lidar": SensorModel(
        "phone-lidar", noise_a=0.002, noise_b=0.0015, lateral_px=1.2,
        missing=0.02, holes=1.0, hole_px=3.0, grazing_deg=80.0, max_range=5.0,
        edge_drop=0.5, flying=0.2, depth_step=0.001, pose_deg=0.5, pose_m=0.005,
        exposure=0.1, rgb_noise=3.0),
    "structured-light": SensorModel(
        "structured-light", noise_a=0.0012, noise_b=0.0019, lateral_px=0.8, missing=0.02,
        holes=2.0, hole_px=4.0, grazing_deg=75.0, max_range=4.0, edge_drop=0.6,
        flying=0.05, depth_step=0.001, disparity_step=0.0003, pose_deg=0.3, pose_m=0.003,
        exposure=0.05, rgb_noise=2.0),
    "time-of-flight": SensorModel(
        "time-of-flight", noise_a=0.001, noise_c=0.001, lateral_px=0.5, missing=0.01,
        holes=0.5, hole_px=3.0, grazing_deg=80.0, max_range=5.5, edge_drop=0.2, flying=0.5,
        depth_step=0.001, pose_deg=0.3, pose_m=0.003, exposure=0.05, rgb_noise=2.0),
}
DEFAULT_PRESET = "clean"


def load_sensor(spec: str | Path) -> SensorModel:
    """A preset by name, or a JSON file of :class:`SensorModel` fields (those left out stay
    at the clean values)."""
    if str(spec) in PRESETS:
        return PRESETS[str(spec)]
    path = Path(spec)
    if path.suffix != ".json":
        raise InputError(f"unknown capture preset {str(spec)!r}; choose from {list(PRESETS)} "
                         "or give a sensor JSON file")
    if not path.is_file():
        raise FormatError(path, None, "no such file (a sensor model JSON)")
    try:
        doc = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise FormatError(path, None, f"not valid JSON: {e}", getattr(e, "lineno", None)) from e
    if not isinstance(doc, dict):
        raise FormatError(path, None, "expected an object of sensor fields")
    known = {f.name: f for f in fields(SensorModel)}
    values = {}
    for key, value in doc.items():
        if key not in known:
            raise FormatError(path, key, f"unknown sensor field; known: {sorted(known)}")
        if key == "name":
            if not isinstance(value, str):
                raise FormatError(path, key, "expected a string")
        elif isinstance(value, bool) or not isinstance(value, (int, float)) or value < 0:
            raise FormatError(path, key, f"expected a number >= 0, got {value!r}")
        values[key] = value
    return replace(SensorModel(name=path.stem), **values)


# -- the faults ------------------------------------------------------------------------------
def _edges(depth: np.ndarray, jump: float) -> tuple[np.ndarray, np.ndarray]:
    """Pixels on a depth edge (a 4-neighbour more than ``jump * z`` farther or missing) and
    the far side's depth there (0 where the far side is empty)."""
    pad = np.pad(depth, 1, mode="edge")  # the image's border is no edge
    neighbours = np.stack([pad[:-2, 1:-1], pad[2:, 1:-1], pad[1:-1, :-2], pad[1:-1, 2:]])
    far = np.where(neighbours == 0, np.inf, neighbours)
    step = (far - depth[None]) > jump * np.maximum(depth[None], 1e-6)
    edge = (depth > 0) & step.any(axis=0)
    farthest = np.where(step, neighbours, 0.0).max(axis=0)
    return edge, farthest


def _grazing(frame: Frame, depth: np.ndarray) -> np.ndarray:
    """The cosine between each pixel's surface normal and its viewing ray (1: facing)."""
    from .fuse import normals_from_points

    dirs = frame.camera.pixel_directions()
    points = dirs * depth[..., None]
    normals = normals_from_points(points, depth > 0)
    view = -dirs / np.linalg.norm(dirs, axis=-1, keepdims=True)
    known = np.linalg.norm(normals, axis=-1) > 0.5
    return np.where(known, np.abs(np.sum(normals * view, axis=-1)), 1.0)


def _holes(shape: tuple[int, int], count: float, radius: float,
           rng: np.random.Generator) -> np.ndarray:
    h, w = shape
    out = np.zeros(shape, dtype=bool)
    rows, cols = np.mgrid[:h, :w]
    for _ in range(rng.poisson(count)):
        r0, c0 = rng.uniform(0, h), rng.uniform(0, w)
        rad = rng.exponential(radius)
        out |= (rows - r0) ** 2 + (cols - c0) ** 2 <= rad ** 2
    return out


def degrade_depth(frame: Frame, sensor: SensorModel, rng: np.random.Generator) -> np.ndarray:
    depth = frame.depth.astype(np.float64)
    h, w = depth.shape
    if sensor.lateral_px > 0:  # read each pixel's depth from a little beside it
        rows = np.clip(np.rint(np.arange(h)[:, None] + rng.normal(0, sensor.lateral_px, (h, w))),
                       0, h - 1).astype(int)
        cols = np.clip(np.rint(np.arange(w)[None] + rng.normal(0, sensor.lateral_px, (h, w))),
                       0, w - 1).astype(int)
        depth = depth[rows, cols]
    valid = depth > 0
    edge, far = _edges(depth, sensor.edge_jump)
    if sensor.flying > 0:
        fly = edge & (rng.random((h, w)) < sensor.flying)
        far_side = np.where(far > 0, far, depth * (1 + rng.uniform(0.05, 0.3, (h, w))))
        t = rng.uniform(0.0, 1.0, (h, w))
        depth = np.where(fly, depth + t * (far_side - depth), depth)
    drop = ~valid
    if sensor.edge_drop > 0:
        drop |= edge & (rng.random((h, w)) < sensor.edge_drop)
    if sensor.grazing_deg < 90.0:
        drop |= _grazing(frame, frame.depth) < np.cos(np.radians(sensor.grazing_deg))
    if sensor.missing > 0:
        drop |= rng.random((h, w)) < sensor.missing
    if sensor.holes > 0:
        drop |= _holes((h, w), sensor.holes, sensor.hole_px, rng)
    sigma = (sensor.noise_a + sensor.noise_b * (depth - sensor.noise_z0) ** 2
             + sensor.noise_c * depth)
    depth = depth + rng.normal(0.0, 1.0, (h, w)) * sigma
    if sensor.disparity_step > 0:
        step = sensor.disparity_step * depth ** 2
        depth = np.where(step > 0, np.round(depth / np.where(step > 0, step, 1)) * step, depth)
    if sensor.depth_step > 0:
        depth = np.round(depth / sensor.depth_step) * sensor.depth_step
    drop |= depth <= 0
    if sensor.max_range > 0:
        drop |= depth > sensor.max_range
    return np.where(drop, 0.0, depth).astype(np.float32)


def degrade_rgb(rgb: np.ndarray, sensor: SensorModel, rng: np.random.Generator) -> np.ndarray:
    out = rgb.astype(np.float64)
    if sensor.blur_px >= 1:  # a straight streak in a random direction
        from scipy.ndimage import convolve

        n = int(round(sensor.blur_px))
        kernel = np.zeros((2 * n + 1, 2 * n + 1))
        angle = rng.uniform(0, np.pi)
        for t in np.linspace(-n / 2, n / 2, 2 * n + 1):
            kernel[int(round(n + t * np.sin(angle))), int(round(n + t * np.cos(angle)))] = 1
        kernel /= kernel.sum()
        out = np.stack([convolve(out[..., c], kernel, mode="nearest") for c in range(3)], -1)
    if sensor.exposure > 0:
        out = out * np.exp(rng.normal(0.0, sensor.exposure))
    if sensor.rgb_noise > 0:
        out = out + rng.normal(0.0, sensor.rgb_noise, out.shape)
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


def perturbed_pose(pose: np.ndarray, sensor: SensorModel, rng: np.random.Generator,
                   ) -> np.ndarray:
    """``pose`` as a tracker records it: off by a random rotation and shift."""
    from scipy.spatial.transform import Rotation

    out = pose.copy()
    if sensor.pose_deg > 0:
        turn = Rotation.from_rotvec(rng.normal(0.0, np.radians(sensor.pose_deg), 3))
        out[:3, :3] = turn.as_matrix() @ pose[:3, :3]
    if sensor.pose_m > 0:
        out[:3, 3] = pose[:3, 3] + rng.normal(0.0, sensor.pose_m, 3)
    return out


def degrade(capture: Capture, sensor: SensorModel, seed: int = 0) -> Capture:
    """``capture`` as ``sensor`` would have recorded it (a new capture; seeded)."""
    if replace(sensor, name="clean") == PRESETS["clean"]:  # no fault, whatever its name
        frames = capture.frames
    else:
        rng = np.random.default_rng(seed)
        frames = [Frame(f.camera, perturbed_pose(f.camera_to_world, sensor, rng),
                        degrade_rgb(f.rgb, sensor, rng), degrade_depth(f, sensor, rng),
                        f.mask, f.name) for f in capture.frames]
    extra = dict(capture.extra) | {"sensor": sensor.to_json()}
    return Capture(frames, list(capture.parts), extra, capture.path)
