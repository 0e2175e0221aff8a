"""What the mask network sees of one view: a square ``SIZE`` x ``SIZE`` grid of RGB, depth
relative to the object, a validity channel, camera-frame surface normals (the geometry
that separates a door from the carcass when both have one colour) and grid coordinates.

The grid covers a :class:`Window` of the capture: by default the square around the pixels
with depth (the object), so the object fills the grid whatever its size in the image and
the network spends its pixels on it (a tall fridge in a 256 x 256 view gets about 1.5x the
resolution that padding the whole view would give it). Depth and labels are sampled at the
nearest capture pixel, RGB area-averaged; the camera-frame points behind the normals are
computed through the sampled pixels' own centres, so normals of flat panels stay exact
however the window falls on the pixel grid.

Outside the object's silhouette (its pixels with depth, enclosed holes filled) the RGB is
the renders' dark background the network was trained on: in a room, isolation leaves depth
only on the object, and the floor's and the wall's colours around it are no part of what the
network learnt (on a table in a room with exactly its own pixels kept: 1 part found with
the room's colours, 4 of 4 without).

A window may be turned (``Window.angle``): a hand-held camera is rolled a few degrees, and
the network was trained on upright views; its grid then stands upright (the world's up
straight up, :func:`upright_angles`) and its rays and normals are those of the same camera
turned upright about its axis, so the view it sees is the upright camera's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..fuse import normals_from_points

SIZE = 128
CHANNELS = 10  # rgb 3, depth 1, valid 1, normals 3, coordinates 2
WINDOW_MARGIN = 0.06  # of the object's extent, on every side


@dataclass(frozen=True)
class Window:
    """The square of capture pixels the model grid covers: model pixel ``i`` spans capture
    coordinates ``[origin + i * scale, origin + (i + 1) * scale)``, per axis; turned by
    ``angle`` (radians, about the square's centre: a grid offset (du, dv) lies at capture
    offset R(angle) (du, dv), image axes) where the grid stands upright in a rolled view."""

    u0: float
    v0: float
    scale: float  # capture pixels per model pixel
    angle: float = 0.0

    def _turn(self) -> tuple[np.ndarray, np.ndarray]:
        """The square's centre (capture coordinates) and R(angle)."""
        half = SIZE * self.scale / 2
        c, s = np.cos(self.angle), np.sin(self.angle)
        return np.array([self.u0 + half, self.v0 + half]), np.array([[c, -s], [s, c]])

    def to_model(self, uv: np.ndarray) -> np.ndarray:
        """Continuous capture pixel coordinates (u, v) -> model grid coordinates."""
        uv = np.asarray(uv, dtype=np.float64)
        if not self.angle:
            return (uv - (self.u0, self.v0)) / self.scale
        centre, turn = self._turn()
        return ((uv - centre) @ turn) / self.scale + SIZE / 2  # R^-1 = R^T

    def source_centres(self, supersample: int = 1) -> np.ndarray:
        """(SIZE * k, SIZE * k, 2): the capture coordinates (u, v) of every model pixel's
        centre (of its k x k sub-pixels' centres, ``supersample`` k)."""
        k = supersample
        grid = (np.arange(SIZE * k) + 0.5) / k * self.scale  # offsets from the corner
        du, dv = np.meshgrid(grid, grid)
        offsets = np.stack([du, dv], -1) - SIZE * self.scale / 2
        centre, turn = self._turn()
        return offsets @ turn.T + centre

    def source_pixels(self, height: int, width: int,
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The capture row and column sampled for every model row and column (nearest: the
        pixel under the model pixel's centre; (SIZE,) each, or (SIZE, SIZE) each for a
        turned window), and the (SIZE, SIZE) mask of model pixels that fall inside the
        capture."""
        if self.angle:
            uv = np.floor(self.source_centres()).astype(int)
            cols, rows = uv[..., 0], uv[..., 1]
            inside = (rows >= 0) & (rows < height) & (cols >= 0) & (cols < width)
            return np.clip(rows, 0, height - 1), np.clip(cols, 0, width - 1), inside
        centres = (np.arange(SIZE) + 0.5) * self.scale
        cols = np.floor(self.u0 + centres).astype(int)
        rows = np.floor(self.v0 + centres).astype(int)
        inside = ((rows >= 0) & (rows < height))[:, None] & ((cols >= 0) & (cols < width))[None]
        return np.clip(rows, 0, height - 1), np.clip(cols, 0, width - 1), inside


def whole_view(height: int, width: int) -> Window:
    """The whole view, padded at the right and bottom to a square."""
    return Window(0.0, 0.0, max(height, width) / SIZE)


def object_window(depth: np.ndarray, margin: float = WINDOW_MARGIN,
                  angle: float = 0.0) -> Window:
    """The square around the pixels with depth, ``margin`` of its side added on every side
    (turned by ``angle``: the square, so turned, around them); the whole view when nothing
    has depth."""
    rows = np.nonzero(depth.any(axis=1))[0]
    cols = np.nonzero(depth.any(axis=0))[0]
    if len(rows) == 0:
        return whole_view(*depth.shape)
    if angle:
        v, u = np.nonzero(depth)
        c, s = np.cos(angle), np.sin(angle)
        turn = np.array([[c, -s], [s, c]])
        grid = np.stack([u + 0.5, v + 0.5], 1) @ turn  # in the turned grid's axes
        lo, hi = grid.min(0) - 0.5, grid.max(0) + 0.5
        side = float(np.max(hi - lo)) * (1 + 2 * margin)
        cu, cv = turn @ ((lo + hi) / 2)
        return Window(cu - side / 2, cv - side / 2, side / SIZE, float(angle))
    side = max(rows[-1] + 1 - rows[0], cols[-1] + 1 - cols[0]) * (1 + 2 * margin)
    cu, cv = (cols[0] + cols[-1] + 1) / 2, (rows[0] + rows[-1] + 1) / 2
    return Window(cu - side / 2, cv - side / 2, side / SIZE)


ROLL_MIN_DEG = 0.1  # a view rolled less than this is taken as upright (its window unturned)


def upright_angles(frames) -> list[float]:
    """Per view, the angle (radians) that turns its grid upright: the world's up, found as
    the direction most nearly across every camera's x axis (a camera held by a person is
    level but for a little roll; least squares), pointing as their y axes do, straight up
    in the grid. Zero for views rolled less than :data:`ROLL_MIN_DEG`, and for all where
    the x axes do not fix up (one view, or all of them parallel)."""
    if len(frames) < 2:
        return [0.0] * len(frames)
    x = np.stack([f.camera_to_world[:3, 0] for f in frames])
    values, vectors = np.linalg.eigh(x.T @ x)
    if values[1] < 1e-3 * len(frames):  # the x axes span no plane: up is not fixed
        return [0.0] * len(frames)
    up = vectors[:, 0]
    if up @ np.sum([f.camera_to_world[:3, 1] for f in frames], axis=0) < 0:
        up = -up
    out = []
    for f in frames:
        ux, uy = f.camera_to_world[:3, :2].T @ up  # up in the camera's x and y (y up)
        angle = float(np.arctan2(ux, uy))
        out.append(angle if abs(angle) >= np.radians(ROLL_MIN_DEG) else 0.0)
    return out


def sample_nearest(image: np.ndarray, window: Window) -> np.ndarray:
    """``image`` (H, W[, C]) on the model grid, nearest capture pixel; 0 outside it."""
    rows, cols, inside = window.source_pixels(*image.shape[:2])
    out = image[rows, cols] if rows.ndim == 2 else image[rows[:, None], cols[None, :]]
    return np.where(inside[..., None] if out.ndim == 3 else inside, out, 0).astype(image.dtype)


def sample_rgb(rgb: np.ndarray, window: Window) -> np.ndarray:
    """RGB on the model grid, area-averaged (nearest sampling would alias thin edges);
    black outside the capture."""
    from PIL import Image

    if window.angle:
        return _sample_rgb_turned(rgb, window)
    h, w = rgb.shape[:2]
    x0, y0 = int(np.floor(window.u0)), int(np.floor(window.v0))
    x1 = int(np.ceil(window.u0 + SIZE * window.scale))
    y1 = int(np.ceil(window.v0 + SIZE * window.scale))
    # PIL's box must lie inside the image: pad the capture to cover the window
    pad = ((max(0, -y0), max(0, y1 - h)), (max(0, -x0), max(0, x1 - w)), (0, 0))
    padded = np.pad(rgb, pad)
    box = (window.u0 + pad[1][0], window.v0 + pad[0][0],
           window.u0 + pad[1][0] + SIZE * window.scale, window.v0 + pad[0][0] + SIZE * window.scale)
    return np.asarray(Image.fromarray(padded).resize((SIZE, SIZE), Image.Resampling.BOX, box=box))


def _sample_rgb_turned(rgb: np.ndarray, window: Window, supersample: int = 3) -> np.ndarray:
    """RGB on a turned window's grid: the mean of k x k bilinear samples per model pixel
    (the area average of :func:`sample_rgb`, turned); black outside the capture."""
    h, w = rgb.shape[:2]
    uv = window.source_centres(supersample) - 0.5  # pixel-centre coordinates
    padded = np.pad(rgb.astype(np.float64), ((1, 1), (1, 1), (0, 0)))
    u = np.clip(uv[..., 0] + 1, 0, w + 1 - 1e-9)
    v = np.clip(uv[..., 1] + 1, 0, h + 1 - 1e-9)
    u0, v0 = np.floor(u).astype(int), np.floor(v).astype(int)
    u1, v1 = np.minimum(u0 + 1, w + 1), np.minimum(v0 + 1, h + 1)
    fu, fv = (u - u0)[..., None], (v - v0)[..., None]
    out = (padded[v0, u0] * (1 - fu) * (1 - fv) + padded[v0, u1] * fu * (1 - fv)
           + padded[v1, u0] * (1 - fu) * fv + padded[v1, u1] * fu * fv)
    k = supersample
    out = out.reshape(SIZE, k, SIZE, k, 3).mean((1, 3))
    return np.clip(np.round(out), 0, 255).astype(np.uint8)


def pixel_rays(fl_x: float, fl_y: float, cx: float, cy: float, window: Window, height: int,
               width: int) -> np.ndarray:
    """(SIZE, SIZE, 2): the camera-frame direction (x / z, y / z, OpenGL axes, up to the
    sign of z) through the centre of the capture pixel each model pixel samples; of a
    turned window, in the frame of the camera turned upright with it (about its axis)."""
    rows, cols, _ = window.source_pixels(height, width)
    x = (cols + 0.5 - cx) / fl_x
    y = -(rows + 0.5 - cy) / fl_y
    if rows.ndim == 1:
        return np.stack(np.broadcast_arrays(x[None, :], y[:, None]), axis=-1).astype(np.float32)
    c, s = np.cos(window.angle), np.sin(window.angle)
    return np.stack([c * x - s * y, s * x + c * y], axis=-1).astype(np.float32)


def grid_features(rgb: np.ndarray, depth: np.ndarray, rays: np.ndarray) -> np.ndarray:
    """(CHANNELS, SIZE, SIZE) float32 network input from a view already on the model grid:
    RGB (SIZE, SIZE, 3) uint8, z-depth in metres (0 = none) and each pixel's ray
    (:func:`pixel_rays`)."""
    z = depth.astype(np.float32)
    valid = z > 0
    points = np.concatenate([rays * z[..., None], -z[..., None]], axis=-1)
    normals = normals_from_points(points, valid)
    if valid.any():
        lo, mid, hi = np.percentile(z[valid], [5, 50, 95])
        scale = max(hi - lo, 0.05)
        rel = np.where(valid, (z - mid) / scale, 0.0)
    else:
        rel = np.zeros_like(z)
    grid = (np.arange(SIZE, dtype=np.float32) + 0.5) / SIZE * 2 - 1
    out = np.empty((CHANNELS, SIZE, SIZE), np.float32)
    out[0:3] = (rgb.astype(np.float32) / 255.0 - 0.5).transpose(2, 0, 1)
    out[3] = rel
    out[4] = valid
    out[5:8] = normals.transpose(2, 0, 1)
    out[8] = grid[None, :]
    out[9] = grid[:, None]
    return out


def object_rgb(rgb: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """``rgb`` with every pixel outside the object's silhouette (pixels with depth, enclosed
    holes filled: a sensor's missing pixels keep their colour) the renders' background; the
    same array where nothing changes."""
    from scipy.ndimage import binary_fill_holes

    from ..render import background_rgb8

    outside = ~binary_fill_holes(depth > 0)
    background = background_rgb8()
    if not (rgb[outside][:, :3] != background).any():
        return rgb
    out = rgb.copy()
    out[outside, :3] = background
    return out


def frame_features(frame, window: Window | None = None) -> np.ndarray:
    """The network input for one capture frame over ``window`` (default: the object's)."""
    window = window or object_window(frame.depth)
    c = frame.camera
    h, w = frame.depth.shape
    return grid_features(sample_rgb(object_rgb(frame.rgb, frame.depth), window),
                         sample_nearest(frame.depth, window),
                         pixel_rays(c.fl_x, c.fl_y, c.cx, c.cy, window, h, w))
