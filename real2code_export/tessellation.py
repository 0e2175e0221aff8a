"""Triangle meshes of the primitive shapes (box, cylinder, capsule, sphere), the very
vertices and faces ``trimesh.creation`` makes (``box``, ``cylinder``, ``capsule``,
``icosphere``; ``tests/test_tessellation.py`` holds them equal), with numpy alone.

Not trimesh itself: importing it imports scipy, about 0.5 s of CPU, which is more than the
rest of a robot's USD export (issue 18), and robots are full of boxes and cylinders. The
algorithms are trimesh's: a box from the unit cube; a cylinder and a capsule by revolving
their outline about z (``creation.revolve``), coincident vertices then merged as trimesh's
constructor merges them; a sphere from the icosahedron, subdivided and projected
``subdivisions`` times (``creation.icosphere``).
"""

from __future__ import annotations

import numpy as np

from .meshtopology import merged

Triangles = tuple[np.ndarray, np.ndarray]  # (V, 3) float64 vertices, (F, 3) int64 faces

# trimesh's resources (creation._data): the unit cube and the unit icosahedron
_BOX_VERTICES = np.array([[0, 0, 0], [0, 0, 1], [0, 1, 0], [0, 1, 1], [1, 0, 0], [1, 0, 1],
                          [1, 1, 0], [1, 1, 1]], dtype=np.float64)
_BOX_FACES = np.array([[1, 3, 0], [4, 1, 0], [0, 3, 2], [2, 4, 0], [1, 7, 3], [5, 1, 4],
                       [5, 7, 1], [3, 7, 2], [6, 4, 2], [2, 7, 6], [6, 5, 4], [7, 5, 6]])
_A, _B = 0.5257311121191336, 0.85065080835204
_ICO_VERTICES = np.array([[-_A, _B, 0], [_A, _B, 0], [-_A, -_B, 0], [_A, -_B, 0],
                          [0, -_A, _B], [0, _A, _B], [0, -_A, -_B], [0, _A, -_B],
                          [_B, 0, -_A], [_B, 0, _A], [-_B, 0, -_A], [-_B, 0, _A]])
_ICO_FACES = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9],
                       [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2],
                       [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10],
                       [8, 6, 7], [9, 8, 1]])
_ZERO_AREA = 1e-8  # trimesh's tol.merge: revolved triangles this small are dropped


def box(extents) -> Triangles:
    """A box of full side lengths ``extents``, centred at the origin."""
    return (_BOX_VERTICES - 0.5) * np.asarray(extents, dtype=np.float64), _BOX_FACES.copy()


def cylinder(radius: float, height: float, sections: int = 32) -> Triangles:
    """A closed cylinder along z, centred at the origin, ``sections`` around."""
    half = abs(float(height)) / 2.0
    return _revolve([[0, -half], [radius, -half], [radius, half], [0, half]], sections)


def capsule(height: float, radius: float, count=(32, 64)) -> Triangles:
    """A capsule along z: a cylinder ``height`` long (without its caps) of ``radius``,
    ``count`` = (points along the outline, sections around), each made even."""
    count = np.array(count, dtype=np.int64)
    count += np.mod(count, 2)
    height, radius = abs(float(height)), abs(float(radius))
    theta = np.concatenate((np.linspace(-np.pi / 2.0, 0.0, count[0] // 2 + 1),
                            np.linspace(0.0, np.pi / 2.0, count[0] // 2 + 1)))
    outline = np.column_stack((np.cos(theta), np.sin(theta))) * radius
    half = len(outline) // 2
    outline[:half, 1] -= height / 2.0
    outline[half:, 1] += height / 2.0
    return _revolve(outline, int(count[1]))


def icosphere(subdivisions: int = 3, radius: float = 1.0) -> Triangles:
    """A sphere of ``radius``: the icosahedron subdivided ``subdivisions`` times, each time
    projected back onto the sphere."""
    vertices, faces = _ICO_VERTICES.copy(), _ICO_FACES.copy()
    for _ in range(max(subdivisions, 0)):
        vertices, faces = _subdivided(vertices, faces)
        vertices = _onto_sphere(vertices, radius)
    if subdivisions <= 0:
        vertices = _onto_sphere(vertices, radius)
    return vertices, faces


def _onto_sphere(vertices: np.ndarray, radius: float) -> np.ndarray:
    scalar = np.sqrt(np.dot(vertices**2, [1, 1, 1]))
    unit = vertices / scalar.reshape((-1, 1))
    return vertices + unit * (radius - scalar).reshape((-1, 1))


def _subdivided(vertices: np.ndarray, faces: np.ndarray) -> Triangles:
    """Each triangle split in four at its edges' midpoints (trimesh's ``remesh.subdivide``:
    the new vertices in the order of their edges sorted by (second, first) index)."""
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape((-1, 2)), axis=1)
    _, unique, inverse = np.unique(edges[:, 1] * np.int64(2**32) + edges[:, 0],
                                   return_index=True, return_inverse=True)
    mid = vertices[edges[unique]].mean(axis=1)
    m = inverse.reshape((-1, 3)) + len(vertices)
    split = np.column_stack([faces[:, 0], m[:, 0], m[:, 2], m[:, 0], faces[:, 1], m[:, 1],
                             m[:, 2], m[:, 1], faces[:, 2], m[:, 0], m[:, 1], m[:, 2]])
    return np.vstack((vertices, mid)), split.reshape((-1, 3))


def _revolve(outline, sections: int) -> Triangles:
    """The surface swept by the 2D ``outline`` (radius, z) turned once about z in
    ``sections`` steps (trimesh's ``creation.revolve`` with a full angle), its coincident
    vertices then merged (as trimesh's constructor, ``process=True``, merges them)."""
    outline = np.asarray(outline, dtype=np.float64)
    theta = np.linspace(0, np.pi * 2.0, sections + 1)
    points = np.column_stack((np.cos(theta), np.sin(theta)))
    per = len(outline)
    vertices = np.column_stack((np.tile(points, (1, per)).reshape((-1, 2))
                                * np.tile(outline[:, 0], len(points)).reshape((-1, 1)),
                                np.tile(outline[:, 1], len(points))))[:-per]
    single = np.tile(np.array([0, per, 1, 1, per, per + 1]), per - 1).reshape((-1, 3))
    single += np.tile(np.arange(per - 1), (2, 1)).T.reshape((-1, 1))
    tri = vertices[single]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    single = single[np.sqrt((cross**2).sum(axis=1)) / 2.0 > _ZERO_AREA]
    slices = len(theta) - 1
    offset = np.tile(np.arange(slices) * per, (len(single), 1)).T.reshape((-1, 1))
    faces = (np.tile(single.ravel(), slices).reshape((-1, 3)) + offset) % len(vertices)
    return merged(vertices, faces)
