"""The capture folder: posed RGB-D frames in nerfstudio's ``transforms.json`` convention.

Layout (docs/design.md)::

    CAPTURE/transforms.json      cameras, frames, parts
    CAPTURE/images/frame_00000.png   RGB, 8 bit
    CAPTURE/depth/frame_00000.png    depth, 16 bit; metres = value * depth_unit_scale_factor
    CAPTURE/masks/frame_00000.png    part index, 16 bit; 0 = background, k = parts[k - 1]
    CAPTURE/ground_truth/object.json the object that was rendered (synthetic captures only)

Conventions, as nerfstudio's: ``transform_matrix`` is camera-to-world with OpenGL camera
axes (x right, y up, looking down -z); pixel (u, v) is sampled at its centre (u + 0.5,
v + 0.5); depth is the z-depth along the viewing axis, 0 where nothing was measured;
intrinsics ``fl_x fl_y cx cy w h`` at the top level or per frame. Our own additions live
under the top-level ``real2code`` key (the ground-truth object and its pose and state).
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from real2code_export import atomic
from real2code_export.batch.inputs import CAPTURE_FILE
from real2code_export.errors import FormatError

# The captures ``real2code demo`` reconstructs: package data, so they ship in the wheel. The
# room one is the same cabinet as people capture it: standing on a floor before a wall with
# clutter around it, a hand-held camera path, the phone-LiDAR preset's faults
# (`real2code render samples/cabinet/object.json --cameras handheld --capture phone-lidar
# --room --state random --seed 0`, run in pipeline/).
SAMPLE_CAPTURE = Path(__file__).resolve().parent / "samples" / "cabinet_capture"
ROOM_SAMPLE_CAPTURE = Path(__file__).resolve().parent / "samples" / "cabinet_room_capture"

TRANSFORMS = CAPTURE_FILE  # named in the core, where `batch` finds captures without the pipeline
GROUND_TRUTH_DIR = "ground_truth"
DEFAULT_DEPTH_SCALE = 1e-3  # nerfstudio's default: depth PNGs in millimetres
_INTRINSICS = ("fl_x", "fl_y", "cx", "cy", "w", "h")


@dataclass(frozen=True)
class Camera:
    """Pinhole intrinsics in pixels."""

    fl_x: float
    fl_y: float
    cx: float
    cy: float
    width: int
    height: int

    def to_json(self) -> dict[str, float | int]:
        return {"fl_x": self.fl_x, "fl_y": self.fl_y, "cx": self.cx, "cy": self.cy,
                "w": self.width, "h": self.height}

    def pixel_directions(self) -> np.ndarray:
        """(H, W, 3) ray directions in the camera frame (OpenGL axes) through the pixel
        centres, scaled so that their z component is -1: a hit at parameter t has z-depth t."""
        u = (np.arange(self.width) + 0.5 - self.cx) / self.fl_x
        v = (np.arange(self.height) + 0.5 - self.cy) / self.fl_y
        uu, vv = np.meshgrid(u, v)
        return np.stack([uu, -vv, -np.ones_like(uu)], axis=-1)

    def project(self, points_camera: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (continuous, (N, 2) as u, v) and z-depth of camera-frame points."""
        z = -points_camera[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = points_camera[:, 0] / z * self.fl_x + self.cx
            v = -points_camera[:, 1] / z * self.fl_y + self.cy
        return np.stack([u, v], axis=1), z


@dataclass(eq=False)
class Frame:
    """One posed view. ``depth`` in metres (z-depth, 0 = none); ``mask`` holds part indices
    (0 = background) when the capture has masks."""

    camera: Camera
    camera_to_world: np.ndarray
    rgb: np.ndarray  # (H, W, 3) uint8
    depth: np.ndarray  # (H, W) float32
    mask: np.ndarray | None = None  # (H, W) uint16
    name: str = "frame"

    def world_to_camera(self) -> np.ndarray:
        r, t = self.camera_to_world[:3, :3], self.camera_to_world[:3, 3]
        out = np.eye(4)
        out[:3, :3] = r.T
        out[:3, 3] = -r.T @ t
        return out


@dataclass(eq=False)
class Capture:
    """Frames and the part names their masks index (mask value k is ``parts[k - 1]``)."""

    frames: list[Frame]
    parts: list[str] = field(default_factory=list)
    extra: dict[str, Any] = field(default_factory=dict)  # the ``real2code`` block
    path: Path | None = None  # the folder it was read from

    @property
    def has_masks(self) -> bool:
        return bool(self.frames) and all(f.mask is not None for f in self.frames)

    def ground_truth_path(self) -> Path | None:
        rel = self.extra.get("ground_truth")
        return None if rel is None or self.path is None else self.path / rel

    def object_pose(self) -> np.ndarray:
        """Where the ground-truth object stood in the capture's world frame."""
        return np.asarray(self.extra.get("object_pose", np.eye(4)), dtype=float).reshape(4, 4)


# -- writing ---------------------------------------------------------------------------------
def _png(array: np.ndarray) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(array).save(buf, format="PNG", optimize=False)
    return buf.getvalue()


def depth_scale_for(frames: list[Frame]) -> float:
    """The finest of 0.1 mm / 1 mm / 1 cm per unit that still holds the farthest depth."""
    far = max((float(f.depth.max()) for f in frames), default=0.0)
    for scale in (1e-4, 1e-3, 1e-2):
        if far / scale < 65535:
            return scale
    raise FormatError(None, "depth", f"depth {far:.1f} m is too far for a 16-bit PNG")


def write_capture(capture: Capture, folder: str | Path, *, ground_truth=None) -> Path:
    """Write ``capture`` into ``folder`` atomically (all files or none); returns the
    transforms.json path. ``ground_truth`` (an ArticulatedObject) is saved beside the frames
    in ``ground_truth/`` and named in the ``real2code`` block."""
    from real2code_export.formats import object_json

    folder = Path(folder)
    if not capture.frames:
        raise FormatError(folder, "frames", "a capture needs at least one frame")
    cameras = {f.camera for f in capture.frames}
    shared = cameras.pop() if len(cameras) == 1 else None
    scale = depth_scale_for(capture.frames)
    doc: dict[str, Any] = {"camera_model": "OPENCV"}
    if shared is not None:
        doc.update(shared.to_json())
    doc["depth_unit_scale_factor"] = scale
    if capture.parts:
        doc["parts"] = list(capture.parts)
    extra = dict(capture.extra)
    if ground_truth is not None:
        extra["ground_truth"] = f"{GROUND_TRUTH_DIR}/{object_json.FILENAME}"
    if extra:
        doc["real2code"] = extra
    frames = []
    with atomic.staged_output(folder) as staging:
        for k, frame in enumerate(capture.frames):
            stem = f"frame_{k:05d}"
            entry: dict[str, Any] = {"file_path": f"images/{stem}.png",
                                     "depth_file_path": f"depth/{stem}.png"}
            (staging / "images").mkdir(exist_ok=True)
            (staging / "depth").mkdir(exist_ok=True)
            (staging / entry["file_path"]).write_bytes(_png(np.ascontiguousarray(frame.rgb)))
            raw = np.round(frame.depth / scale).astype(np.uint16)
            (staging / entry["depth_file_path"]).write_bytes(_png(raw))
            if frame.mask is not None:
                entry["mask_path"] = f"masks/{stem}.png"
                (staging / "masks").mkdir(exist_ok=True)
                (staging / entry["mask_path"]).write_bytes(_png(frame.mask.astype(np.uint16)))
            if shared is None:
                entry.update(frame.camera.to_json())
            entry["transform_matrix"] = np.round(frame.camera_to_world, 9).tolist()
            frames.append(entry)
        doc["frames"] = frames
        if ground_truth is not None:
            object_json.save(ground_truth, staging / GROUND_TRUTH_DIR)
        (staging / TRANSFORMS).write_text(json.dumps(doc, indent=1) + "\n")
    return folder / TRANSFORMS


# -- reading ---------------------------------------------------------------------------------
def _read_image(path: Path, element: str) -> np.ndarray:
    from PIL import Image, UnidentifiedImageError

    if not path.is_file():
        raise FormatError(path, element, "no such file")
    try:
        with Image.open(path) as im:
            im.load()
            return np.asarray(im)
    except (UnidentifiedImageError, OSError) as e:
        raise FormatError(path, element, f"cannot read image: {e}") from e


def _read_16bit(path: Path, element: str, shape: tuple[int, int]) -> np.ndarray:
    arr = _read_image(path, element)
    if arr.ndim != 2 or arr.dtype not in (np.uint16, np.int32):
        raise FormatError(path, element, f"expected a single-channel 16-bit PNG, got "
                          f"{arr.dtype} with shape {arr.shape}")
    if arr.shape != shape:
        raise FormatError(path, element, f"size {arr.shape[1]}x{arr.shape[0]} differs from "
                          f"the camera's {shape[1]}x{shape[0]}")
    return arr.astype(np.int64)


def _camera(entry: dict, top: dict, path: Path, element: str) -> Camera:
    values = {}
    for key in _INTRINSICS:
        value = entry.get(key, top.get(key))
        if value is None:
            raise FormatError(path, element, f"missing camera intrinsic {key!r} (neither in "
                              "the frame nor at the top level)")
        positive = key in ("fl_x", "fl_y", "w", "h")
        if isinstance(value, bool) or not isinstance(value, (int, float)) \
                or not np.isfinite(value) or (positive and value <= 0):
            raise FormatError(path, element, f"camera intrinsic {key!r} must be a finite number "
                              f"(positive for focal lengths and sizes), got {value!r}")
        values[key] = value
    return Camera(float(values["fl_x"]), float(values["fl_y"]), float(values["cx"]),
                  float(values["cy"]), int(values["w"]), int(values["h"]))


def _pose(entry: dict, path: Path, element: str) -> np.ndarray:
    if "transform_matrix" not in entry:
        raise FormatError(path, element, "missing 'transform_matrix'")
    try:
        m = np.asarray(entry["transform_matrix"], dtype=float)
    except (TypeError, ValueError) as e:
        raise FormatError(path, element, "'transform_matrix' is not a matrix of numbers") from e
    if m.shape != (4, 4) or not np.all(np.isfinite(m)):
        raise FormatError(path, element, f"'transform_matrix' must be 4x4 and finite, "
                          f"got shape {m.shape}")
    r = m[:3, :3]
    if not np.allclose(m[3], [0, 0, 0, 1], atol=1e-6) or \
            not np.allclose(r @ r.T, np.eye(3), atol=1e-4) or np.linalg.det(r) < 0:
        raise FormatError(path, element, "'transform_matrix' is not a rigid camera-to-world "
                          "transform (rotation must be orthonormal and right-handed)")
    return m


def read_capture(folder: str | Path) -> Capture:
    """Read and validate a capture folder (or its transforms.json). Raises
    :class:`FormatError` naming the file, the frame and what is wrong."""
    folder = Path(folder)
    path = folder if folder.suffix == ".json" else folder / TRANSFORMS
    folder = path.parent
    if not path.is_file():
        raise FormatError(path, None, "no such file (a capture folder holds transforms.json)")
    try:
        doc = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise FormatError(path, None, f"not valid JSON: {e}", getattr(e, "lineno", None)) from e
    if not isinstance(doc, dict) or not isinstance(doc.get("frames"), list) or not doc["frames"]:
        raise FormatError(path, "frames", "expected a non-empty 'frames' list")
    scale = doc.get("depth_unit_scale_factor", DEFAULT_DEPTH_SCALE)
    if not isinstance(scale, (int, float)) or not scale > 0:
        raise FormatError(path, "depth_unit_scale_factor", "must be positive, "
                          f"got {scale!r}")
    parts = doc.get("parts", [])
    if not isinstance(parts, list) or not all(isinstance(p, str) for p in parts):
        raise FormatError(path, "parts", "expected a list of part names")
    frames = []
    for k, entry in enumerate(doc["frames"]):
        element = f"frames[{k}]"
        if not isinstance(entry, dict):
            raise FormatError(path, element, "expected an object")
        camera = _camera(entry, doc, path, element)
        pose = _pose(entry, path, element)
        shape = (camera.height, camera.width)
        if "file_path" not in entry:
            raise FormatError(path, element, "missing 'file_path'")
        rgb = _read_image(folder / entry["file_path"], f"{element} file_path")
        if rgb.ndim == 3 and rgb.shape[2] == 4:
            rgb = rgb[..., :3]
        if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.dtype != np.uint8:
            raise FormatError(folder / entry["file_path"], element,
                              f"expected an 8-bit RGB image, got {rgb.dtype} {rgb.shape}")
        if rgb.shape[:2] != shape:
            raise FormatError(folder / entry["file_path"], element,
                              f"size {rgb.shape[1]}x{rgb.shape[0]} differs from the camera's "
                              f"{camera.width}x{camera.height}")
        if "depth_file_path" not in entry:
            raise FormatError(path, element, "missing 'depth_file_path' (reconstruction needs "
                              "depth)")
        depth = _read_16bit(folder / entry["depth_file_path"], f"{element} depth_file_path",
                            shape).astype(np.float32) * np.float32(scale)
        mask = None
        if "mask_path" in entry:
            mask = _read_16bit(folder / entry["mask_path"], f"{element} mask_path", shape)
            if mask.max() > len(parts):
                raise FormatError(folder / entry["mask_path"], element,
                                  f"mask holds part index {int(mask.max())} but 'parts' lists "
                                  f"{len(parts)} part(s)")
            mask = mask.astype(np.uint16)
        frames.append(Frame(camera, pose, np.ascontiguousarray(rgb), depth, mask,
                            Path(entry["file_path"]).stem))
    extra = doc.get("real2code", {})
    if not isinstance(extra, dict):
        raise FormatError(path, "real2code", "expected an object")
    return Capture(frames, list(parts), extra, folder)
