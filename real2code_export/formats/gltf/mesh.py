"""Model meshes as glTF vertex data, and back.

A visual mesh gets per-vertex normals. glTF has one normal per vertex, so a box with 8
shared corners would render as a blob: vertices are split along creases
(:mod:`real2code_export.normals`) and each output vertex keeps the index of the model vertex
it came from (``source``), so the reader restores the model's exact vertex list and faces. Collision
meshes are never rendered: written as they are, without normals.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...model import Mesh
from ...normals import creased_normals


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
    split = creased_normals(mesh)
    source = split.source
    identity = len(source) == len(mesh.vertices) and np.array_equal(source, np.arange(len(source)))
    return VertexData(
        positions=mesh.vertices[source].astype(np.float32),
        normals=split.normals,
        indices=split.indices.astype(_index_dtype(len(source))),
        source=None if identity else source.astype(np.uint32),
        texcoords=None if mesh.uv is None else flip_v(mesh.uv[source]).astype(np.float32),
    )


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
