"""Creased vertex normals: how a triangle mesh is shaded where a file carries normals.

A model mesh shares its vertices (a box has 8 corners), so one normal per model vertex would
shade a box as a blob. The faces are grouped into smoothing groups (the connected components
of the faces over the edges two faces share at a dihedral angle under CREASE_ANGLE, as
Blender's auto smooth and the glTF exporters split them) and each model vertex gets one
normal per smoothing group that uses it. glTF stores these as split vertices; USD as an
indexed face-varying ``primvars:normals``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .meshtopology import Edges, component_labels, face_cross_products, unique_inverse
from .model import Mesh

CREASE_ANGLE = np.radians(30.0)


@dataclass(frozen=True)
class CreasedNormals:
    source: np.ndarray  # (V',) int64: the model vertex of each split vertex
    indices: np.ndarray  # (F, 3) int64: each face's split vertices
    normals: np.ndarray  # (V', 3) float32 unit vectors, one per split vertex


def creased_normals(mesh: Mesh) -> CreasedNormals:
    """The mesh's vertices split along creases, with their area-weighted normals, from the
    float32 positions the files store (re-exporting what was read back then gives the same
    bytes). Vertices no face uses are kept, one split vertex each. Computed once per mesh
    (cached on it, read-only): an export to USD and glTF asks for each visual's in both."""
    cached = mesh.__dict__.get("_creased_normals")
    if cached is None:
        cached = mesh.__dict__["_creased_normals"] = _creased_normals(mesh)
    return cached


def _creased_normals(mesh: Mesh) -> CreasedNormals:
    vertices = mesh.vertices.astype(np.float32).astype(np.float64)
    faces = mesh.faces
    n_faces = len(faces)
    face_normals = face_cross_products(vertices, faces)  # area-weighted
    group = smoothing_groups(faces, face_normals)
    # one split vertex per (model vertex, smoothing group); unreferenced vertices kept too
    n_groups = int(group.max()) + 2 if n_faces else 1
    corner_key = faces * n_groups + group[:, None]
    used = np.zeros(len(vertices), dtype=bool)
    used[faces] = True
    unused = np.flatnonzero(~used)  # (np.setdiff1d: the same, hashing every corner, 20x slower)
    all_keys = np.concatenate([corner_key.reshape(-1), unused * n_groups + n_groups - 1])
    if len(vertices) * n_groups < 2**31:  # int32 keys sort in half the time, same answer
        all_keys = all_keys.astype(np.int32)
    keys, inverse = unique_inverse(all_keys)
    keys = keys.astype(np.int64)
    indices = inverse[: faces.size].reshape(-1, 3)
    # each split vertex's sum of its corners' face normals, added in corner order (what
    # np.add.at adds, the same floats; bincount is a tenth of its time)
    corners = indices.reshape(-1)
    normals = np.column_stack([np.bincount(corners, np.repeat(face_normals[:, k], 3),
                                           minlength=len(keys)) for k in range(3)])
    length = row_norms(normals)
    bad = length < 1e-20
    normals[bad] = (0.0, 0.0, 1.0)  # only degenerate faces touch it: any unit vector will do
    normals[~bad] /= length[~bad, None]
    normals = normals.astype(np.float32)
    normals /= row_norms(normals)[:, None]  # unit in float32 too
    split = CreasedNormals(keys // n_groups, indices, normals)
    for array in (split.source, split.indices, split.normals):
        array.flags.writeable = False
    return split


def smoothing_groups(faces: np.ndarray, cross: np.ndarray) -> np.ndarray:
    """Per face, its smoothing group: the connected components of the faces over the edges
    that exactly two faces share at a dihedral angle under CREASE_ANGLE (as trimesh's
    ``face_adjacency`` and ``face_adjacency_angles`` give them, with numpy alone: trimesh
    and scipy cost more to import than the export), from the faces and their area-weighted
    normals ``cross`` (which :func:`creased_normals` has computed already)."""
    pairs = Edges(faces).face_adjacency()
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]  # a degenerate face touching itself
    norm = np.sqrt(np.dot(cross * cross, [1.0, 1.0, 1.0]))
    valid = norm > 1e-13  # trimesh's zero: a degenerate face's normal is 0, never smooth
    unit = np.divide(cross, norm[:, None], out=np.zeros_like(cross), where=valid[:, None])
    dots = np.dot(unit[pairs[:, 0]] * unit[pairs[:, 1]], [1.0, 1.0, 1.0])
    return component_labels(len(faces), pairs[_under_crease_angle(dots)])


# Where a dot product is farther than this from cos(CREASE_ANGLE), the angle is told by the
# dot alone: there the angle is at least 2e-9 from CREASE_ANGLE, and arccos errs by 1e-16.
_CREASE_COS = np.cos(CREASE_ANGLE)
_CREASE_BAND = 1e-9


def _under_crease_angle(dots: np.ndarray) -> np.ndarray:
    """``abs(arccos(clip(dots, -1, 1))) < CREASE_ANGLE``, the same answers (NaN: False), with
    the arccos taken only of the dots near the crease's cosine (a tenth of a mesh's normals'
    time was arccos of every edge's)."""
    smooth = dots > _CREASE_COS + _CREASE_BAND
    near = np.flatnonzero(np.abs(dots - _CREASE_COS) <= _CREASE_BAND)
    smooth[near] = np.abs(np.arccos(np.clip(dots[near], -1.0, 1.0))) < CREASE_ANGLE
    return smooth


def row_norms(rows: np.ndarray) -> np.ndarray:
    """``np.linalg.norm(rows, axis=1)`` of an (N, 3) array, the same floats: the squares
    added as numpy's reduction adds them, (x^2 + y^2) + z^2, on the columns rather than
    three numbers at a time along each row (five times quicker)."""
    x, y, z = rows.T.copy()
    return np.sqrt((x * x + y * y) + z * z)

