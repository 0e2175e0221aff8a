"""Completing one part: partial points in, a watertight mesh out.

The network (:mod:`.network`, shipped weights) predicts occupancy on a grid over the part's
unit frame; the cells holding observed points are marked occupied too (as Real2Code's own
evaluation adds the input's voxel grid to the prediction: what was seen stays in the mesh,
the network supplies what was not); scikit-image's marching cubes extracts the 0.5 level. The grid is padded with
empty cells, so every surface closes; grid counts follow the region's metric size (about
1 cm cells, 16 to 96 per axis, the paper queries 96^3), so a thin door gets as many cells
across its thickness as it needs. Small stray components are dropped.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from real2code_export.errors import Real2CodeError, warn

from .data import MIN_POINTS, network_input

WEIGHTS = Path(__file__).resolve().parent / "weights" / "occupancy.pt"
CELL = 0.01  # m, target grid spacing
MIN_CELLS, MAX_CELLS = 16, 96
KEEP_FRACTION = 0.05  # unseen components under this share of the largest volume are strays
# ... and a seen one too when fewer points than this fall on it: a noisy sensor's stray points
# (flying pixels, a speck of another surface) each made a one-cell cube, up to 40 per part on
# a phone-LiDAR capture, and each cube became a collision piece to separate from the others
MIN_SEEN_POINTS = 6


class CompletionError(Real2CodeError, ValueError):
    """A part cannot be completed (too few points, non-finite points, unreadable weights)."""


@dataclass
class OccupancyModel:
    network: object  # a TriplaneOccupancy in eval mode
    config: dict
    path: Path


@functools.lru_cache(maxsize=4)
def _load(path: Path) -> OccupancyModel:
    from ..weights import load_network
    from .network import build_network

    net, config = load_network(path, "occupancy-network", lambda c: build_network(**c),
                               "python -m pipeline.complete.train")
    return OccupancyModel(net, config, path)


def load_model(path: str | Path | None = None) -> OccupancyModel:
    """The occupancy network from ``path`` (default: the shipped weights), loaded once."""
    return _load(Path(path).resolve() if path else WEIGHTS)


def _check_points(points, what: str) -> np.ndarray:
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise CompletionError(f"{what}: expected an (N, 3) array, got shape {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise CompletionError(f"{what}: has non-finite coordinates")
    return pts


def grid_counts(half: np.ndarray) -> np.ndarray:
    return np.clip(np.ceil(2.0 * half / CELL), MIN_CELLS, MAX_CELLS).astype(int)


def occupancy_grid(points: np.ndarray, context: np.ndarray | None, model: OccupancyModel,
                   keep_points: bool = True, chunk: int = 65536):
    """Occupancy probabilities on the part's grid (cell centres) and the frame; with
    ``keep_points`` every cell holding one of ``points`` is occupied."""
    import torch

    x, frame = network_input(points, context, np.random.default_rng(0))
    counts = grid_counts(frame.half)
    axes = [-0.5 + (np.arange(n) + 0.5) / n for n in counts]
    queries = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    net = model.network
    with torch.no_grad():
        planes, code = net.encode(torch.from_numpy(x)[None],
                                  torch.from_numpy(frame.features())[None])
        q = torch.from_numpy(queries.astype(np.float32))[None]
        logits = torch.cat([net.decode(planes, code, q[:, s:s + chunk])
                            for s in range(0, q.shape[1], chunk)], dim=1)
    probability = torch.sigmoid(logits)[0].numpy().reshape(*counts)
    if keep_points:
        cells = np.floor((frame.to_unit(points) + 0.5) * counts).astype(int)
        cells = cells[np.all((cells >= 0) & (cells < counts), axis=1)]
        probability[tuple(cells.T)] = 1.0
    return probability, frame


def mesh_from_grid(probability: np.ndarray, frame, level: float = 0.5,
                   seen: np.ndarray | None = None):
    """The ``level`` surface of a cell-centred grid over the unit cube, in the world, closed;
    ``None`` when nothing is occupied. Components smaller than ``KEEP_FRACTION`` of the
    largest are dropped unless at least ``MIN_SEEN_POINTS`` of the ``seen`` world points lie
    in them (their box)."""
    import trimesh
    from skimage import measure

    if not (probability > level).any():
        return None
    counts = np.array(probability.shape)
    padded = np.pad(probability, 1, constant_values=0.0)  # empty border: surfaces close
    verts, faces, _, _ = measure.marching_cubes(padded, level=level)
    unit = -0.5 + (verts - 0.5) / counts
    # No vertex merging: skimage's vertices are already one per grid edge, and merging by
    # position welds pieces that touch at a corner into non-manifold edges.
    mesh = trimesh.Trimesh(frame.from_unit(unit), faces, process=False)
    pieces = mesh.split(only_watertight=False)
    if len(pieces) > 1:
        volumes = np.array([abs(p.volume) for p in pieces])
        keep = volumes >= KEEP_FRACTION * volumes.max()
        if seen is not None and len(seen) and not keep.all():
            margin = 0.25 / counts  # a quarter cell, in the grid's unit frame
            seen_unit = frame.to_unit(seen)
            for k in np.flatnonzero(~keep):
                unit = frame.to_unit(pieces[k].vertices)
                lo, hi = unit.min(0) - margin, unit.max(0) + margin
                inside = np.all((seen_unit >= lo) & (seen_unit <= hi), axis=1)
                keep[k] = int(inside.sum()) >= MIN_SEEN_POINTS
        mesh = trimesh.util.concatenate([p for p, k in zip(pieces, keep, strict=True) if k])
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def complete_part(points, *, context=None, model: OccupancyModel | str | Path | None = None,
                  keep_points: bool = True):
    """A watertight mesh (``trimesh.Trimesh``, world frame) of the part seen as ``points``.

    ``points``: (N, 3) world points of this part (fused depth under its mask), N >= 30.
    ``context``: optional (M, 3) world points of the *other* parts of the object (not this
    one): they tell the network where neighbours bound the hidden geometry.
    ``model``: an :class:`OccupancyModel`, a weights path, or ``None`` for the shipped one.
    ``keep_points``: cells holding observed points count as occupied (the default; ``False``
    meshes the network's prediction alone). Deterministic: the same input gives the same mesh.
    """
    pts = _check_points(points, "part points")
    if len(pts) < MIN_POINTS:
        raise CompletionError(f"part points: {len(pts)} points, at least {MIN_POINTS} "
                              "needed to complete a part")
    ctx = None if context is None else _check_points(context, "context points")
    if not isinstance(model, OccupancyModel):
        model = load_model(model)
    probability, frame = occupancy_grid(pts, ctx, model, keep_points)
    mesh = mesh_from_grid(probability, frame, seen=pts if keep_points else None)
    if mesh is None or not mesh.is_watertight:
        import trimesh

        warn(f"shape completion: the network gave {'no' if mesh is None else 'a non-closed'} "
             f"surface for a part of {len(pts)} points; using the points' convex hull")
        mesh = trimesh.convex.convex_hull(pts)
    return mesh
