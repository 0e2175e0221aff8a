"""Collada (.dae) meshes, as most ROS robots ship them, read through pycollada.

The visual scene is walked as ROS tools show it: every ``<instance_geometry>`` (also through
``<instance_node>``) placed by the product of its nodes' transforms, in metres by the file's
``<unit meter>``. ``<up_axis>`` is not applied: URDF meshes are in their link frame, whatever
the exporter recorded. Each triangle's colour is its material's diffuse colour (pycollada's
material library; a texture, or no material, gives none). The bindings of materials to an
instance are taken out before pycollada reads the scene and kept aside, so a binding pycollada
cannot resolve (a material whose effect refers to a missing image: pycollada drops the whole
node) costs the colour only, never geometry. Only positions and their indices are read
(:func:`_positions_only`). (trimesh's own Collada loader ignores the unit and loses such
nodes.)
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from .errors import warn
from .meshtopology import unique_inverse
from .model import RGBA


def read_collada(path: Path, data: bytes | None = None) -> tuple[
        np.ndarray, np.ndarray, float, list[tuple[int, RGBA | None]]]:
    """Vertices (metres, scene-graph transforms applied), triangles, the file's unit (metres
    per unit, already applied) and the triangles' colours, as runs: one (number of triangles,
    diffuse RGBA or None) per primitive placed, in the triangles' order, from the file's
    bytes ``data`` where read already. Raises ValueError saying what is wrong."""
    import collada
    from lxml import etree

    try:
        parser = etree.XMLParser(huge_tree=True)
        root = (etree.parse(str(path), parser).getroot() if data is None
                else etree.fromstring(data, parser, base_url=str(path)))
    except etree.XMLSyntaxError as e:
        raise ValueError(f"not a Collada file (not XML: {e})") from e
    if etree.QName(root).localname != "COLLADA":
        raise ValueError(f"not a Collada file (root element <{etree.QName(root).localname}>)")
    tree = root.getroottree()
    bindings: dict[str, dict[str, str]] = {}  # instance's path -> {symbol: material id}
    for binding in list(root.iter("{*}bind_material")):
        instance = binding.getparent()
        bindings[tree.getpath(instance)] = {
            m.get("symbol"): m.get("target", "").removeprefix("#")
            for m in binding.iter("{*}instance_material")}
        instance.remove(binding)
    lines = sum(1 for el in root.iter("{*}lines", "{*}linestrips")
                if etree.QName(el.getparent()).localname == "mesh")
    if lines:  # (edges a CAD exporter left in; the converters warn too)
        warn(f"{path}: {lines} Collada <lines>/<linestrips> primitive(s), edges with no "
             "surface: not read (no triangles to show or collide)")
    _positions_only(root)
    try:
        doc = collada.Collada(io.BytesIO(etree.tostring(root)),
                              ignore=[collada.common.DaeUnsupportedError,
                                      collada.common.DaeBrokenRefError])
    except collada.common.DaeError as e:
        raise ValueError(f"malformed Collada: {e}") from e
    unit = float(doc.assetInfo.unitmeter or 1.0) if doc.assetInfo is not None else 1.0
    if not np.isfinite(unit) or unit <= 0:
        raise ValueError(f"invalid <unit meter='{unit}'>")
    pieces: list[tuple[np.ndarray, np.ndarray, RGBA | None]] = []
    if doc.scene is not None:
        colour = _Colours(doc, bindings)
        for node in doc.scene.nodes:
            _walk(node, np.eye(4), pieces, collada, colour)
    else:  # no <scene>: the geometry library as it is (no instance binds a material)
        for geometry in doc.geometries:
            pieces += [(*p, None) for p in map(_triangles, geometry.primitives)
                       if p is not None]
    if not pieces:
        raise ValueError("no triangles in its scene")
    vertices, faces, runs, offset = [], [], [], 0
    for v, f, rgba in pieces:
        vertices.append(v)
        faces.append(f + offset)
        runs.append((len(f), rgba))
        offset += len(v)
    return np.concatenate(vertices) * unit, np.concatenate(faces), unit, runs


_UNREAD = "REAL2CODE_UNREAD"  # a semantic pycollada does not know: it keeps the input, reads nothing


def _positions_only(root) -> None:
    """Empty every mesh's sources that only shading reads (normals, texture coordinates,
    colours, tangents) before pycollada parses them: this reader takes positions and their
    indices only, and parsing those sources' text was a fifth of a robot's whole export
    (example-robot-data, sampled). Their inputs stay, under a semantic pycollada keeps
    unread, as each input's offset sets the stride of the primitive's index list."""
    for mesh in root.iter("{*}mesh"):
        positions = set()
        for vertices in mesh.iterfind("{*}vertices"):
            for put in list(vertices.iterfind("{*}input")):
                if put.get("semantic") == "POSITION":
                    positions.add(put.get("source", "").removeprefix("#"))
                else:
                    vertices.remove(put)
        primitive_inputs = [put for primitive in mesh if primitive.tag.endswith(
            ("triangles", "polylist", "polygons", "tristrips", "trifans", "lines",
             "linestrips")) for put in primitive.iterfind("{*}input")]
        positions |= {put.get("source", "").removeprefix("#") for put in primitive_inputs
                      if put.get("semantic") == "VERTEX"}
        unread = set()
        for source in mesh.iterfind("{*}source"):
            if source.get("id") not in positions:
                unread.add(source.get("id"))
                for array in source.iterfind("{*}float_array"):
                    array.text = None
        for put in primitive_inputs:
            if put.get("source", "").removeprefix("#") in unread:
                put.set("semantic", _UNREAD)


class _Colours:
    """A placed primitive's diffuse colour: its material symbol, bound by the instance that
    places it to a material of pycollada's library, whose effect's diffuse is a colour (not a
    texture)."""

    def __init__(self, doc, bindings: dict[str, dict[str, str]]) -> None:
        self.doc, self.bindings = doc, bindings

    def __call__(self, instance, symbol) -> RGBA | None:
        path = self.doc.xmlnode.getpath(instance.xmlnode) if instance.xmlnode is not None \
            else None
        target = self.bindings.get(path, {}).get(symbol) if isinstance(symbol, str) else None
        material = self.doc.materials.get(target) if target else None
        diffuse = None if material is None or material.effect is None \
            else material.effect.diffuse
        if not isinstance(diffuse, tuple) or len(diffuse) not in (3, 4):
            return None  # a texture (collada.material.Map), or no diffuse
        rgba = np.clip(np.array([*diffuse, 1.0][:4], dtype=np.float64), 0.0, 1.0)
        return tuple(float(c) for c in rgba)


def _walk(node, parent: np.ndarray, pieces: list, collada, colour: _Colours) -> None:
    if isinstance(node, collada.scene.GeometryNode):
        for primitive in node.geometry.primitives:
            piece = _triangles(primitive)
            if piece is not None:
                v, f = piece
                pieces.append((v @ parent[:3, :3].T + parent[:3, 3], f,
                               colour(node, primitive.material)))
    elif isinstance(node, collada.scene.NodeNode):
        _walk(node.node, parent, pieces, collada, colour)
    elif isinstance(node, collada.scene.Node):
        matrix = parent @ np.asarray(node.matrix, dtype=np.float64)
        for child in node.children or ():
            _walk(child, matrix, pieces, collada, colour)


def _triangles(primitive) -> tuple[np.ndarray, np.ndarray] | None:
    """A primitive's used vertices and triangles (polygons fan-triangulated; lines skipped,
    warned by :func:`read_collada`)."""
    import collada

    if isinstance(primitive, collada.polylist.Polylist):  # also <polygons>
        primitive = primitive.triangleset()
    if not isinstance(primitive, collada.triangleset.TriangleSet) or primitive.vertex is None:
        return None
    index = np.asarray(primitive.vertex_index, dtype=np.int64).reshape(-1, 3)
    if len(index) == 0:
        return None
    used, faces = unique_inverse(index)
    vertices = np.asarray(primitive.vertex, dtype=np.float64).reshape(-1, 3)[used]
    return vertices, faces.reshape(-1, 3)
