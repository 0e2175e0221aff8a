"""The topology of a triangle mesh that mass properties and glTF's smoothing groups need:
coincident vertices merged, edges counted, faces grouped into connected components, closed
components wound outward.

The same operations as trimesh's ``process=True``, ``is_watertight``,
``is_winding_consistent``, ``face_adjacency``, ``repair.fix_winding`` and
``repair.fix_inversion(multibody=True)``, on which these are modelled and against which
``tests/test_inertia_collision.py`` holds them. Not trimesh itself: importing it imports
scipy, about 0.5 s of CPU, which is more than a whole URDF -> USD export of a PartNet object
takes without it (issue 17), and these are a few numpy lines each.
"""

from __future__ import annotations

from collections import deque

import numpy as np

# Vertices are merged on a grid of 10**-8 (trimesh's tol.merge): OBJ files split vertices at
# seams, and no PartNet piece would be closed otherwise.
MERGE_DIGITS = 8


def used_indices(indices: np.ndarray) -> np.ndarray:
    """The distinct non-negative integers in ``indices``, sorted (``np.unique``'s answer, for
    the vertex indices of faces or the material ids of an OBJ's faces; negatives are none).
    Counted by ``np.bincount``: ``np.unique`` without ``return_*`` asks ``np.ma`` whether the
    array is masked, and importing ``numpy.ma`` costs 13 ms of CPU, 4 % of a URDF -> USD
    export of a PartNet object."""
    flat = np.asarray(indices).reshape(-1)
    flat = flat[flat >= 0]
    return np.flatnonzero(np.bincount(flat)) if len(flat) else np.zeros(0, dtype=np.intp)


def stable_argsort(keys: np.ndarray) -> np.ndarray:
    """``np.argsort(keys, kind="stable")`` of 1-D integer ``keys``, the same permutation.
    Where each key's position fits beside it in an int64 (key * len + position: no two
    alike), numpy's default sort of those, which needs no stability and runs vectorised
    (x86-simd-sort): a third of the stable sort's time on a mesh's edge keys (go1's largest
    link, 1.05 M corners: 139 -> 47 ms); else the stable sort itself."""
    keys = np.asarray(keys)
    n = len(keys)
    if n > 1 and keys.dtype.kind in "iu":
        low, high = int(keys.min()), int(keys.max())
        if (high - low + 1) * n < 2**63:  # (Python integers: no overflow in the test)
            tagged = keys.astype(np.int64)
            tagged -= low
            tagged *= n
            tagged += np.arange(n, dtype=np.int64)
            return np.argsort(tagged)
    return np.argsort(keys, kind="stable")


def unique_inverse(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(keys, return_inverse=True)`` of integer ``keys``, the same two arrays
    (the inverse of the flattened keys). Keys within a span of at most twice their number
    (a mesh's vertex indices, its corners' (vertex, smoothing group) keys) are counted, not
    sorted: a mark per value in the span, each key's rank the count of marks before it;
    others are sorted stably (:func:`stable_argsort`; ``np.unique`` sorts them by
    quicksort, half as quick on a mesh's keys, which come partly ordered)."""
    keys = np.asarray(keys).reshape(-1)
    if len(keys) and keys.dtype.kind in "iu":
        low, high = int(keys.min()), int(keys.max())
        if high - low < 2 * len(keys):
            offset = (keys - keys.dtype.type(low)).astype(np.intp)  # (in their own type)
            present = np.zeros(high - low + 1, dtype=bool)
            present[offset] = True
            rank = np.cumsum(present) - 1
            return (np.flatnonzero(present) + low).astype(keys.dtype), rank[offset]
    order = stable_argsort(keys)
    ordered = keys[order]
    starts = np.empty(len(keys), dtype=bool)
    starts[:1] = True
    np.not_equal(ordered[1:], ordered[:-1], out=starts[1:])
    inverse = np.empty(len(keys), dtype=np.intp)
    inverse[order] = np.cumsum(starts) - 1
    return ordered[starts], inverse


def face_cross_products(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(F, 3): each face's (b - a) x (c - a), as ``np.cross`` computes it (the same products
    and differences, so the same floats) on contiguous columns rather than strided views of
    an (F, 3, 3) gather: half its time on a robot's meshes (creased normals, a file's faces' areas)."""
    columns = vertices.T.copy()  # (3, V): x, y, z
    a, b, c = faces[:, 0], faces[:, 1], faces[:, 2]
    u = [columns[k][b] - columns[k][a] for k in range(3)]
    v = [columns[k][c] - columns[k][a] for k in range(3)]
    out = np.empty((len(faces), 3))
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        np.multiply(u[i], v[j], out=out[:, k])
        out[:, k] -= u[j] * v[i]
    return out


def merged(vertices: np.ndarray, faces: np.ndarray, digits: int = MERGE_DIGITS
           ) -> tuple[np.ndarray, np.ndarray]:
    """The vertices the faces use, those equal after rounding to ``digits`` decimals made
    one (in first-use order), and the faces renumbered."""
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    used = np.zeros(len(vertices), dtype=bool)
    used[faces] = True
    index = np.flatnonzero(used)
    grid = np.round(vertices[index] * 10.0**digits).astype(np.int64)
    _, first, inverse = np.unique(_row_keys(grid), return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")  # first-use order, as trimesh keeps it
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    renumber = np.zeros(len(vertices), dtype=np.int64)
    renumber[index] = rank[inverse.reshape(-1)]
    return vertices[index[first[order]]], renumber[faces]


def _row_keys(grid: np.ndarray) -> np.ndarray:
    """One sortable key per row of an (N, 3) integer array, equal exactly when the rows are:
    the three columns packed into an int64 where they fit in 21 bits each (as trimesh's
    ``hashable_rows``), else the rows as opaque bytes (slower to sort)."""
    low = grid.min(axis=0) if len(grid) else np.zeros(3, dtype=np.int64)
    shifted = grid - low
    if len(grid) == 0 or shifted.max() < 2**21:
        return (shifted[:, 0] << 42) | (shifted[:, 1] << 21) | shifted[:, 2]
    return np.ascontiguousarray(grid).view(np.dtype((np.void, 24))).reshape(-1)


class Edges:
    """A mesh's edges, each face corner's in turn ((a, b), (b, c), (c, a)), grouped by the
    undirected edge they are (one sort, shared by every question below)."""

    def __init__(self, faces: np.ndarray):
        self.faces = faces
        self.directed = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
        n = np.int64(int(faces.max()) + 1 if len(faces) else 1)
        a, b = self.directed[:, 0], self.directed[:, 1]
        lo, hi = np.minimum(a, b), np.maximum(a, b)  # (min(axis=1) on pairs: 30x slower)
        keys = lo * n + hi
        self.order = stable_argsort(keys)  # (ties by corner)
        sorted_keys = keys[self.order]
        self.starts = np.flatnonzero(np.r_[True, sorted_keys[1:] != sorted_keys[:-1]])
        self.sizes = np.diff(np.r_[self.starts, len(keys)])

    def counts(self) -> np.ndarray:
        """(3F,): how many faces share each corner's edge (2 on a closed surface)."""
        out = np.empty(len(self.directed), dtype=np.int64)
        out[self.order] = np.repeat(self.sizes, self.sizes)
        return out

    def watertight(self) -> bool:
        """Every edge shared by exactly two faces."""
        return len(self.faces) > 0 and bool(np.all(self.sizes == 2))

    def winding_consistent(self) -> bool:
        """On a watertight mesh: each edge walked once each way by its two faces."""
        if not self.watertight():
            return False
        first = self.directed[self.order[self.starts], 0]
        second = self.directed[self.order[self.starts + 1], 0]
        return bool(np.all(first != second))

    def face_adjacency(self) -> np.ndarray:
        """(A, 2) pairs of faces sharing an edge that exactly these two faces share."""
        pairs = self.starts[self.sizes == 2]
        return np.column_stack([self.order[pairs], self.order[pairs + 1]]) // 3


def component_labels(count: int, pairs: np.ndarray) -> np.ndarray:
    """Connected-component label of each of ``count`` nodes joined by ``pairs``, numbered
    in the order of each component's smallest node (as scipy's ``connected_components``)."""
    parent = np.arange(count)
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    while True:
        while True:  # point every node at its root
            grand = parent[parent]
            if np.array_equal(grand, parent):
                break
            parent = grand
        a, b = parent[pairs[:, 0]], parent[pairs[:, 1]]
        apart = a != b
        if not apart.any():
            break
        # hook each root under the smallest root it touches
        np.minimum.at(parent, np.maximum(a, b)[apart], np.minimum(a, b)[apart])
    # every node's parent is now its component's root, the smallest node in it (roots
    # hook under smaller ones only): a root's label is the count of roots before it
    # (np.unique's inverse of ``parent``, without its sort)
    rank = np.cumsum(parent == np.arange(count)) - 1
    return rank[parent]


def _tetra_volumes(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Signed volume of each tetrahedron (face, the vertices' mean): a closed mesh's volume
    does not depend on the apex, and the mean keeps round-off small."""
    tri = vertices[faces] - vertices[faces].reshape(-1, 3).mean(axis=0)
    return np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])) / 6.0


def signed_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    return float(_tetra_volumes(vertices, faces).sum()) if len(faces) else 0.0


def encloses_volume(vertices: np.ndarray, faces: np.ndarray) -> bool:
    """A positive volume beyond round-off (a two-sided sheet closes on itself with none)."""
    if len(faces) == 0:
        return False
    tetra = _tetra_volumes(vertices, faces)
    return bool(tetra.sum() > 1e-9 * np.abs(tetra).sum())


def wound_outward(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``faces`` of a watertight mesh with each connected component wound consistently
    (breadth first from its first face, as trimesh's ``fix_winding``) and turned outward
    where its volume came out negative (``fix_inversion(multibody=True)``)."""
    faces = faces.copy()
    pairs = Edges(faces).face_adjacency()
    neighbours: list[list[int]] = [[] for _ in range(len(faces))]
    for f, g in pairs.tolist():
        neighbours[f].append(g)
        neighbours[g].append(f)
    seen = np.zeros(len(faces), dtype=bool)
    for start in range(len(faces)):
        if seen[start]:
            continue
        seen[start] = True
        queue = deque([start])
        while queue:
            f = queue.popleft()
            for g in neighbours[f]:
                if seen[g]:
                    continue
                seen[g] = True
                queue.append(g)
                if _same_direction(faces[f], faces[g]):
                    faces[g] = faces[g][::-1]
    labels = component_labels(len(faces), pairs)
    for label in range(int(labels.max()) + 1 if len(labels) else 0):
        body = np.flatnonzero(labels == label)
        sub = faces[body]
        if len(body) >= 4 and Edges(sub).winding_consistent() \
                and signed_volume(vertices, sub) < 0:
            faces[body] = sub[:, ::-1]
    return faces


def _same_direction(f: np.ndarray, g: np.ndarray) -> bool:
    """Whether faces ``f`` and ``g`` walk their shared edge the same way (one is flipped)."""
    f_edges = {(int(f[i]), int(f[(i + 1) % 3])) for i in range(3)}
    return any((int(g[i]), int(g[(i + 1) % 3])) in f_edges for i in range(3))
