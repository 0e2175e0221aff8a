"""Model meshes as glTF vertex data, and back.

A visual mesh gets per-vertex normals. glTF has one normal per vertex, so a box with 8
shared corners would render as a blob: vertices are split along creases (faces meeting at
more than CREASE_ANGLE form separate smoothing groups, found as connected components over
the smooth edges) and each output vertex keeps the index of the model vertex it came from
(``source``), so the reader restores the model's exact vertex list and faces. Collision
meshes are never rendered: written as they are, without normals.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...meshtopology import Edges, component_labels
from ...model import Mesh

CREASE_ANGLE = np.radians(30.0)


@dataclass
class VertexData:
    positions: np.ndarray  # (V', 3) float32
    normals: np.ndarray | None  # (V', 3) float32 unit vectors
    indices: np.ndarray  # (F, 3) uint16 or uint32
    source: np.ndarray | None  # (V',) uint32 model vertex of each output vertex; None: identity
    texcoords: np.ndarray | None = None  # (V', 2) float32, glTF's (u, 1 - v)


def _index_dtype(count: int):
    # 65535 is the primitive-restart value in some graphics APIs: avoid it in uint16
    return np.uint16 if count < 65535 else np.uint32


def encode_collision(mesh: Mesh) -> VertexData:
    return VertexData(mesh.vertices.astype(np.float32), None,
                      mesh.faces.astype(_index_dtype(len(mesh.vertices))), None)


def encode_visual(mesh: Mesh) -> VertexData:
    # normals from the float32 positions the file stores: re-exporting what was read back
    # then gives the same bytes
    uv = mesh.uv
    mesh = Mesh(mesh.vertices.astype(np.float32), mesh.faces)
    faces = mesh.faces
    n_faces = len(faces)
    face_normals = np.cross(mesh.vertices[faces[:, 1]] - mesh.vertices[faces[:, 0]],
                            mesh.vertices[faces[:, 2]] - mesh.vertices[faces[:, 0]])  # area-weighted
    group = smoothing_groups(mesh)
    # one output vertex per (model vertex, smoothing group); unreferenced vertices kept too
    n_groups = int(group.max()) + 2 if n_faces else 1
    corner_key = faces * n_groups + group[:, None]
    used = np.zeros(len(mesh.vertices), dtype=bool)
    used[faces] = True
    unused = np.flatnonzero(~used)  # (np.setdiff1d: the same, hashing every corner, 20x slower)
    keys, inverse = np.unique(np.concatenate([corner_key.reshape(-1), unused * n_groups + n_groups - 1]),
                              return_inverse=True)
    source = keys // n_groups
    indices = inverse[: faces.size].reshape(-1, 3)
    normals = np.zeros((len(keys), 3))
    np.add.at(normals, indices.reshape(-1), np.repeat(face_normals, 3, axis=0))
    length = np.linalg.norm(normals, axis=1)
    bad = length < 1e-20
    normals[bad] = (0.0, 0.0, 1.0)  # only degenerate faces touch it: any unit vector will do
    normals[~bad] /= length[~bad, None]
    normals = normals.astype(np.float32)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)  # unit in float32 too
    identity = len(keys) == len(mesh.vertices) and np.array_equal(source, np.arange(len(keys)))
    return VertexData(
        positions=mesh.vertices[source].astype(np.float32),
        normals=normals,
        indices=indices.astype(_index_dtype(len(keys))),
        source=None if identity else source.astype(np.uint32),
        texcoords=None if uv is None else flip_v(uv[source]).astype(np.float32),
    )


def smoothing_groups(mesh: Mesh) -> np.ndarray:
    """Per face, its smoothing group: the connected components of the faces over the edges
    that exactly two faces share at a dihedral angle under CREASE_ANGLE (as trimesh's
    ``face_adjacency`` and ``face_adjacency_angles`` give them, with numpy alone: trimesh
    and scipy cost more to import than the export)."""
    pairs = Edges(mesh.faces).face_adjacency()
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]  # a degenerate face touching itself
    tri = mesh.vertices.astype(np.float64)[mesh.faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    norm = np.sqrt(np.dot(cross * cross, [1.0, 1.0, 1.0]))
    valid = norm > 1e-13  # trimesh's zero: a degenerate face's normal is 0, never smooth
    unit = np.zeros_like(cross)
    unit[valid] = cross[valid] / norm[valid, None]
    dots = np.dot(unit[pairs[:, 0]] * unit[pairs[:, 1]], [1.0, 1.0, 1.0])
    smooth = pairs[np.abs(np.arccos(np.clip(dots, -1.0, 1.0))) < CREASE_ANGLE]
    return component_labels(len(mesh.faces), smooth)


def flip_v(uv: np.ndarray) -> np.ndarray:
    """glTF's texture coordinates put v = 0 at the image's top; the model's (OBJ's, USD's)
    at its bottom. The same map both ways."""
    return np.stack([uv[:, 0], 1.0 - uv[:, 1]], axis=1)


def decode(positions: np.ndarray, indices: np.ndarray, source: np.ndarray | None,
           texcoords: np.ndarray | None = None) -> Mesh:
    """The model mesh from glTF vertex data (inverse of :func:`encode_visual`)."""
    faces = np.asarray(indices, dtype=np.int64).reshape(-1, 3)
    uv = None if texcoords is None else flip_v(np.asarray(texcoords, dtype=np.float64))
    if source is None:
        return Mesh(positions, faces, uv)
    source = np.asarray(source, dtype=np.int64)
    vertices = np.zeros((int(source.max()) + 1 if len(source) else 0, 3))
    vertices[source] = positions
    model_uv = None
    if uv is not None:  # split copies of a vertex share its coordinates
        model_uv = np.zeros((len(vertices), 2))
        model_uv[source] = uv
    return Mesh(vertices, source[faces], model_uv)
