"""What the mask network sees of one view: a square ``SIZE`` x ``SIZE`` grid of RGB, depth
relative to the object, a validity channel, camera-frame surface normals (the geometry
that separates a door from the carcass when both have one colour) and pixel coordinates.

A view of any size is padded at the right and bottom to a square (no distortion) and
sampled down; :func:`to_model_uv` maps capture pixels to the model grid.
"""

from __future__ import annotations

import numpy as np

SIZE = 128
CHANNELS = 10  # rgb 3, depth 1, valid 1, normals 3, coordinates 2


def model_scale(height: int, width: int) -> float:
    """Model pixels per capture pixel."""
    return SIZE / max(height, width)


def to_model_uv(uv: np.ndarray, height: int, width: int) -> np.ndarray:
    """Continuous capture pixel coordinates (u, v) -> model grid coordinates."""
    return np.asarray(uv, dtype=np.float64) * model_scale(height, width)


def _sample_nearest(image: np.ndarray, square: int) -> np.ndarray:
    """The ``SIZE`` x ``SIZE`` nearest-pixel sampling of ``image`` padded to ``square``."""
    idx = np.floor((np.arange(SIZE) + 0.5) * square / SIZE).astype(int)
    h, w = image.shape[:2]
    rows, cols = idx[:, None], idx[None, :]
    inside = (rows < h) & (cols < w)
    out = image[np.minimum(rows, h - 1), np.minimum(cols, w - 1)]
    return np.where(inside[..., None] if out.ndim == 3 else inside, out, 0)


def _rgb_box(rgb: np.ndarray, square: int) -> np.ndarray:
    """Area-averaged RGB on the model grid (nearest sampling would alias thin edges)."""
    from PIL import Image

    h, w = rgb.shape[:2]
    padded = np.zeros((square, square, 3), np.uint8)
    padded[:h, :w] = rgb
    if square == SIZE:
        return padded
    return np.asarray(Image.fromarray(padded).resize((SIZE, SIZE), Image.Resampling.BOX))


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


def view_features(rgb: np.ndarray, depth: np.ndarray, fl_x: float, fl_y: float, cx: float,
                  cy: float) -> np.ndarray:
    """(CHANNELS, SIZE, SIZE) float32 input for one view (depth in metres, 0 = none)."""
    h, w = depth.shape
    square = max(h, w)
    z = _sample_nearest(depth.astype(np.float32), square)
    valid = z > 0
    # Camera-frame points of the sampled pixels (OpenGL axes), at their capture pixel centres.
    centres = (np.arange(SIZE) + 0.5) * square / SIZE
    centres = np.floor(centres) + 0.5
    x = (centres[None, :] - cx) / fl_x * z
    y = -(centres[:, None] - cy) / fl_y * z
    points = np.stack([x, y, -z], axis=-1)
    normals = normals_from_points(points, valid)
    if valid.any():
        lo, mid, hi = np.percentile(z[valid], [5, 50, 95])
        scale = max(hi - lo, 0.05)
        rel = np.where(valid, (z - mid) / scale, 0.0)
    else:
        rel = np.zeros_like(z)
    colour = _rgb_box(rgb, square).astype(np.float32) / 255.0 - 0.5
    grid = (np.arange(SIZE, dtype=np.float32) + 0.5) / SIZE * 2 - 1
    out = np.empty((CHANNELS, SIZE, SIZE), np.float32)
    out[0:3] = colour.transpose(2, 0, 1)
    out[3] = rel
    out[4] = valid
    out[5:8] = normals.transpose(2, 0, 1)
    out[8] = grid[None, :]
    out[9] = grid[:, None]
    return out


def frame_features(frame) -> np.ndarray:
    c = frame.camera
    return view_features(frame.rgb, frame.depth, c.fl_x, c.fl_y, c.cx, c.cy)


def mask_on_grid(mask: np.ndarray) -> np.ndarray:
    """A capture's (H, W) label image on the model grid (nearest; padding is background)."""
    return _sample_nearest(mask, max(mask.shape))
