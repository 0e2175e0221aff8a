"""Training views for the mask network: procedural objects (every category, 2 to 15
parts), every joint partly open as the paper assumes (a few left closed), rendered from
the front arc like a capture, with the appearance varied so the network learns parts from
geometry as much as from paint: original, single, random or grey part colours, random
lighting, background and field of view.

Views are rendered at twice the model grid and cut to the object's square
(``features.object_window``) as a capture's are at test time, with the margin and the
centre jittered a little. A view is stored small (RGB, depth and part labels on the model
grid, and what is needed to recompute each pixel's ray); the network's input is computed
from it when a batch is drawn (``features.grid_features``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .features import (
    SIZE,
    WINDOW_MARGIN,
    Window,
    object_window,
    pixel_rays,
    sample_nearest,
    sample_rgb,
)

RENDER_SIZE = 2 * SIZE  # training views are rendered this large, then cut to the object


@dataclass
class View:
    rgb: np.ndarray  # (SIZE, SIZE, 3) uint8
    depth: np.ndarray  # (SIZE, SIZE) float32, metres
    mask: np.ndarray  # (SIZE, SIZE) uint8, 0 = background, k = part k
    camera: tuple[float, float, float, float, int, int]  # fl_x fl_y cx cy height width
    window: Window  # what of the rendered view the grid covers

    def rays(self) -> np.ndarray:
        return pixel_rays(*self.camera[:4], self.window, *self.camera[4:])


def jittered_window(depth: np.ndarray, rng: np.random.Generator) -> Window:
    """The object's window with its margin and centre jittered (a capture's foreground is
    not always cut as cleanly as a render's)."""
    base = object_window(depth, margin=WINDOW_MARGIN * rng.uniform(0.3, 2.5))
    side = base.scale * SIZE
    du, dv = rng.uniform(-0.04, 0.04, 2) * side
    return Window(base.u0 + du, base.v0 + dv, base.scale)


def _colours(names: list[str], original: dict[str, tuple], rng: np.random.Generator,
             ) -> dict[str, tuple]:
    mode = rng.choice(["original", "single", "random", "grey"], p=[0.35, 0.25, 0.25, 0.15])
    if mode == "original":
        return original
    if mode == "single":
        c = tuple(rng.uniform(0.05, 0.9, 3))
        return {n: c for n in names}
    if mode == "grey":
        return {n: (g, g, g) for n in names for g in [rng.uniform(0.3, 0.9)]}
    return {n: tuple(rng.uniform(0.05, 0.9, 3)) for n in names}


# How the shipped weights' views were taken: the front arc, exact depth. ``--cameras`` and
# ``--sensors`` of the training command draw each object's path and sensor from lists.
SHIPPED_CAMERAS = ("front-arc",)
SHIPPED_SENSORS = ("clean",)
SHIPPED_WORLD = "real2code"  # the world of weights whose record names none (before session 25)


def _pick(options: tuple[str, ...], rng: np.random.Generator) -> str:
    """One of ``options``; a single option draws nothing (the shipped data stay as made)."""
    return options[0] if len(options) == 1 else options[int(rng.integers(len(options)))]


def object_views(obj, rng: np.random.Generator, views: int,
                 cameras: tuple[str, ...] = SHIPPED_CAMERAS,
                 sensors: tuple[str, ...] = SHIPPED_SENSORS) -> list[View]:
    """``views`` training views of ``obj`` at a random, mostly partly-open configuration,
    from a camera path and through a sensor (preset) drawn from ``cameras`` and ``sensors``;
    a degraded frame's depth is cleaned as reconstruction cleans it
    (:func:`pipeline.depth_cleanup.clean_depth`), so the network learns what it will see."""
    from ..capture import Capture
    from ..depth_cleanup import clean_depth
    from ..predictors.data import ajar_configuration
    from ..render import Lighting, render_object
    from ..sensors import degrade, load_sensor

    q = ajar_configuration(obj, rng)
    for j in obj.movable_joints:
        if rng.random() < 0.1:  # some parts closed, so a shut door is not unseen
            q[j.name] = float(j.limits.lower) if j.limits else 0.0
    names = [p.name for p in obj.parts]
    colours = _colours(names, {p.name: p.color for p in obj.parts}, rng)
    lighting = Lighting(ambient=rng.uniform(0.15, 0.45), head=rng.uniform(0.25, 0.6),
                        key=rng.uniform(0.0, 0.5))
    background = tuple(rng.uniform(0, 1, 3) * (0.2 if rng.random() < 0.7 else 1.0))
    fov = rng.uniform(40.0, 60.0)
    cap = render_object(obj, q=q, views=12, width=RENDER_SIZE, height=RENDER_SIZE,
                        fov_deg=fov, seed=int(rng.integers(2**31)), colors=colours,
                        lighting=lighting, background=background,
                        cameras=_pick(cameras, rng))
    sensor = load_sensor(_pick(sensors, rng))
    picks = sorted(rng.choice(len(cap.frames), size=min(views, len(cap.frames)),
                              replace=False))
    cap = Capture([cap.frames[k] for k in picks], cap.parts, cap.extra)
    if sensor.name != "clean":  # only the views kept (a third of the degrading's cost)
        cap = degrade(cap, sensor, int(rng.integers(2**31)))
    out = []
    for f in cap.frames:
        if not f.mask.any():
            continue
        depth = clean_depth(f.depth)[0] if sensor.name != "clean" else f.depth
        window = jittered_window(depth, rng)
        c = f.camera
        out.append(View(sample_rgb(f.rgb, window), sample_nearest(depth, window),
                        sample_nearest(f.mask.astype(np.uint8), window),
                        (c.fl_x, c.fl_y, c.cx, c.cy, c.height, c.width), window))
    return out


def _one(spec) -> list[View]:
    from ..procedural import generate

    category, n_parts, seed, views, cameras, sensors = spec
    return object_views(generate(category, n_parts, seed), np.random.default_rng(seed + 77),
                        views, cameras, sensors)


def make_views(n_objects: int, seed: int, views_per_object: int = 4,
               workers: int = 2, cameras: tuple[str, ...] = SHIPPED_CAMERAS,
               sensors: tuple[str, ...] = SHIPPED_SENSORS,
               world: str = SHIPPED_WORLD) -> list[View]:
    """Views of ``n_objects`` procedural objects of ``world`` (the joint predictor's mix of
    categories and part counts, ``pipeline.predictors.data.WORLDS``; seeds below the
    evaluation's held-out offset)."""
    from ..predictors.data import object_specs

    specs = [(c, n, s, views_per_object, tuple(cameras), tuple(sensors))
             for c, n, s in object_specs(n_objects, seed, world)]
    if workers > 1:
        from multiprocessing import get_context

        with get_context("spawn").Pool(workers) as pool:
            chunks = pool.map(_one, specs, chunksize=16)
    else:
        chunks = [_one(s) for s in specs]
    return [v for chunk in chunks for v in chunk]
