"""Geoms of a compiled MuJoCo model as triangle meshes in their body's frame.

Mesh geoms are read from their files (float64, faces as written) where trimesh reads the
format, else taken from the compiled model (float32); primitives become meshes through
trimesh.creation. MuJoCo moves a mesh to its own inertial frame when it compiles and folds
that move into the geom pose; it is undone here, so a file mesh keeps its own coordinates.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ... import transforms as tf
from ...errors import FormatError
from ...meshfiles import read_mesh
from ...model import Mesh

# Formats trimesh reads as MuJoCo does; others (e.g. MuJoCo's own .msh) come from the model.
_FILE_FORMATS = (".obj", ".stl", ".ply", ".off")
_SPHERE_SUBDIVISIONS = 2
_ROUND_SECTIONS = 24


def pose(pos, quat) -> np.ndarray:
    return tf.make(tf.quat_to_matrix(quat), pos)


def geom_pose(model, g: int) -> np.ndarray:
    """Pose of geom ``g`` in its body, for the geometry :func:`geom_mesh` returns."""
    return pose(model.geom_pos[g], model.geom_quat[g])


def geom_mesh(model, g: int, source: Path, element: str,
              mesh_cache: dict[int, tuple[Mesh, np.ndarray]]) -> Mesh | None:
    """Geom ``g`` as a mesh in its body's frame; None for what has no finite surface
    (planes, height fields, SDFs), which the caller reports."""
    import mujoco

    from ... import tessellation  # trimesh.creation's meshes, without importing trimesh

    kind = int(model.geom_type[g])
    size = np.asarray(model.geom_size[g], dtype=np.float64)
    placed = geom_pose(model, g)
    G = mujoco.mjtGeom
    if kind == G.mjGEOM_MESH:
        mesh_id = int(model.geom_dataid[g])
        if mesh_id not in mesh_cache:
            mesh_cache[mesh_id] = _mesh_asset(model, mesh_id, source, element)
        mesh, mesh_frame = mesh_cache[mesh_id]
        transform = placed @ mesh_frame
        if np.allclose(transform, np.eye(4), rtol=0.0, atol=1e-12):
            return mesh  # the usual case (our own files): keep the numbers exactly
        return mesh.transformed(transform)
    if kind == G.mjGEOM_BOX:
        shape = tessellation.box(2.0 * size)
    elif kind == G.mjGEOM_SPHERE:
        shape = tessellation.icosphere(_SPHERE_SUBDIVISIONS, size[0])
    elif kind == G.mjGEOM_ELLIPSOID:
        vertices, faces = tessellation.icosphere(_SPHERE_SUBDIVISIONS, 1.0)
        shape = vertices * size, faces
    elif kind == G.mjGEOM_CAPSULE:  # MuJoCo: radius, half-length of the cylinder part
        shape = tessellation.capsule(2.0 * size[1], size[0],
                                     [_ROUND_SECTIONS, _ROUND_SECTIONS // 2])
    elif kind == G.mjGEOM_CYLINDER:  # radius, half-height
        shape = tessellation.cylinder(size[0], 2.0 * size[1], _ROUND_SECTIONS)
    else:
        return None
    return Mesh(*shape).transformed(placed)


def _mesh_asset(model, mesh_id: int, source: Path, element: str) -> tuple[Mesh, np.ndarray]:
    """The mesh in its own file coordinates (scaled), and the transform from those to the
    compiled geom frame (the inverse of MuJoCo's centring)."""
    start, count = int(model.mesh_vertadr[mesh_id]), int(model.mesh_vertnum[mesh_id])
    fstart, fcount = int(model.mesh_faceadr[mesh_id]), int(model.mesh_facenum[mesh_id])
    compiled = np.asarray(model.mesh_vert[start:start + count], dtype=np.float64)
    path = _mesh_path(model, mesh_id)
    if path is not None and path.suffix.lower() in _FILE_FORMATS:
        mesh = read_mesh(path, source=source, element=element,
                         scale=np.asarray(model.mesh_scale[mesh_id], dtype=np.float64))
        centring = pose(model.mesh_pos[mesh_id], model.mesh_quat[mesh_id])
        # Same place as MuJoCo's vertices (float32)? Else (legacy refpos/refquat, a reader
        # that saw another file) MuJoCo's own vertices are the truth.
        moved = mesh.transformed(tf.inverse(centring)).bounds()
        scale = max(float(np.abs(compiled).max(initial=0.0)), 1e-3)
        if len(compiled) and np.allclose(moved, _bounds(compiled), rtol=0.0, atol=1e-5 * scale):
            return mesh, tf.inverse(centring)
    faces = np.asarray(model.mesh_face[fstart:fstart + fcount], dtype=np.int64)
    if len(faces) == 0:
        raise FormatError(source, element, "mesh has no triangles")
    return Mesh(compiled, faces), np.eye(4)


def _bounds(vertices: np.ndarray) -> np.ndarray:
    return np.stack([vertices.min(axis=0), vertices.max(axis=0)])


def _mesh_path(model, mesh_id: int) -> Path | None:
    adr = int(model.mesh_pathadr[mesh_id])
    if adr < 0:
        return None
    raw = bytes(model.paths[adr:]).split(b"\0", 1)[0].decode("utf-8", errors="replace")
    return Path(raw) if raw else None
