"""Training samples for shape completion: procedural parts seen partially, with occupancy.

Each object is generated, opened to a random ajar state and placed as the joint predictor's
training objects are (``pipeline.predictors.data``), seen by :mod:`.views` (12 noisy
views on a full ring or, as often, on the renderer's 120-degree front arc; borders
mislabelled at a random rate), and every part seen by enough points
becomes one sample: its points and its neighbours' points (the context) in the part's unit
frame (:mod:`.frame`), and query points with their exact occupancy (:mod:`.occupancy`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .frame import PartFrame, part_frame
from .occupancy import inside, piece_planes, query_points
from .views import DEFAULT_VIEWS, ViewSettings, partial_clouds

INPUT_POINTS = 1024  # of the part (the paper uses 2048)
CONTEXT_POINTS = 512  # of the other parts, inside the part's region
MIN_POINTS = 30  # fewer seen points than this: the part is not completed (nor trained on)
FRONT_ARC_DEG = 120.0  # pipeline.render's default arc
FRONT_ARC_SHARE = 0.5  # of the training objects seen from the front arc only


@dataclass
class Sample:
    points: np.ndarray  # (INPUT_POINTS + CONTEXT_POINTS, 4): unit xyz and 1 = this part
    size: np.ndarray  # (3,) log half-sizes of the frame (m)
    queries: np.ndarray  # (Q, 3) unit
    occupied: np.ndarray  # (Q,) bool


def subsample(points: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` of ``points``, without repeats when there are enough."""
    idx = rng.choice(len(points), n, replace=len(points) < n)
    return points[idx]


def network_input(points: np.ndarray, context: np.ndarray | None,
                  rng: np.random.Generator) -> tuple[np.ndarray, PartFrame]:
    """The part's points and its context as the network takes them, and the frame they are
    in. Without context (or none inside the region) the context slots repeat part points,
    flagged as the part: the network was trained that way too."""
    own = subsample(points, INPUT_POINTS, rng)
    frame = part_frame(own)
    own_u = frame.to_unit(own)
    ctx_u = np.zeros((0, 3))
    if context is not None and len(context):
        ctx_u = frame.to_unit(context)
        ctx_u = ctx_u[np.all(np.abs(ctx_u) <= 0.5, axis=1)]
    if len(ctx_u):
        ctx = np.column_stack([subsample(ctx_u, CONTEXT_POINTS, rng),
                               np.zeros(CONTEXT_POINTS)])
    else:
        ctx = np.column_stack([subsample(own_u, CONTEXT_POINTS, rng), np.ones(CONTEXT_POINTS)])
    x = np.concatenate([np.column_stack([own_u, np.ones(INPUT_POINTS)]), ctx])
    return x.astype(np.float32), frame


def object_samples(obj, rng: np.random.Generator, n_queries: int = 3072,
                   settings: ViewSettings = DEFAULT_VIEWS, context_dropout: float = 0.3,
                   q=None, base=None) -> list[Sample]:
    """Samples of every well-seen part of ``obj`` (at ``q`` placed at ``base``)."""
    import trimesh

    from real2code_export.kinematics import world_part_meshes
    from real2code_export.model import forward_kinematics

    meshes = world_part_meshes(obj, q, base)
    poses = forward_kinematics(obj, obj.observed_configuration() if q is None else q, base)
    names = list(meshes)
    arc = FRONT_ARC_DEG if rng.random() < FRONT_ARC_SHARE else 360.0
    settings = replace(settings, border_swap=float(rng.uniform(0.0, settings.border_swap)),
                       arc_deg=arc)
    front = (np.eye(4) if base is None else base)[:3, :3] @ np.array([1.0, 0.0, 0.0])
    clouds = partial_clouds([meshes[n] for n in names], rng, settings, threads=1, front=front)
    samples = []
    for k, name in enumerate(names):
        if len(clouds[k]) < MIN_POINTS:
            continue
        others = np.concatenate([c for j, c in enumerate(clouds) if j != k] or [np.zeros((0, 3))])
        context = None if rng.random() < context_dropout else others
        x, frame = network_input(clouds[k], context, rng)
        part = obj.part(name)
        planes = piece_planes([p.transformed(poses[name]) for p in part.collision])
        surface, _ = trimesh.sample.sample_surface(meshes[name].to_trimesh(), 4096,
                                                   seed=int(rng.integers(2**31)))
        queries = query_points(frame.to_unit(surface), n_queries, rng)
        occupied = inside(planes, frame.from_unit(queries))
        samples.append(Sample(x.astype(np.float16), frame.features(),
                              queries.astype(np.float16), occupied))
    return samples
