"""Triangle meshes between the model (float64 arrays) and Blender mesh data (float32)."""

from __future__ import annotations

import bpy
import numpy as np

from real2code_export.model import Mesh

UV_LAYER = "UVMap"  # Blender's own default name


def to_blender(name: str, mesh: Mesh) -> bpy.types.Mesh:
    """New mesh data holding ``mesh``'s triangles (bulk ``foreach_set``: PartNet parts have
    tens of thousands of faces)."""
    data = bpy.data.meshes.new(name)
    n_vertices, n_faces = len(mesh.vertices), len(mesh.faces)
    data.vertices.add(n_vertices)
    data.vertices.foreach_set("co", mesh.vertices.astype(np.float32).ravel())
    data.loops.add(3 * n_faces)
    data.loops.foreach_set("vertex_index", mesh.faces.astype(np.int32).ravel())
    data.polygons.add(n_faces)
    data.polygons.foreach_set("loop_start", np.arange(0, 3 * n_faces, 3, dtype=np.int32))
    if mesh.uv is not None:  # one coordinate per loop (face corner), from its vertex
        layer = data.uv_layers.new(name=UV_LAYER)
        layer.data.foreach_set("uv", mesh.uv[mesh.faces.reshape(-1)].astype(np.float32).ravel())
    data.update()
    return data


def from_blender(data: bpy.types.Mesh, transform: np.ndarray | None = None) -> Mesh:
    """The triangles of mesh data (polygons split by Blender's own triangulation), with the
    vertices mapped by ``transform`` (4x4) when given; with its active UV map, a vertex whose
    face corners have different coordinates (a seam) becomes one vertex per coordinate."""
    vertices = np.empty(3 * len(data.vertices), dtype=np.float32)
    data.vertices.foreach_get("co", vertices)
    vertices = vertices.reshape(-1, 3).astype(np.float64)
    data.calc_loop_triangles()
    faces = np.empty(3 * len(data.loop_triangles), dtype=np.int32)
    data.loop_triangles.foreach_get("vertices", faces)
    if transform is not None:
        vertices = vertices @ transform[:3, :3].T + transform[:3, 3]
    layer = data.uv_layers.active
    if layer is None or not len(data.loop_triangles):
        return Mesh(vertices, faces.reshape(-1, 3))
    loops = np.empty(3 * len(data.loop_triangles), dtype=np.int32)
    data.loop_triangles.foreach_get("loops", loops)
    loop_uv = np.empty(2 * len(data.loops), dtype=np.float32)
    layer.data.foreach_get("uv", loop_uv)
    corner_uv = loop_uv.reshape(-1, 2)[loops].astype(np.float64)
    keys = np.concatenate([faces.reshape(-1, 1).astype(np.float64), corner_uv], axis=1)
    unique, inverse = np.unique(keys, axis=0, return_inverse=True)
    return Mesh(vertices[unique[:, 0].astype(np.int64)], inverse.reshape(-1, 3), unique[:, 1:])


def object_mesh(obj: bpy.types.Object, depsgraph, transform: np.ndarray | None = None) -> Mesh:
    """An object's mesh as the viewport shows it (modifiers applied) where the object is
    evaluated, else its mesh data."""
    evaluated = obj.evaluated_get(depsgraph) if depsgraph is not None else obj
    if evaluated is obj:
        return from_blender(obj.data, transform)
    data = evaluated.to_mesh()
    try:
        return from_blender(data, transform)
    finally:
        evaluated.to_mesh_clear()
