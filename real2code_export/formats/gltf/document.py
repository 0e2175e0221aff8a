"""A glTF file opened for reading: its JSON (with pygltflib's property names) plus what every
reader needs (node parents, world transforms, meshes as model meshes) and errors that name
the element."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np

from ... import transforms as tf
from ...errors import FormatError, warn
from ...model import Mesh, Texture, sanitize_name
from .conventions import (
    TRIANGLES,
    Z_UP_FROM_Y_UP,
    AccessorReader,
    buffer_bytes,
    node_matrix,
    ours,
)
from .mesh import decode

GLB_MAGIC = b"glTF"
# glTF properties that default to an empty list / object when absent
_LISTS = frozenset({"accessors", "animations", "bufferViews", "buffers", "channels", "children",
                    "extensionsRequired", "extensionsUsed", "materials", "meshes", "nodes",
                    "primitives", "samplers", "scenes", "targets"})
_RAW = frozenset({"extras", "extensions"})  # free-form: handed out as plain dicts


class JsonView:
    """Attribute access to a glTF JSON object with pygltflib's property names.

    The importer reads the JSON through this view instead of pygltflib's document: pygltflib
    decodes every object with dataclasses_json, about 2 s for a 15-part object (1,200 glTF
    objects), while this costs nothing. Absent properties read as None (lists as [],
    ``extras``/``extensions`` as {}).
    """

    __slots__ = ("_data", "_cache", "_blob")

    def __init__(self, data: dict, blob: bytes | None = None):
        self._data = data
        self._cache: dict[str, object] = {}
        self._blob = blob

    def __getattr__(self, name: str):
        if name.startswith("_"):
            raise AttributeError(name)
        if name in self._cache:
            return self._cache[name]
        value = self._data.get(name)
        if value is None:
            value = [] if name in _LISTS else {} if name in _RAW else None
        elif name in _RAW:
            value = value if isinstance(value, dict) else {}
        elif isinstance(value, dict):
            value = JsonView(value)
        elif isinstance(value, list) and any(isinstance(v, dict) for v in value):
            value = [JsonView(v) if isinstance(v, dict) else v for v in value]
        self._cache[name] = value
        return value

    def binary_blob(self) -> bytes | None:
        return self._blob


def _read_glb(path: Path, data: bytes) -> tuple[bytes, bytes | None]:
    """The JSON and binary chunks of a GLB, refusing truncated or corrupt framing."""
    if len(data) < 20 or data[:4] != GLB_MAGIC:
        raise FormatError(path, "GLB header", "not a binary glTF (missing 'glTF' magic)")
    version, length = struct.unpack_from("<II", data, 4)
    if version != 2:
        raise FormatError(path, "GLB header", f"unsupported GLB version {version}")
    if length != len(data):
        raise FormatError(path, "GLB header", f"declares {length} bytes but the file has "
                                              f"{len(data)} (truncated or corrupt)")
    offset, k, chunks = 12, 0, {}
    while offset < length:
        if offset + 8 > length:
            raise FormatError(path, f"GLB chunk {k}", "truncated chunk header")
        size, kind = struct.unpack_from("<I4s", data, offset)
        if offset + 8 + size > length:
            raise FormatError(path, f"GLB chunk {k}", f"chunk of {size} bytes runs past the end "
                                                      "of the file")
        if k == 0 and kind != b"JSON":
            raise FormatError(path, "GLB chunk 0", "the first chunk must be JSON")
        chunks.setdefault(kind, data[offset + 8: offset + 8 + size])
        offset += 8 + size
        k += 1
    return chunks[b"JSON"], chunks.get(b"BIN\0")


def open_gltf(path: str | Path) -> JsonView:
    """The document of a .glb or .gltf file; FormatError for anything unreadable."""
    path = Path(path)
    if not path.is_file():
        raise FormatError(path, None, "file not found")
    data = path.read_bytes()
    blob = None
    if data[:4] == GLB_MAGIC or path.suffix.lower() == ".glb":
        data, blob = _read_glb(path, data)
    try:
        document = json.loads(data.decode("utf-8"))
    except UnicodeDecodeError as e:
        raise FormatError(path, None, f"glTF JSON is not UTF-8: {e}") from e
    except json.JSONDecodeError as e:
        raise FormatError(path, None, f"malformed glTF JSON: {e.msg}", e.lineno) from e
    if not isinstance(document, dict) or not isinstance(document.get("asset"), dict) \
            or not str(document["asset"].get("version", "")).startswith("2."):
        raise FormatError(path, "asset", "not a glTF 2.0 document (asset.version must be 2.x)")
    return JsonView(document, blob)


def _placed(mesh: Mesh, transform: np.ndarray | None) -> Mesh:
    """``mesh`` moved by ``transform`` (None: as it is); a mirroring transform flips the
    winding back."""
    if transform is None:
        return mesh
    mesh = mesh.transformed(transform)
    if np.linalg.det(transform[:3, :3]) < 0:
        mesh = Mesh(mesh.vertices, mesh.faces[:, ::-1], mesh.uv, colors=mesh.colors)
    return mesh


class Document:
    """Node tree queries over one glTF document (world transforms in Y-up or Z-up)."""

    def __init__(self, path: str | Path, gltf=None):
        self.path = Path(path)
        self.gltf = gltf if gltf is not None else open_gltf(path)
        self.nodes = self.gltf.nodes
        self.accessors = AccessorReader(self.gltf, self.path)
        self.parent: list[int | None] = [None] * len(self.nodes)
        for i, node in enumerate(self.nodes):
            for c in node.children or []:
                if not 0 <= c < len(self.nodes):
                    raise FormatError(self.path, self.element(i), f"child {c} does not exist")
                if self.parent[c] is not None:
                    raise FormatError(self.path, self.element(c), "has more than one parent")
                self.parent[c] = i
        self.scene_order = self._scene_order()
        self.in_scene = set(self.scene_order)
        self._world: dict[int, np.ndarray] = {}

    def element(self, i: int) -> str:
        name = self.nodes[i].name if 0 <= i < len(self.nodes) else None
        return f"nodes[{i}]" + (f" ({name})" if name else "")

    def _scene_order(self) -> list[int]:
        """Nodes of the default scene, depth first (cycles refused)."""
        scenes = self.gltf.scenes or []
        if not scenes:
            roots = [i for i, p in enumerate(self.parent) if p is None]
        else:
            index = self.gltf.scene if self.gltf.scene is not None else 0
            if not 0 <= index < len(scenes):
                raise FormatError(self.path, "scene", f"scene {index} does not exist")
            roots = list(scenes[index].nodes or [])
        order, seen, stack = [], set(), list(reversed(roots))
        while stack:
            i = stack.pop()
            if not 0 <= i < len(self.nodes):
                raise FormatError(self.path, "scene", f"node {i} does not exist")
            if i in seen:
                raise FormatError(self.path, self.element(i), "the node tree has a cycle")
            seen.add(i)
            order.append(i)
            stack.extend(reversed(self.nodes[i].children or []))
        return order

    def ours(self, i: int) -> dict:
        return ours(self.nodes[i].extras)

    def world(self, i: int) -> np.ndarray:
        """World transform of node ``i`` in the model's Z-up frame."""
        if i not in self._world:
            chain, j = [], i
            while j is not None:
                chain.append(j)
                j = self.parent[j]
                if len(chain) > len(self.nodes):
                    raise FormatError(self.path, self.element(i), "the node tree has a cycle")
            t = Z_UP_FROM_Y_UP.copy()
            for j in reversed(chain):
                t = t @ node_matrix(self.nodes[j])
            self._world[i] = t
        return self._world[i]

    def mesh(self, index: int, element: str, transform: np.ndarray | None = None) -> Mesh:
        """glTF mesh ``index`` (its triangle primitives merged) as a model mesh, optionally
        transformed (a mirroring transform flips the winding back). Primitives of several
        base colours give a mesh with colour runs; consecutive primitives reading the same
        vertex accessors (our writer's colours on one visual) are one piece of their
        triangles in turn."""
        pieces, keys, runs = [], [], []  # runs: each piece's (face count, colour) in order
        for prim, piece in self._triangle_primitives(index, element):
            positions, indices, source, texcoords = piece
            key = (prim.attributes.POSITION, ours(prim.extras).get("source_vertex"),
                   getattr(prim.attributes, "TEXCOORD_0", None))
            run = (len(indices) // 3, self.material_color(prim.material))
            if pieces and keys[-1] == key:  # the same vertices: one piece
                indices = np.concatenate([pieces[-1][1], indices])
                pieces[-1], runs[-1] = (positions, indices, source, texcoords), \
                    runs[-1] + [run]
            else:
                pieces.append(piece)
                keys.append(key)
                runs.append([run])
        return _placed(Mesh.join_colored([decode(*piece) for piece in pieces], runs),
                       transform)

    def primitive_meshes(self, index: int, element: str, transform: np.ndarray | None = None
                         ) -> list[tuple[Mesh, int | None]]:
        """Each triangle primitive of glTF mesh ``index`` as a mesh of its own (with its
        texture coordinates), and its material: a mesh drawn by several materials."""
        return [(_placed(decode(*piece), transform), prim.material)
                for prim, piece in self._triangle_primitives(index, element)]

    def _triangle_primitives(self, index: int, element: str):
        """(primitive, (positions, indices, source vertices, texture coordinates)) for each
        triangle primitive of glTF mesh ``index``, checked; others skipped, warned."""
        meshes = self.gltf.meshes or []
        if not 0 <= index < len(meshes):
            raise FormatError(self.path, element, f"mesh {index} does not exist")
        for k, prim in enumerate(meshes[index].primitives or []):
            el = f"meshes[{index}].primitives[{k}]"
            if (prim.mode if prim.mode is not None else TRIANGLES) != TRIANGLES:
                warn(f"{self.path}: {el}: not a triangle list (mode {prim.mode}); skipped")
                continue
            if getattr(prim.attributes, "POSITION", None) is None:
                raise FormatError(self.path, el, "has no POSITION attribute")
            positions = self.accessors.read(prim.attributes.POSITION)
            if prim.indices is not None:
                indices = self.accessors.read(prim.indices)
            else:
                indices = np.arange(len(positions))
            if len(indices) % 3:
                raise FormatError(self.path, el, f"{len(indices)} indices is not a triangle list")
            source = ours(prim.extras).get("source_vertex")
            source = self.accessors.read(source) if source is not None else None
            if len(indices) and (indices.min() < 0 or indices.max() >= len(positions)):
                raise FormatError(self.path, el, "indices out of range")
            if source is not None and (len(source) != len(positions) or source.min() < 0):
                raise FormatError(self.path, el, "source_vertex does not match POSITION")
            texcoords = getattr(prim.attributes, "TEXCOORD_0", None)
            if texcoords is not None:
                texcoords = self.accessors.read(texcoords)
                if texcoords.shape != (len(positions), 2):
                    raise FormatError(self.path, el, "TEXCOORD_0 does not match POSITION")
            yield prim, (positions, indices, source, texcoords)

    def material_color(self, material: int | None) -> tuple[float, float, float, float] | None:
        """A material's base colour factor (None: no material, or none stated)."""
        if material is None or not 0 <= material < len(self.gltf.materials or []):
            return None
        pbr = self.gltf.materials[material].pbrMetallicRoughness
        factor = getattr(pbr, "baseColorFactor", None) if pbr is not None else None
        if not factor or len(factor) != 4:
            return None
        return tuple(float(np.clip(v, 0.0, 1.0)) for v in factor)

    def texture(self, mesh_index: int | None) -> Texture | None:
        """The base colour image of the first primitive's material (PNG or JPEG, from the
        binary buffer, a data URI or a file beside the document), if any."""
        return self.images(mesh_index).get("texture")

    def maps(self, mesh_index: int | None) -> dict[str, Texture]:
        """The first primitive's material maps beside the base colour (``PBR_MAPS``)."""
        return {role: t for role, t in self.images(mesh_index).items() if role != "texture"}

    def images(self, mesh_index: int | None) -> dict[str, Texture]:
        """role ("texture" for the base colour, or a ``PBR_MAPS`` role) -> image, for the
        first primitive's material. A map on a second set of texture coordinates is not
        kept (the model holds one), with a warning."""
        if mesh_index is None:
            return {}
        prims = self.gltf.meshes[mesh_index].primitives or []
        return self.material_images(prims[0].material) if prims else {}

    def material_images(self, k: int | None) -> dict[str, Texture]:
        """role -> image of material ``k`` (:meth:`images`); {} for no material."""
        if k is None or not 0 <= k < len(self.gltf.materials or []):
            return {}
        material = self.gltf.materials[k]
        pbr = material.pbrMetallicRoughness
        infos = {
            "texture": ("pbrMetallicRoughness.baseColorTexture",
                        getattr(pbr, "baseColorTexture", None) if pbr is not None else None),
            "metallic_roughness": (
                "pbrMetallicRoughness.metallicRoughnessTexture",
                getattr(pbr, "metallicRoughnessTexture", None) if pbr is not None else None),
            "normal": ("normalTexture", material.normalTexture),
            "occlusion": ("occlusionTexture", material.occlusionTexture),
            "emissive": ("emissiveTexture", material.emissiveTexture),
        }
        out = {}
        for role, (field, info) in infos.items():
            if info is None:
                continue
            el = f"materials[{k}].{field}"
            if (info.texCoord or 0) != 0:
                warn(f"{self.path}: {el}: on TEXCOORD_{info.texCoord}; only TEXCOORD_0 is "
                     "kept, so this image is not")
                continue
            texture = self._image(info, el)
            if texture is not None:
                out[role] = texture
        return out

    def _image(self, info, el: str) -> Texture | None:
        textures, images = self.gltf.textures or [], self.gltf.images or []
        index = info.index
        if not isinstance(index, int) or not 0 <= index < len(textures) \
                or not isinstance(textures[index].source, int) \
                or not 0 <= textures[index].source < len(images):
            raise FormatError(self.path, el, "refers to a texture or image that does not exist")
        image = images[textures[index].source]
        el = f"images[{textures[index].source}]"
        if image.bufferView is not None:
            view = self.gltf.bufferViews[image.bufferView]
            start = view.byteOffset or 0
            data = buffer_bytes(self.gltf, self.path, view.buffer)[start:start + view.byteLength]
        elif image.uri and image.uri.startswith("data:"):
            import base64

            try:
                data = base64.b64decode(image.uri.split(",", 1)[1])
            except (IndexError, ValueError) as e:
                raise FormatError(self.path, el, f"bad data URI: {e}") from e
        elif image.uri:
            from urllib.parse import unquote

            file = self.path.parent / unquote(image.uri)
            if not file.is_file():
                warn(f"{self.path}: {el}: image file {file} not found; the texture is not kept")
                return None
            data = file.read_bytes()
        else:
            raise FormatError(self.path, el, "has neither a bufferView nor a uri")
        mime = Texture.sniff(data)
        if mime is None:
            warn(f"{self.path}: {el}: not PNG or JPEG; the texture is not kept")
            return None
        return Texture(data, mime, sanitize_name(image.name or "texture"))

    def color(self, mesh_index: int | None) -> tuple[float, float, float, float] | None:
        """Base colour of the first primitive's material, if any."""
        if mesh_index is None:
            return None
        prims = self.gltf.meshes[mesh_index].primitives or []
        return self.material_color(prims[0].material) if prims else None


def rigid(t: np.ndarray) -> np.ndarray:
    """The rigid part of an affine transform (scale and shear removed)."""
    return tf.make(rotation=tf.orthonormalize(t[:3, :3]), translation=t[:3, 3])

