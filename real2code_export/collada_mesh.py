"""Collada (.dae) meshes, as most ROS robots ship them, read through pycollada.

The visual scene is walked as ROS tools show it: every ``<instance_geometry>`` (also through
``<instance_node>``) placed by the product of its nodes' transforms, in metres by the file's
``<unit meter>``. ``<up_axis>`` is not applied: URDF meshes are in their link frame, whatever
the exporter recorded. Materials are not read: their bindings are removed before pycollada
sees the file, so a missing texture (pycollada drops the whole node) cannot lose geometry.
(trimesh's own Collada loader ignores the unit and loses such nodes.)
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np


def read_collada(path: Path) -> tuple[np.ndarray, np.ndarray, float]:
    """Vertices (metres, scene-graph transforms applied), triangles and the file's unit
    (metres per unit, already applied). Raises ValueError saying what is wrong."""
    import collada
    from lxml import etree

    try:
        root = etree.parse(str(path), etree.XMLParser(huge_tree=True)).getroot()
    except etree.XMLSyntaxError as e:
        raise ValueError(f"not a Collada file (not XML: {e})") from e
    if etree.QName(root).localname != "COLLADA":
        raise ValueError(f"not a Collada file (root element <{etree.QName(root).localname}>)")
    for binding in list(root.iter("{*}bind_material")):
        binding.getparent().remove(binding)
    try:
        doc = collada.Collada(io.BytesIO(etree.tostring(root)),
                              ignore=[collada.common.DaeUnsupportedError,
                                      collada.common.DaeBrokenRefError])
    except collada.common.DaeError as e:
        raise ValueError(f"malformed Collada: {e}") from e
    unit = float(doc.assetInfo.unitmeter or 1.0) if doc.assetInfo is not None else 1.0
    if not np.isfinite(unit) or unit <= 0:
        raise ValueError(f"invalid <unit meter='{unit}'>")
    pieces: list[tuple[np.ndarray, np.ndarray]] = []
    if doc.scene is not None:
        for node in doc.scene.nodes:
            _walk(node, np.eye(4), pieces, collada)
    else:  # no <scene>: the geometry library as it is
        for geometry in doc.geometries:
            pieces += [p for p in map(_triangles, geometry.primitives) if p is not None]
    if not pieces:
        raise ValueError("no triangles in its scene")
    vertices, faces, offset = [], [], 0
    for v, f in pieces:
        vertices.append(v)
        faces.append(f + offset)
        offset += len(v)
    return np.concatenate(vertices) * unit, np.concatenate(faces), unit


def _walk(node, parent: np.ndarray, pieces: list, collada) -> None:
    if isinstance(node, collada.scene.GeometryNode):
        for primitive in node.geometry.primitives:
            piece = _triangles(primitive)
            if piece is not None:
                v, f = piece
                pieces.append((v @ parent[:3, :3].T + parent[:3, 3], f))
    elif isinstance(node, collada.scene.NodeNode):
        _walk(node.node, parent, pieces, collada)
    elif isinstance(node, collada.scene.Node):
        matrix = parent @ np.asarray(node.matrix, dtype=np.float64)
        for child in node.children or ():
            _walk(child, matrix, pieces, collada)


def _triangles(primitive) -> tuple[np.ndarray, np.ndarray] | None:
    """A primitive's used vertices and triangles (polygons fan-triangulated; lines skipped)."""
    import collada

    if isinstance(primitive, collada.polylist.Polylist):  # also <polygons>
        primitive = primitive.triangleset()
    if not isinstance(primitive, collada.triangleset.TriangleSet) or primitive.vertex is None:
        return None
    index = np.asarray(primitive.vertex_index, dtype=np.int64).reshape(-1, 3)
    if len(index) == 0:
        return None
    used, faces = np.unique(index, return_inverse=True)
    vertices = np.asarray(primitive.vertex, dtype=np.float64).reshape(-1, 3)[used]
    return vertices, faces.reshape(-1, 3)
