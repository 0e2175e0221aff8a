"""Hollow parts as convex pieces that keep their insides: a voxel box decomposition.

A carcass's convex hull fills its openings, a drawer's fills its inside, so nothing can be put
in them and the doors and drawers that sit there overlap it. CoACD decomposes such meshes
faithfully but takes ~80 s on a 10k-face part on these machines; furniture is made of walls,
so this does it in about a second:

1. the mesh's points are put in its minimum-volume oriented box (walls end up along the
   grid's axes) and its surface is subdivided to points a voxel apart;
2. the points mark the voxels they fall in (``pitch``: the caller's, about 40 voxels along
   the part's longest side), one-voxel gaps are closed and enclosed cavities filled (a
   solid stays solid, an open box stays open);
3. when the voxels fill most of the hull (``SOLID_FRACTION``) the hull is kept: it is faithful;
4. otherwise the voxels are merged greedily into boxes (walls become slabs), then
   neighbouring boxes whose common bounding box the voxels fill best are merged while they
   fill at least ``MERGE_FILL`` of it, and further until at most ``max_pieces`` are left (a
   scan's ragged walls make hundreds of small boxes);
5. each box's piece is the convex hull of the surface points inside it (the true wall, not
   the voxel staircase), plus the box's corners where it holds a solid's inside.
"""

from __future__ import annotations

import itertools

import numpy as np

from .meshtopology import used_indices
from .model import Mesh

DEFAULT_RESOLUTION = 40  # voxels along the longest side of the part
# Voxels covering at least this much of the hull's volume: the part is (nearly) solid.
SOLID_FRACTION = 0.8
# Two boxes merge freely when the voxels fill this much of their common bounding box.
MERGE_FILL = 0.85


def hollow_pieces(mesh: Mesh, hull_volume: float, pitch: float, max_pieces: int
                  ) -> list[np.ndarray] | None:
    """Point sets (part frame) whose convex hulls cover ``mesh`` and keep its cavities, or
    None when the mesh is (nearly) solid at this ``pitch`` (m) and its hull is faithful."""
    import trimesh
    from scipy import ndimage

    if len(mesh.faces) == 0 or hull_volume <= 0:
        return None
    points = mesh.vertices[used_indices(mesh.faces)]
    if np.ptp(points, axis=0).max() < 3 * pitch:  # a few voxels: no cavity worth keeping
        return None
    try:
        to_box, _ = trimesh.bounds.oriented_bounds(points)
    except (TypeError, ValueError):  # trimesh finds no box when every candidate's volume is
        # NaN (PartNet 12036's thin pieces), and fails on some exactly flat point sets (a
        # panel's face cut out by its colour): the voxels are then axis-aligned
        to_box = np.eye(4)
    samples = _surface_samples(mesh, pitch)
    local = trimesh.transform_points(samples, to_box)
    low = local.min(axis=0)
    cells = np.floor((local - low) / pitch).astype(np.int64)
    surface = np.zeros(cells.max(axis=0) + 1, dtype=bool)
    surface[tuple(cells.T)] = True
    occupied = _filled(surface)
    # voxels of a solid's inside, not just walls closed up: their boxes span the solid
    interior = occupied & ~ndimage.binary_dilation(surface, structure=np.ones((3, 3, 3), bool))
    if occupied.sum() * pitch**3 >= SOLID_FRACTION * hull_volume:
        return None
    to_part = np.linalg.inv(to_box)
    pieces = []
    for start, stop in _merged_boxes(_greedy_boxes(occupied), occupied, max_pieces):
        inside = np.all((cells >= start) & (cells < stop), axis=1)
        pts = local[inside]
        if interior[tuple(slice(a, b) for a, b in zip(start, stop, strict=True))].any():
            # the box holds a solid's inside: its corners (in the grid) belong to it too
            corners = np.array(list(itertools.product(*zip(start, stop, strict=True))), float)
            pts = np.concatenate([pts, low + corners * pitch])
        if len(pts):
            pieces.append(trimesh.transform_points(pts, to_part))
    return pieces


def _surface_samples(mesh: Mesh, pitch: float) -> np.ndarray:
    """Points on the surface no farther apart than a voxel: the vertices of the mesh
    subdivided until every edge is shorter than ``pitch`` (deterministic; trimesh voxelises
    with half that, four times the points: the gaps it leaves are closed in ``_filled``)."""
    import trimesh

    vertices, _ = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces,
                                                   max_edge=pitch, max_iter=12)
    return np.asarray(vertices)


def _filled(surface: np.ndarray) -> np.ndarray:
    """Enclosed cavities filled (the inside of a closed wall or solid), after closing the
    one-voxel gaps a surface sampled a voxel apart can leave."""
    from scipy import ndimage

    padded = np.pad(surface, 2)
    closed = ndimage.binary_closing(padded, structure=np.ones((3, 3, 3), bool))
    return (ndimage.binary_fill_holes(closed) | padded)[2:-2, 2:-2, 2:-2]


def _greedy_boxes(occupied: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Disjoint boxes (start, stop index triples, stop exclusive) covering the occupied
    voxels: from each free voxel in order, grown along x, then y, then z while every voxel
    added is occupied and free."""
    free = occupied.copy()
    shape = occupied.shape
    boxes = []
    for i, j, k in np.argwhere(occupied):
        if not free[i, j, k]:
            continue
        i1 = i + 1
        while i1 < shape[0] and free[i1, j, k]:
            i1 += 1
        j1 = j + 1
        while j1 < shape[1] and free[i:i1, j1, k].all():
            j1 += 1
        k1 = k + 1
        while k1 < shape[2] and free[i:i1, j:j1, k1].all():
            k1 += 1
        free[i:i1, j:j1, k:k1] = False
        boxes.append((np.array([i, j, k]), np.array([i1, j1, k1])))
    return boxes


def _merged_boxes(boxes: list[tuple[np.ndarray, np.ndarray]], occupied: np.ndarray,
                  max_boxes: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Agglomerate boxes: repeatedly the pair whose common bounding box the occupied voxels
    fill best (counted with a summed-volume table) becomes that box, and boxes inside it
    are absorbed; while the best fill is at least ``MERGE_FILL`` or more than ``max_boxes``
    are left."""
    table = np.zeros(np.array(occupied.shape) + 1, dtype=np.int64)
    table[1:, 1:, 1:] = occupied.cumsum(0).cumsum(1).cumsum(2)
    lo = np.array([b[0] for b in boxes]).reshape(-1, 3)
    hi = np.array([b[1] for b in boxes]).reshape(-1, 3)
    fill = _union_fill(table, lo[:, None], hi[:, None], lo[None], hi[None])
    np.fill_diagonal(fill, -1.0)
    while len(lo) > 1:
        a, b = np.unravel_index(int(np.argmax(fill)), fill.shape)
        if fill[a, b] < MERGE_FILL and len(lo) <= max_boxes:
            break
        new_lo, new_hi = np.minimum(lo[a], lo[b]), np.maximum(hi[a], hi[b])
        keep = ~(np.all(lo >= new_lo, axis=1) & np.all(hi <= new_hi, axis=1))
        lo, hi = lo[keep], hi[keep]
        row = _union_fill(table, new_lo[None], new_hi[None], lo, hi)
        fill = np.block([[fill[keep][:, keep], row[:, None]], [row[None], np.array([[-1.0]])]])
        lo = np.concatenate([lo, new_lo[None]])
        hi = np.concatenate([hi, new_hi[None]])
    return list(zip(lo, hi, strict=True))


def _union_fill(table: np.ndarray, lo_a: np.ndarray, hi_a: np.ndarray, lo_b: np.ndarray,
                hi_b: np.ndarray) -> np.ndarray:
    """The fraction of the common bounding box of boxes a and b that is occupied."""
    lo, hi = np.minimum(lo_a, lo_b), np.maximum(hi_a, hi_b)
    return _count(table, lo, hi) / np.prod(hi - lo, axis=-1)


def _count(table: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Occupied voxels in boxes [lo, hi) (index arrays (..., 3)), by inclusion-exclusion."""
    total = np.zeros(lo.shape[:-1], dtype=np.int64)
    for corner in itertools.product((0, 1), repeat=3):
        idx = [np.where(c, hi[..., d], lo[..., d]) for d, c in enumerate(corner)]
        sign = (-1) ** (3 - sum(corner))
        total += sign * table[idx[0], idx[1], idx[2]]
    return total
