"""Collada (.dae) meshes, as most ROS robots ship them, read through pycollada.

The visual scene is walked as ROS tools show it: every ``<instance_geometry>`` (also through
``<instance_node>``) placed by the product of its nodes' transforms, in metres by the file's
``<unit meter>``. ``<up_axis>`` is not applied: URDF meshes are in their link frame, whatever
the exporter recorded. Each triangle's colour is its material's diffuse colour (pycollada's
material library), or its material's diffuse image through the primitive's first set of
texture coordinates (read only in a file that has images), or none. The bindings of materials to an
instance are taken out before pycollada reads the scene and kept aside, so a binding pycollada
cannot resolve (a material whose effect refers to a missing image: pycollada drops the whole
node) costs the colour only, never geometry. Only positions and their indices are read, and texture coordinates in a file
with images (:func:`_positions_only`). (trimesh's own Collada loader ignores the unit and loses such
nodes.)
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import NamedTuple
from urllib.parse import unquote

import numpy as np

from .errors import warn
from .meshtopology import unique_inverse
from .model import RGBA


class ColladaPiece(NamedTuple):
    """One placed primitive: its used vertices (metres, placed), triangles into them, and how
    it is drawn: its material's diffuse colour, or its image file with one texture coordinate
    per vertex (a corner seen with two coordinates is two vertices), or neither."""

    vertices: np.ndarray
    faces: np.ndarray
    color: RGBA | None = None
    image: Path | None = None
    uv: np.ndarray | None = None


def read_collada(path: Path, data: bytes | None = None) -> tuple[list[ColladaPiece], float]:
    """The file's placed primitives in scene order (:class:`ColladaPiece`; vertices in metres,
    scene-graph transforms applied) and its unit (metres per unit, already applied), from the
    file's bytes ``data`` where read already. Texture coordinates are read only in a file
    with images (``<library_images>``). Raises ValueError saying what is wrong."""
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
    textured = any(True for _ in root.iterfind("{*}library_images/{*}image"))
    _positions_only(root, keep_texcoords=textured)
    try:
        doc = collada.Collada(io.BytesIO(etree.tostring(root)),
                              ignore=[collada.common.DaeUnsupportedError,
                                      collada.common.DaeBrokenRefError])
    except collada.common.DaeError as e:
        raise ValueError(f"malformed Collada: {e}") from e
    unit = float(doc.assetInfo.unitmeter or 1.0) if doc.assetInfo is not None else 1.0
    if not np.isfinite(unit) or unit <= 0:
        raise ValueError(f"invalid <unit meter='{unit}'>")
    pieces: list[ColladaPiece] = []
    if doc.scene is not None:
        look = _Looks(doc, bindings, path)
        for node in doc.scene.nodes:
            _walk(node, np.eye(4), pieces, collada, look)
    else:  # no <scene>: the geometry library as it is (no instance binds a material)
        for geometry in doc.geometries:
            pieces += [ColladaPiece(*p) for p in (_triangles(q, None)
                                                  for q in geometry.primitives)
                       if p is not None]
    if not pieces:
        raise ValueError("no triangles in its scene")
    return [p._replace(vertices=p.vertices * unit) for p in pieces], unit


_UNREAD = "REAL2CODE_UNREAD"  # a semantic pycollada does not know: it keeps the input, reads nothing


def _positions_only(root, keep_texcoords: bool = False) -> None:
    """Empty every mesh's sources that only shading reads (normals, texture coordinates
    unless ``keep_texcoords``, colours, tangents) before pycollada parses them: this reader
    takes positions and their indices only, and parsing those sources' text was a fifth of a
    robot's whole export (sampled over a robot corpus; docs/benchmarks.md). Their inputs stay, under a semantic
    pycollada keeps unread, as each input's offset sets the stride of the primitive's index
    list."""
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
        kept = ("VERTEX", "TEXCOORD") if keep_texcoords else ("VERTEX",)
        positions |= {put.get("source", "").removeprefix("#") for put in primitive_inputs
                      if put.get("semantic") in kept}
        unread = set()
        for source in mesh.iterfind("{*}source"):
            if source.get("id") not in positions:
                unread.add(source.get("id"))
                for array in source.iterfind("{*}float_array"):
                    array.text = None
        for put in primitive_inputs:
            if put.get("source", "").removeprefix("#") in unread:
                put.set("semantic", _UNREAD)


class _Looks:
    """How a placed primitive is drawn: its material symbol, bound by the instance that places
    it to a material of pycollada's library, whose effect's diffuse is a colour or a texture
    (an image through a sampler, on one of the primitive's coordinate sets)."""

    def __init__(self, doc, bindings: dict[str, dict[str, str]], path: Path) -> None:
        self.doc, self.bindings, self.path = doc, bindings, path

    def __call__(self, instance, symbol) -> tuple[RGBA | None, Path | None]:
        """(colour, None), (None, the image file), or (None, None)."""
        path = self.doc.xmlnode.getpath(instance.xmlnode) if instance.xmlnode is not None \
            else None
        target = self.bindings.get(path, {}).get(symbol) if isinstance(symbol, str) else None
        material = self.doc.materials.get(target) if target else None
        diffuse = None if material is None or material.effect is None \
            else material.effect.diffuse
        if isinstance(diffuse, tuple) and len(diffuse) in (3, 4):
            rgba = np.clip(np.array([*diffuse, 1.0][:4], dtype=np.float64), 0.0, 1.0)
            return tuple(float(c) for c in rgba), None
        image = getattr(getattr(getattr(getattr(diffuse, "sampler", None), "surface", None),
                                "image", None), "path", None)
        if not image:
            return None, None
        image = unquote(image.removeprefix("file://"))
        return None, (self.path.parent / image if not Path(image).is_absolute()
                      else Path(image))


def _walk(node, parent: np.ndarray, pieces: list, collada, look: _Looks) -> None:
    if isinstance(node, collada.scene.GeometryNode):
        for primitive in node.geometry.primitives:
            rgba, image = look(node, primitive.material)
            piece = _triangles(primitive, image)
            if piece is not None:
                v, f, uv = piece
                pieces.append(ColladaPiece(v @ parent[:3, :3].T + parent[:3, 3], f, rgba,
                                           image if uv is not None else None, uv))
    elif isinstance(node, collada.scene.NodeNode):
        _walk(node.node, parent, pieces, collada, look)
    elif isinstance(node, collada.scene.Node):
        matrix = parent @ np.asarray(node.matrix, dtype=np.float64)
        for child in node.children or ():
            _walk(child, matrix, pieces, collada, look)


def _triangles(primitive, image: Path | None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None] | None:
    """A primitive's used vertices, triangles (polygons fan-triangulated; lines skipped,
    warned by :func:`read_collada`) and, where it is drawn from an ``image`` and has texture
    coordinates, one per vertex (its first set: the one exporters bind the diffuse to)."""
    import collada

    if isinstance(primitive, collada.polylist.Polylist):  # also <polygons>
        primitive = primitive.triangleset()
    if not isinstance(primitive, collada.triangleset.TriangleSet) or primitive.vertex is None:
        return None
    index = np.asarray(primitive.vertex_index, dtype=np.int64).reshape(-1, 3)
    if len(index) == 0:
        return None
    positions = np.asarray(primitive.vertex, dtype=np.float64).reshape(-1, 3)
    texcoords = primitive.texcoordset[0] if image is not None and primitive.texcoordset \
        else None
    if texcoords is not None and len(texcoords):
        uv_index = np.asarray(primitive.texcoord_indexset[0], dtype=np.int64).reshape(-1, 3)
        texcoords = np.asarray(texcoords, dtype=np.float64).reshape(len(texcoords), -1)[:, :2]
        # Exporters index a coordinate per corner, the same values again and again: equal
        # values are one coordinate, so a vertex is split only where its coordinates differ
        # (else every triangle stands alone: five times the vertices, and no shared edge to
        # smooth the normals over)
        # ((u, v) as one complex number: a sort of one column, a tenth of np.unique's by rows)
        pairs_uv = np.ascontiguousarray(texcoords).view(np.complex128).ravel()
        values, same = np.unique(pairs_uv, return_inverse=True)
        texcoords, uv_index = np.column_stack([values.real, values.imag]), same[uv_index]
        # (position, coordinate) pairs as one integer each, as the OBJ reader pairs them
        n_uv = np.int64(len(texcoords))
        pairs, faces = unique_inverse(index * n_uv + uv_index)
        return positions[pairs // n_uv], faces.reshape(-1, 3), texcoords[pairs % n_uv]
    used, faces = unique_inverse(index)
    return positions[used], faces.reshape(-1, 3), None
