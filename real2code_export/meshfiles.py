"""Mesh files shared by every exporter: one OBJ per distinct visual mesh, collision piece
and placed mesh asset.

Every format references the same files (``meshes/<part>.obj``,
``meshes/<part>_collision_<k>.obj``, ``meshes/<part>_mesh_<k>.obj`` for an asset placed
several times: :class:`MeshLayout`), each distinct mesh written once per export,
deterministically, so the same model gives byte-identical files. Reading: OBJ through
tinyobjloader (the geometry and its MTL colours in one pass, without importing trimesh and
scipy: a PartNet object is ~100 OBJ files and the export of one is a command a user waits
on), Collada through ``collada_mesh`` (pycollada: scene-graph transforms, unit and
materials' diffuse colours applied), everything else through trimesh (STL, glTF, PLY, ...).
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path
from typing import NamedTuple
from urllib.parse import unquote

import numpy as np

from .errors import FormatError, NoTrianglesError, warn
from .meshtopology import face_cross_products, unique_inverse, used_indices
from .model import RGBA, WHITE, ArticulatedObject, Mesh, Part, Texture
from .placements import placed_pieces, shared_assets, whole_placement


class MeshFile(NamedTuple):
    """What a mesh file holds for a part: its triangles (with UVs where it has them), its own
    colour (an OBJ's MTL ``Kd``, a Collada material's diffuse colour; the area-weighted mean
    where its triangles have several), its colour image (the MTL's ``map_Kd``) and, for a
    file of several colours, its triangles' colours as runs (number of triangles, RGBA, or
    None where a triangle has none) in their order, () otherwise.

    ``looks``: for a file whose triangles are drawn by several images, or by an image beside
    colours (no ``texture`` then), runs in order of (number of triangles, image or None,
    the image's tint or the flat colour); the part that shows it packs them with its other
    visuals into one image (:mod:`.texture_atlas`), once."""

    mesh: Mesh
    color: RGBA | None = None
    texture: Texture | None = None
    runs: tuple[tuple[int, RGBA | None], ...] = ()
    looks: tuple[tuple[int, Texture | None, RGBA], ...] = ()

MESH_DIR = "meshes"


def visual_relpath(part_name: str) -> str:
    return f"{MESH_DIR}/{part_name}.obj"


def collision_relpath(part_name: str, k: int) -> str:
    return f"{MESH_DIR}/{part_name}_collision_{k}.obj"


def visual_color_files(part: Part) -> list[tuple[str, Mesh, RGBA]]:
    """The visual's mesh files, (relpath, mesh, colour): what of the visual goes into a mesh
    file (its own triangles: formats write its shapes, box, cylinder..., as shapes) in the
    part's colour, or, for a visual of several colours, a file per colour
    (``<part>_colour_<k>.obj``, each a geometry of that colour in MJCF and URDF); [] when
    nothing is left."""
    pieces = [] if part.visual is None else part.visual.color_pieces()
    if len(pieces) == 1 and pieces[0][1] is None:
        return [(visual_relpath(part.name), pieces[0][0], part.color)]
    return [(f"{MESH_DIR}/{part.name}_colour_{k}.obj", mesh, rgba)
            for k, (mesh, rgba) in enumerate(pieces)]


def visual_element_name(part_name: str, k: int) -> str:
    """The name of the MJCF geom or URDF <visual> that holds :func:`visual_color_files`'s
    file ``k`` (0: named as a visual of one colour)."""
    return f"{part_name}_visual" if k == 0 else f"{part_name}_visual_colour_{k}"


def collision_file_meshes(part: Part) -> list[tuple[int, Mesh]]:
    """The collision pieces (index, mesh) that are mesh files: every piece but the shapes."""
    return [(k, m) for k, m in enumerate(part.collision) if m.primitive is None]


def material_relpath(part_name: str) -> str:
    return f"{MESH_DIR}/{part_name}.mtl"


def texture_relpath(part: Part) -> str:
    """Where a textured part's image goes, beside its meshes (every format refers to it)."""
    return image_relpath(part.texture)


def map_relpath(part: Part, role: str) -> str:
    """Where a part's material map (``PBR_MAPS``) goes, beside its meshes."""
    return image_relpath(part.maps[role])


def image_relpath(texture: Texture) -> str:
    """An image's file beside the meshes, named by its own name and its bytes' digest: parts
    that show the same image (a robot's four legs) share one file, whatever their names,
    and different images never share a name."""
    stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", texture.name).strip("._") or "image"
    return f"{MESH_DIR}/{stem}_{texture.digest[:8]}{texture.suffix}"


def image_textures(part: Part) -> dict[str, Texture]:
    """relpath -> image, for every image on the part (base colour and maps)."""
    out = {texture_relpath(part): part.texture} if part.texture is not None else {}
    return out | {map_relpath(part, role): t for role, t in part.maps.items()}


def image_files(part: Part) -> dict[str, bytes]:
    """relpath -> encoded image, for every image on the part (base colour and maps)."""
    return {rel: t.image for rel, t in image_textures(part).items()}


def obj_bytes(mesh: Mesh, exact: bool = False, material: str | None = None) -> bytes:
    """OBJ text: 9 decimals (nanometres) for exports, or the shortest exact float64 text
    (``exact=True``, for the lossless object.json); texture coordinates as ``vt`` (one per
    vertex, so faces read ``f a/a b/b c/c``); ``material``: the MTL file (``<material>.mtl``
    beside it) and material the faces use.

    Written directly rather than with trimesh's exporter, whose header and number
    formatting change between releases and would break byte-identical outputs.
    """
    if len(mesh.vertices) < 4:  # MuJoCo refuses a mesh of fewer (a one-triangle decal)
        mesh = _padded(mesh)
    # one %-format per block, not an f-string per line: the same text, 2.5x quicker
    number = "%r" if exact else "%.9f"
    lines = ["# real2code_export mesh\n"]
    if material is not None:
        lines.append(f"mtllib {material}.mtl\n")
    lines.append(_block(f"v {number} {number} {number}\n", mesh.vertices))
    if mesh.uv is not None:
        lines.append(_block(f"vt {number} {number}\n", mesh.uv))
    if material is not None:
        lines.append(f"usemtl {material}\n")
    corner = "%d/%d" if mesh.uv is not None else "%d"
    faces = mesh.faces + 1
    if mesh.uv is not None:
        faces = np.repeat(faces, 2, axis=1)
    lines.append(_block(f"f {corner} {corner} {corner}\n", faces))
    return "".join(lines).encode("ascii")


def _padded(mesh: Mesh) -> Mesh:
    """A mesh of fewer than 4 vertices with its centroid added, used by no face, so that
    MuJoCo, which refuses such a mesh, loads the file; the readers that keep only the
    vertices faces use (ours, MuJoCo's shell inertia, the viewers) see the same triangles."""
    def with_means(rows: np.ndarray) -> np.ndarray:
        return np.vstack([rows, np.repeat(rows.mean(axis=0, keepdims=True),
                                          4 - len(mesh.vertices), axis=0)])

    return Mesh(with_means(mesh.vertices), mesh.faces,
                None if mesh.uv is None else with_means(mesh.uv))


def _block(line: str, rows: np.ndarray) -> str:
    """``line`` %-formatted with each row of ``rows`` in turn, as one string."""
    return (line * len(rows)) % tuple(rows.ravel().tolist())


def mtl_bytes(part: Part) -> bytes:
    """A textured part's MTL: its colour (``Kd``, ``d``) and image (``map_Kd``)."""
    r, g, b, a = part.color
    lines = ["# real2code_export material", f"newmtl {part.name}", f"Kd {r!r} {g!r} {b!r}",
             f"d {a!r}", f"map_Kd {Path(texture_relpath(part)).name}"]
    return ("\n".join(lines) + "\n").encode("ascii")


class MeshGeometry(NamedTuple):
    """A mesh geometry a file-based format writes for a part (an MJCF geom, a URDF
    ``<visual>``/``<collision>``, an object.json entry): the file ``relpath`` holding
    ``mesh``, which lies at ``pose`` in the part frame (None: as the file has it), of colour
    ``rgba`` (a visual's; None for a collider), the element named ``name``."""

    name: str
    relpath: str
    mesh: Mesh
    rgba: RGBA | None
    pose: np.ndarray | None = None


class MeshLayout:
    """Every mesh file of an export and each part's geometries naming them, the one plan
    object.json, MJCF and URDF share (they share the files). A part's visual is its colour
    files (:func:`visual_color_files`) or, where it is wholly placements of mesh assets
    the object places more than once (:mod:`real2code_export.placements`), a geometry per
    placement naming the asset's one file (``<part>_mesh_<k>.obj``, after the first part
    placing it) at the placement's pose; a collision piece likewise. Placements are used
    only where each stretch is its asset moved bit for bit, so the lossless object.json
    reads the same numbers back from the same files."""

    def __init__(self, obj: ArticulatedObject) -> None:
        self.obj = obj
        shared = shared_assets(obj)
        taken = {rel for part in obj.parts
                 for rel in [r for r, _, _ in visual_color_files(part)]
                 + [collision_relpath(part.name, k) for k, _ in collision_file_meshes(part)]}
        asset_files: dict[int, str] = {}

        def asset_file(part: Part, asset: Mesh) -> str:
            if id(asset) not in asset_files:
                k = sum(rel.startswith(f"{MESH_DIR}/{part.name}_mesh_")
                        for rel in asset_files.values())
                while (rel := f"{MESH_DIR}/{part.name}_mesh_{k}.obj") in taken:
                    k += 1  # (a part named like another's asset file)
                taken.add(rel)
                asset_files[id(asset)] = rel
            return asset_files[id(asset)]

        self.visuals: dict[str, list[MeshGeometry]] = {}
        self.collisions: dict[str, list[tuple[int, MeshGeometry]]] = {}
        for part in obj.parts:
            own = part.visual.remainder() if part.visual is not None and shared else None
            pieces = None if own is None else placed_pieces(own, part, shared, exact=True)
            if pieces is not None:
                self.visuals[part.name] = [
                    MeshGeometry(_placed_visual_name(part.name, k), asset_file(part, p.asset),
                                 p.asset, part.color if rgba is None else rgba, p.pose)
                    for k, (p, rgba) in enumerate(pieces)]
            else:
                self.visuals[part.name] = [
                    MeshGeometry(visual_element_name(part.name, k), rel, mesh, rgba)
                    for k, (rel, mesh, rgba) in enumerate(visual_color_files(part))]
            collisions = []
            for k, mesh in collision_file_meshes(part):
                name = f"{part.name}_collision_{k}"
                p = whole_placement(mesh, shared, exact=True) if shared else None
                collisions.append((k, MeshGeometry(name, collision_relpath(part.name, k), mesh,
                                                   None) if p is None else
                                   MeshGeometry(name, asset_file(part, p.asset), p.asset,
                                                None, p.pose)))
            self.collisions[part.name] = collisions

    def geometries(self, part: Part) -> list[tuple[MeshGeometry, bool]]:
        """The part's mesh geometries, (geometry, whether it is a visual), visuals first."""
        return [(g, True) for g in self.visuals[part.name]] + [
            (g, False) for _, g in self.collisions[part.name]]

    def files(self) -> dict[str, tuple[Mesh, str | None]]:
        """relpath -> (the mesh it holds, the material it names: a textured visual's), each
        file once (an asset placed several times is one file)."""
        out: dict[str, tuple[Mesh, str | None]] = {}
        for part in self.obj.parts:
            material = part.name if part.texture is not None else None
            for g, visual in self.geometries(part):
                out.setdefault(g.relpath, (g.mesh, material if visual and g.pose is None
                                           else None))
        return out

    def shared_files(self) -> dict[str, str]:
        """Each mesh file an export writes (relpath) -> the first in part order holding the
        same mesh, itself where none before it does: a format that may name one file for
        several geometries (MJCF, URDF) names that one, so its tools read and compile each
        distinct mesh once (a gripper's left and right fingers, a collision piece that is its
        part's visual)."""
        first: dict[tuple, str] = {}
        return {rel: first.setdefault((material, _digest(mesh)), rel)
                for rel, (mesh, material) in self.files().items()}


def _placed_visual_name(part_name: str, k: int) -> str:
    """The MJCF geom's or URDF <visual>'s name of a visual's placement ``k`` (0: named as a
    visual of one mesh)."""
    return f"{part_name}_visual" if k == 0 else f"{part_name}_visual_mesh_{k}"


def shared_mesh_files(obj: ArticulatedObject) -> dict[str, str]:
    """:meth:`MeshLayout.shared_files` of the object's layout."""
    return MeshLayout(obj).shared_files()


def _digest(mesh: Mesh) -> bytes:
    """What tells two meshes' files apart: vertices, faces, texture coordinates."""
    import hashlib

    h = hashlib.blake2b(digest_size=16)
    for array in (mesh.vertices, mesh.faces, mesh.uv):
        h.update(b"-" if array is None else np.ascontiguousarray(array).tobytes())
        h.update(b"|")
    return h.digest()


def write_object_meshes(obj: ArticulatedObject, out_dir: Path, exact: bool = False
                        ) -> dict[str, Path]:
    """Write every distinct mesh file of ``obj``'s :class:`MeshLayout` under ``out_dir`` (an
    asset placed several times once; a mesh equal to one before it not again: every format
    names the first, :meth:`MeshLayout.shared_files`), a textured part's visual with its
    MTL and image beside it; returns relpath -> absolute path."""
    layout = MeshLayout(obj)
    written = {}

    def put(rel: str, data: bytes) -> None:
        path = out_dir / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
        written[rel] = path

    shared = layout.shared_files()
    for rel, (mesh, material) in layout.files().items():
        if shared[rel] == rel:  # (a mesh equal to one before it: that file serves both)
            put(rel, obj_bytes(mesh, exact, material))
    for part in obj.parts:
        if part.texture is not None and layout.visuals[part.name]:
            put(material_relpath(part.name), mtl_bytes(part))
    written.update(write_texture_images(obj, out_dir))
    return written


def warn_maps_not_referenced(obj: ArticulatedObject, format_name: str) -> None:
    """A format whose materials hold the base colour image only: each part's other maps are
    written beside the meshes but the file does not use them; say so."""
    for part in obj.parts:
        if part.maps:
            warn(f"{format_name}: part {part.name!r}: its {', '.join(sorted(part.maps))} "
                 f"map(s) are not used by the {format_name} file (it keeps the base colour "
                 "image only); the images are written beside the meshes")


def write_texture_images(obj: ArticulatedObject, out_dir: Path) -> dict[str, Path]:
    """Only the textured parts' images (formats that hold geometry inline, as USD does, still
    refer to them as files); returns relpath -> absolute path."""
    written = {}
    for part in obj.parts:
        for relpath, image in image_files(part).items():
            path = out_dir / relpath
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(image)
            written[relpath] = path
    return written


# Mesh files read here as the tools that use them read them (MuJoCo, trimesh): a folder of
# part meshes, an MJCF's mesh files.
MESH_SUFFIXES = (".obj", ".stl", ".ply", ".off")


def read_mesh(path: str | Path, *, source: str | Path | None = None, element: str | None = None,
              line: int | None = None, scale=None, key: tuple | None = None) -> Mesh:
    """Load a mesh file (any format trimesh reads) as one :class:`Mesh`, all pieces merged.

    ``source``/``element``/``line`` name the referencing file for the error message;
    ``key``: as :func:`read_mesh_file`'s.
    """
    return read_mesh_file(path, source=source, element=element, line=line, scale=scale,
                          key=key).mesh


def read_mesh_file(path: str | Path, *, source: str | Path | None = None,
                   element: str | None = None, line: int | None = None,
                   scale=None, key: tuple | None = None) -> MeshFile:
    """:func:`read_mesh` and the file's own colour: for an OBJ the area-weighted diffuse
    colour (``Kd``) of its MTL materials, None when it names none (or other formats), and its
    texture (``map_Kd``) where its faces have texture coordinates. A file read before with
    the same bytes is not parsed again (:class:`_ReadMeshes`); its warnings are said again.
    ``key``: the file's key from its bytes as the caller has just read them
    (:func:`read_ahead`'s), so that a file read there is not read and hashed again here."""
    path = Path(path)
    read = _READ.get(key) if key is not None else None
    if read is None:
        if not path.is_file():
            raise FormatError(source or path, element, f"mesh file not found: {path}", line)
        data = path.read_bytes()  # once: hashed for the key, then parsed
        key = _READ.key(path, data)
        read = _READ.get(key)
    if read is None:
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always")
            read = _read_unscaled(path, data, source, element, line)
        read = _READ.put(key, read, [(w.message, w.category) for w in said])
    mesh_file, said = read
    for message, category in said:  # each read says what reading the file says
        warnings.warn(message, category, stacklevel=2)
    mesh = Mesh(mesh_file.mesh.vertices, mesh_file.mesh.faces, mesh_file.mesh.uv)
    if scale is not None:
        mesh = Mesh(mesh.vertices * np.asarray(scale, dtype=float), mesh.faces, mesh.uv)
    return mesh_file._replace(mesh=mesh)


class _ReadMeshes:
    """The meshes read lately, by what they were read from, as MuJoCo keeps a mesh cache: the
    MJCF and URDF of one export name the same files, a model may name one file twice (a
    mirrored scale), and a process that reads both (a check, a read back, a survey) parses
    each once. The key is the file's bytes and, for an OBJ, its MTL files' bytes and their
    images' sizes and times (a file rewritten in place within the clock's tick is still
    seen). Arrays are kept read-only (every reader gets its own :class:`Mesh` of them); the
    least recently used go first past ``limit`` bytes of arrays."""

    def __init__(self, limit: int) -> None:
        self.limit, self.used = limit, 0
        self.entries: dict[tuple, tuple[MeshFile, list, int]] = {}

    @staticmethod
    def key(path: Path, data: bytes) -> tuple:
        """``path``'s key from its bytes ``data``. SHA-256: this CPU's SHA instructions
        hash a 4.6 MB Collada file in 2.6 ms, BLAKE2b in 9."""
        import hashlib

        h = hashlib.sha256(data)
        if path.suffix.lower() == ".obj":  # what the colour and texture are read from
            for name in _MTLLIB.findall(b"\n" + data):
                mtl = path.parent / name.decode("utf-8", "replace").strip()
                text = mtl.read_bytes() if mtl.is_file() else b""
                h.update(b"|" + text)
                for image in _MAP_LINE.findall(b"\n" + text):
                    image = mtl.parent / image.decode("utf-8", "replace").strip()
                    _hash_stat(h, image)
        elif path.suffix.lower() == ".dae" and b"<library_images" in data:  # its images
            for name in _INIT_FROM.findall(data):
                _hash_stat(h, path.parent / unquote(name.decode("utf-8", "replace").strip()
                                                    .removeprefix("file://")))
        return str(path.resolve()), h.digest()

    def get(self, key: tuple) -> tuple[MeshFile, list] | None:
        entry = self.entries.pop(key, None)
        if entry is None:
            return None
        self.entries[key] = entry  # most recently used last
        return entry[0], entry[1]

    def put(self, key: tuple, mesh_file: MeshFile, said: list) -> tuple[MeshFile, list]:
        arrays = [a for a in (mesh_file.mesh.vertices, mesh_file.mesh.faces,
                              mesh_file.mesh.uv) if a is not None]
        for a in arrays:
            a.flags.writeable = False
        size = sum(a.nbytes for a in arrays)
        if size <= self.limit:
            while self.entries and self.used + size > self.limit:
                self.used -= self.entries.pop(next(iter(self.entries)))[2]
            self.entries[key] = (mesh_file, said, size)
            self.used += size
        return mesh_file, said


def _hash_stat(h, file: Path) -> None:
    """An image's size and time into the key ``h`` (it is read only when the mesh is)."""
    if file.is_file():
        stat = file.stat()
        h.update(f"|{file} {stat.st_size} {stat.st_mtime_ns}".encode())


_READ = _ReadMeshes(512 << 20)
_MTLLIB = re.compile(rb"\nmtllib[ \t]+([^\r\n]+)")
_INIT_FROM = re.compile(rb"<init_from>([^<]+)</init_from>")
_MAP_LINE = re.compile(rb"\n[ \t]*map_\w+[ \t]+(?:-\S+[ \t]+\S+[ \t]+)*([^\r\n]+)")


def read_ahead(paths) -> dict[Path, tuple]:
    """Parse the STL files among ``paths`` not read yet on two threads, into the meshes read
    lately (:class:`_ReadMeshes`), where :func:`read_mesh_file` then finds them (by their
    keys, returned by path: each file read and hashed once): welding an
    STL's corners (sorting them) is most of reading one, numpy sorts without holding the GIL,
    and a robot's STL files are read at once on two cores where there are two
    (docs/benchmarks.md, session 28). STL reading says nothing but its errors (no warning,
    whose capture is not thread-safe); a file that fails is left to :func:`read_mesh_file`,
    which says why and where. OBJ and Collada parsers hold the GIL: read in turn, as before."""
    todo: dict[tuple, tuple[Path, bytes]] = {}
    keys: dict[Path, tuple] = {}
    for path in dict.fromkeys(map(Path, paths)):  # (a visual's file is often its collision's)
        if path.suffix.lower() != ".stl" or not path.is_file():
            continue
        data = path.read_bytes()
        key = keys[path] = _READ.key(path, data)
        if key not in todo and _READ.get(key) is None:
            todo[key] = (path, data)
    if len(todo) < 2:
        return keys  # (one file: read where it is asked for, by its key's miss)
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(2, thread_name_prefix="read-stl") as pool:  # (ended on return)
        futures = {key: pool.submit(_read_stl, path, data, None, None, None)
                   for key, (path, data) in todo.items()}
    for key, future in futures.items():
        if future.exception() is None:
            _READ.put(key, MeshFile(future.result()), [])
    return keys


def _read_unscaled(path: Path, data: bytes, source, element, line) -> MeshFile:
    """The file's mesh as :func:`read_mesh_file` reads it, before any scale, from its bytes
    ``data`` (tinyobjloader and trimesh read the file again themselves)."""
    if path.suffix.lower() == ".obj":
        return _read_obj(path, data, source, element, line)
    if path.suffix.lower() == ".dae":
        return _read_collada(path, data, source, element, line)
    if path.suffix.lower() == ".stl":
        return MeshFile(_read_stl(path, data, source, element, line))
    import trimesh

    try:
        loaded = trimesh.load(str(path), force="mesh", process=False, skip_materials=True)
    except Exception as e:  # trimesh raises many types for broken files
        raise FormatError(source or path, element,
                          f"cannot read mesh {path}: {type(e).__name__}: {e}", line) from e
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise NoTrianglesError(source or path, element, f"mesh {path} has no triangles", line)
    return MeshFile(Mesh.from_trimesh(loaded))


def _read_obj(path: Path, data: bytes, source, element, line) -> MeshFile:
    """An OBJ's triangles (polygons fanned by tinyobjloader; only the vertices the faces use,
    in file order, as trimesh keeps them) and its MTL colours (``Kd``, alpha 1, as trimesh
    reads MTLs). A missing MTL or texture costs the colour only, as in trimesh and the
    viewers."""
    import tinyobjloader

    reader, config = tinyobjloader.ObjReader(), tinyobjloader.ObjReaderConfig()
    config.triangulate = True
    if not reader.ParseFromFile(str(path), config):
        raise FormatError(source or path, element,
                          f"cannot read mesh {path}: {reader.Error().strip()}", line)
    vertices = _exact_vertices(data, np.array(reader.GetAttrib().vertices, dtype=np.float64))
    # the list accessors: numpy_vertices()/numpy_indices() of 2.0.0rc13 return wrong values
    shapes = [s.mesh for s in reader.GetShapes()]
    faces = np.concatenate([np.zeros(0, np.int64)]
                           + [np.array(m.vertex_indices(), dtype=np.int64) for m in shapes])
    if len(faces) == 0 or len(faces) % 3:
        raise NoTrianglesError(source or path, element, f"mesh {path} has no triangles",
                               line)
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise FormatError(source or path, element, f"mesh {path}: a face refers to vertex "
                          f"{int(faces.max()) + 1} of {len(vertices)}", line)
    uv_faces = np.concatenate([np.zeros(0, np.int64)]
                              + [np.array(m.texcoord_indices(), dtype=np.int64) for m in shapes])
    texcoords = np.array(reader.GetAttrib().texcoords, dtype=np.float64).reshape(-1, 2)
    material = np.concatenate([np.zeros(0, np.int64)]
                              + [np.array(m.material_ids, dtype=np.int64) for m in shapes])
    materials = reader.GetMaterials()
    if len(texcoords) and len(uv_faces) == len(faces) and uv_faces.max() < len(texcoords) \
            and uv_faces.min() < 0 and _bare_faces_untextured(uv_faces, material, materials) \
            and any((path.parent / m.diffuse_texname.replace("\\", "/")).is_file()
                    for m in materials if m.diffuse_texname):
        # faces of an image with coordinates beside faces of a colour without (the
        # layout of scanned-object datasets): the bare corners get a coordinate nothing reads (the
        # image's faces are then packed with the colours' as tiles: _needs_obj_atlas).
        # Only where an image is there: without one the mesh is read as before, unsplit.
        uv_faces = np.where(uv_faces < 0, len(texcoords), uv_faces)
        texcoords = np.vstack([texcoords, [0.0, 0.0]])
    if len(texcoords) and len(uv_faces) == len(faces) and uv_faces.min() >= 0 \
            and uv_faces.max() < len(texcoords):
        # a vertex seen with two texture coordinates becomes two (the model keeps one UV
        # per vertex, as glTF and USD's vertex primvars do)
        # (pairs as one integer each: unique rows sort in the same order, 10x quicker)
        n_uv = np.int64(len(texcoords))
        pairs, corners = unique_inverse(faces * n_uv + uv_faces)
        mesh = Mesh(vertices[pairs // n_uv], corners.reshape(-1, 3), texcoords[pairs % n_uv])
    else:
        used = np.zeros(len(vertices), dtype=bool)
        used[faces] = True
        renumber = np.cumsum(used) - 1  # a mask, not np.unique: no sort
        mesh = Mesh(vertices[used], renumber[faces].reshape(-1, 3))
    if mesh.uv is not None and _needs_obj_atlas(material, materials):
        return _obj_looks(path, mesh, material, materials)
    texture = _obj_texture(path, mesh, material, materials)
    known = (material >= 0) & (material < len(materials))
    return MeshFile(mesh, None, texture)._replace(
        **_face_colours(mesh, np.where(known, material, -1), [_kd(m) for m in materials]))


def _kd(material) -> RGBA:
    """An MTL material's colour as trimesh reads it: ``Kd``, alpha 1."""
    return (*(float(c) for c in np.clip(list(material.diffuse)[:3], 0.0, 1.0)), 1.0)


_MTL_MAPS = ("normal_texname", "bump_texname", "roughness_texname", "metallic_texname",
             "emissive_texname")  # tinyobjloader's fields for the maps beside map_Kd


def _obj_texture(path: Path, mesh: Mesh, material: np.ndarray, materials) -> Texture | None:
    """The colour image (``map_Kd``) the OBJ's faces use: one per mesh, as a part has one;
    more, a missing image, or one without texture coordinates to place it are warned about
    (the part keeps its colour, as viewers show it)."""
    used = [int(k) for k in used_indices(material) if k < len(materials)]
    others = sorted({f"{field.removesuffix('_texname')} ({getattr(materials[k], field)})"
                     for k in used for field in _MTL_MAPS if getattr(materials[k], field)})
    if others:  # MTL's PBR extension spreads glTF's maps over channels: not read yet
        warn(f"{path}: material maps {', '.join(others)} are not kept; the colour image is")
    names = list(dict.fromkeys(materials[k].diffuse_texname for k in used
                               if materials[k].diffuse_texname))
    if not names:
        return None
    if mesh.uv is None:
        warn(f"{path}: texture {names[0]!r} without texture coordinates on every face: "
             "not kept")
        return None
    if len(names) > 1:
        warn(f"{path}: {len(names)} textures ({', '.join(names)}); a part holds one: "
             f"{names[0]!r} kept")
    image_path = path.parent / names[0].replace("\\", "/")
    if not image_path.is_file():
        warn(f"{path}: texture image {image_path} not found: not kept")
        return None
    return texture_from_file(image_path)


def _bare_faces_untextured(uv_faces: np.ndarray, material: np.ndarray, materials) -> bool:
    """Whether every face without texture coordinates is drawn by a material without an
    image, and some face by one with: the coordinates an image needs are all there."""
    imaged = np.array([bool(m.diffuse_texname) for m in materials] + [False])
    face_image = imaged[np.where((material >= 0) & (material < len(materials)), material, -1)]
    bare = (uv_faces.reshape(-1, 3) < 0).any(axis=1)
    return bool(face_image.any()) and not (bare & face_image).any()


def _needs_obj_atlas(material: np.ndarray, materials) -> bool:
    """Whether the OBJ's faces use two images, or an image beside faces of no image."""
    used = [int(k) for k in used_indices(material) if k < len(materials)]
    images = {materials[k].diffuse_texname for k in used if materials[k].diffuse_texname}
    bare = len(used) > len(
        [k for k in used if materials[k].diffuse_texname]) or (material < 0).any()
    return len(images) > 1 or (len(images) == 1 and bare)


def _obj_looks(path: Path, mesh: Mesh, material: np.ndarray, materials) -> MeshFile:
    """An OBJ whose faces use several images, or an image beside colours: its runs of faces
    by material, each image tinted by its ``Kd``, each other material its colour
    (``MeshFile.looks``). An image that is not there costs its colour only, as viewers draw
    it."""
    from .model import DEFAULT_COLOR
    from .texture_atlas import AtlasPiece, needs_atlas

    images: dict[str, Texture | None] = {}
    looks = []
    starts = np.flatnonzero(np.r_[True, material[1:] != material[:-1]])
    for start, end in zip(starts, np.r_[starts[1:], len(material)], strict=True):
        k = int(material[start])
        known = 0 <= k < len(materials)
        name = materials[k].diffuse_texname if known else ""
        if name and name not in images:
            image_path = path.parent / name.replace("\\", "/")
            images[name] = texture_from_file(image_path) if image_path.is_file() else None
            if images[name] is None:
                warn(f"{path}: texture image {image_path} not found: not kept")
        looks.append((int(end - start), images.get(name) if name else None,
                      _kd(materials[k]) if known else DEFAULT_COLOR))
    known = (material >= 0) & (material < len(materials))
    coloured = MeshFile(mesh)._replace(**_face_colours(
        mesh, np.where(known, material, -1), [_kd(m) for m in materials]))
    if not any(texture is not None for _, texture, _ in looks):  # (every image missing)
        return coloured
    if not needs_atlas([AtlasPiece(mesh, t, c) for _, t, c in looks]):  # (one image left)
        return coloured._replace(texture=next(t for _, t, _ in looks if t is not None))
    return coloured._replace(looks=tuple(looks), runs=())


def texture_from_file(image_path: Path) -> Texture:
    """A texture from an image file: PNG and JPEG as they are; anything Pillow reads (TGA, BMP,
    ...) converted to PNG, with a warning, since glTF, USD and MuJoCo read only those two."""
    data = image_path.read_bytes()
    mime = Texture.sniff(data)
    if mime is None:
        import io

        from PIL import Image

        try:
            image = Image.open(io.BytesIO(data))
            buffer = io.BytesIO()
            image.save(buffer, format="PNG")
        except Exception as e:  # Pillow raises many types for unreadable images
            raise FormatError(image_path, None, f"cannot read texture image: {e}") from e
        warn(f"{image_path}: texture converted to PNG (glTF and USD read PNG and JPEG, MuJoCo PNG)")
        data, mime = buffer.getvalue(), "image/png"
    return Texture(data, mime, image_path.stem)


# (a line break before the ``v``, not ``^`` in MULTILINE mode: a literal prefix the regular
# expression engine searches for quickly; the numbers of a line in one group, split once)
_VERTEX_LINE = re.compile(rb"\nv[ \t]+(\S+[ \t]+\S+[ \t]+\S+)")


def _exact_vertices(data: bytes, parsed: np.ndarray) -> np.ndarray:
    """The OBJ's vertices as the nearest float64 to each number written: tinyobjloader's own
    number parser can be one unit in the last place off, which would break the lossless
    object.json round trip. Its values stand when the ``v`` lines do not read plainly."""
    try:
        numbers = b" ".join(_VERTEX_LINE.findall(b"\n" + data)).split()
        exact = np.array(numbers, dtype=np.float64).reshape(-1, 3)
    except ValueError:
        exact = np.zeros((0, 3))
    if exact.shape == (len(parsed) // 3, 3) and np.allclose(exact.ravel(), parsed, rtol=1e-6,
                                                               atol=1e-12):
        return exact
    return parsed.reshape(-1, 3)


def _face_colours(mesh: Mesh, index: np.ndarray, palette: list[RGBA]) -> dict:
    """A file's ``color`` (its faces' colours weighted by face area, None when none has one
    or they have no area) and ``runs`` (:class:`MeshFile`), from each face's colour as an
    index into ``palette`` (-1: none)."""
    colours = np.array(palette, dtype=np.float64).reshape(-1, 4)
    known = index >= 0
    color = None
    used = colours[index[known]]
    if known.any() and np.all(used == used[0]) and _has_area(mesh, known):
        # one colour (most files): the mean is it, channel by channel, as below; the faces'
        # areas are not needed (computing them was a twentieth of a robot's USD export)
        color = tuple(float(v) for v in used[0])
    elif known.any():
        area = 0.5 * np.linalg.norm(face_cross_products(mesh.vertices, mesh.faces[known]),
                                    axis=1)  # (as _areas: the same floats)
        if area.sum() > 0:
            mean = np.clip(area @ used / area.sum(), 0.0, 1.0)  # (round-off can pass 1)
            # a channel all faces agree on is that value (an alpha of 1 stays opaque)
            mean = np.where(np.all(used == used[0], axis=0), used[0], mean)
            color = tuple(float(v) for v in mean)
    # runs of equal colour (materials of one colour are one run)
    key = np.array([-1 if k < 0 else palette.index(palette[k]) for k in range(len(palette))]
                   + [-1])[index]
    if not len(key) or np.all(key == key[0]):  # (one value, or none: no runs)
        return {"color": color, "runs": ()}
    starts = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    lengths = np.diff(np.r_[starts, len(key)])
    runs = tuple((int(n), None if key[s] < 0 else palette[key[s]])
                 for s, n in zip(starts, lengths, strict=True))
    return {"color": color, "runs": runs}


def _areas(tri: np.ndarray) -> np.ndarray:
    return 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)


def _has_area(mesh: Mesh, known: np.ndarray) -> bool:
    """Whether the ``known`` faces' areas sum to more than 0, told from their first few:
    one of those with an area, and coordinates under 1e50 (nothing in any face's area
    overflows: none is NaN, none warns), is enough; else False (the caller sums them all)."""
    vertices = mesh.vertices
    if not (len(vertices) and np.abs(vertices).max() < 1e50):  # (NaN compares False)
        return False
    return bool(np.any(_areas(vertices[mesh.faces[known][:16]]) > 0))


_STL_RECORD = np.dtype([("normal", "<f4", 3), ("vertices", "<f4", (3, 3)), ("attribute", "<u2")])
STL_HEADER = 84  # 80 bytes of text, then the triangle count (uint32)


def binary_stl_triangles(head: bytes, size: int) -> int | None:
    """The triangle count of a binary STL of ``size`` bytes whose first bytes are ``head`` (84
    at least), or None where the file is no binary STL (its length is not what the count
    says: an ASCII one)."""
    if size < STL_HEADER or len(head) < STL_HEADER:
        return None
    count = int(np.frombuffer(head, "<u4", 1, STL_HEADER - 4)[0])
    return count if size == STL_HEADER + count * _STL_RECORD.itemsize else None


_STL_VERTEX = re.compile(rb"vertex\s+(\S+)\s+(\S+)\s+(\S+)", re.IGNORECASE)


def _read_stl(path: Path, data: bytes, source, element, line) -> Mesh:
    """An STL's triangles, as trimesh reads them (``process=False``) and MuJoCo keeps their
    vertices (:func:`_welded`): binary when the file's length is what its triangle count says,
    else ASCII (``vertex x y z`` lines, every solid in turn). Read here rather than by
    trimesh: STL is robots' most common mesh file (1394 of the 2335 mesh references in
    example-robot-data), and importing trimesh (with scipy) costs more than the rest of
    their USD export."""
    count = binary_stl_triangles(data[:STL_HEADER], len(data))
    if count is not None:
        corners = np.frombuffer(data, _STL_RECORD, count, STL_HEADER)["vertices"]
        corners = corners.reshape(-1, 3)
    else:
        try:
            corners = np.array(_STL_VERTEX.findall(data), dtype=np.float64).reshape(-1, 3)
        except ValueError as e:
            raise FormatError(source or path, element, f"cannot read STL mesh {path}: {e}",
                              line) from e
    if len(corners) == 0 or len(corners) % 3:
        raise NoTrianglesError(source or path, element, f"mesh {path} has no triangles",
                               line)
    return _welded(corners)  # (a binary STL's float32 as they are: widened once welded)


def _welded(corners: np.ndarray) -> Mesh:
    """Triangles given corner by corner (float32 or float64) as a mesh whose equal corners
    are one vertex (float64), in the order first met: MuJoCo's reading of an STL. An STL
    holds every vertex once per triangle that uses it (about 6 times); kept so, every file
    written from it (OBJ, USD, glTF) held them all and every tool that reads those read them
    all (MuJoCo compiling such an export took twice as long; docs/benchmarks.md). Equal
    corners are found by one sort: of a 64-bit key per corner where every coordinate is a
    float32 (:func:`_float32_runs`), else of the coordinates' bits (:func:`_sort_keys`);
    a corner's vertex is the first corner of its run of equals either way."""
    runs = _float32_runs(corners)
    if runs is None:
        corners = corners.astype(np.float64, copy=False)
        order = np.lexsort(_sort_keys(corners))  # stable: a run of equal corners in file order
        ordered = corners[order]
        starts = np.ones(len(order), dtype=bool)
        starts[1:] = np.any(ordered[1:] != ordered[:-1], axis=1)
        first = order[starts]  # where each run is first met
    else:
        order, starts = runs
        first = np.minimum.reduceat(order, np.flatnonzero(starts))  # (its runs unordered)
    run = np.empty(len(order), dtype=np.int64)
    run[order] = np.cumsum(starts) - 1  # each corner's run of equals
    by_first = np.argsort(first)  # (no ties: any sort gives this order)
    number = np.empty(len(first), dtype=np.int64)
    number[by_first] = np.arange(len(first))
    return Mesh(corners[first[by_first]].astype(np.float64, copy=False),
                number[run].reshape(-1, 3))


_KEY_MIX = np.uint64(0x9E3779B97F4A7C15)  # odd: z's bits spread over the key's 64


def _float32_runs(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Where every coordinate is a float32 and none is NaN (a binary STL's, as a rule): the
    corners' order under one 64-bit key each, and where each run of equal corners starts
    in that order; else None. The key is x's and y's bits side by side, z's bits mixed in
    (-0.0 folded into 0.0, the two that compare equal): equal corners share it, and one
    sort of it is a third of the time :func:`_sort_keys`' two keys take (each run's first
    corner is then its least index, not its place). Two unequal corners sharing a key, which
    differ in z then, are found, and answered None (the caller sorts by the bits)."""
    single = (corners + 0.0).astype(np.float32)
    if corners.dtype != np.float32 and not np.array_equal(single, corners):
        return None
    if np.isnan(single).any():  # (unequal to themselves: each NaN corner a vertex)
        return None
    bits = single.view(np.uint32)
    x, y, z = (bits[:, k].astype(np.uint64) for k in range(3))
    key = ((x << np.uint64(32)) | y) ^ (z * _KEY_MIX)
    order = np.argsort(key)
    ordered = key[order]
    starts = np.empty(len(order), dtype=bool)
    starts[:1] = True
    np.not_equal(ordered[1:], ordered[:-1], out=starts[1:])
    z_ordered = bits[:, 2][order]
    if np.any(z_ordered[1:][~starts[1:]] != z_ordered[:-1][~starts[1:]]):
        return None
    return order, starts


def _sort_keys(corners: np.ndarray) -> tuple[np.ndarray, ...]:
    """Integer keys for ``np.lexsort`` (last key first) under which equal corners are
    neighbours, as under their values (the order between unequal ones does not matter):
    the coordinates' bits, -0.0 folded into 0.0 (``+ 0.0``), the two that compare equal;
    packed two to an integer where every value is a float32 (a binary STL's). Twice as
    quick as sorting the float64 values."""
    single = (corners + 0.0).astype(np.float32)
    if np.array_equal(single, corners):
        bits = single.view(np.uint32).astype(np.uint64)
        return bits[:, 2], (bits[:, 0] << np.uint64(32)) | bits[:, 1]
    bits = (corners + 0.0).view(np.uint64)
    return bits[:, 2], bits[:, 1], bits[:, 0]


def _read_collada(path: Path, data: bytes, source, element, line) -> MeshFile:
    try:
        import collada  # noqa: F401 - pycollada reads the file
    except ImportError as e:
        raise FormatError(source or path, element, f"cannot read Collada mesh {path}: "
                          "pycollada is not installed (pip install pycollada)", line) from e
    from .collada_mesh import read_collada

    try:
        pieces, _ = read_collada(path, data)
    except ValueError as e:
        raise FormatError(source or path, element,
                          f"cannot read Collada (.dae) mesh {path}: {e}", line) from e
    if any(p.image is not None for p in pieces):
        return _textured_collada(path, pieces)
    return _coloured_collada(pieces)


def _coloured_collada(pieces) -> MeshFile:
    """A Collada mesh without images: its triangles' colours as runs."""
    mesh = Mesh.concatenate([Mesh(p.vertices, p.faces) for p in pieces]) if len(pieces) > 1 \
        else Mesh(pieces[0].vertices, pieces[0].faces)
    palette = list(dict.fromkeys(p.color for p in pieces if p.color is not None))
    index = np.repeat([-1 if p.color is None else palette.index(p.color) for p in pieces],
                      [len(p.faces) for p in pieces]).astype(np.int64)
    return MeshFile(mesh)._replace(**_face_colours(mesh, index, palette))


def _textured_collada(path: Path, pieces) -> MeshFile:
    """A Collada mesh with images: one image over every triangle, or its primitives' images
    and colours as ``MeshFile.looks`` where there are several, the colour white (nothing
    tints an image). An image that is not there costs its colour only."""
    from .model import DEFAULT_COLOR
    from .texture_atlas import AtlasPiece, needs_atlas

    images: dict[Path, Texture | None] = {}
    looks = []
    for p in pieces:
        texture = None
        if p.image is not None:
            if p.image not in images:
                images[p.image] = texture_from_file(p.image) if p.image.is_file() else None
                if images[p.image] is None:
                    warn(f"{path}: texture image {p.image} not found: not kept")
            texture = images[p.image]
        uv = p.uv if texture is not None else np.zeros((len(p.vertices), 2))  # (none drawn)
        looks.append(AtlasPiece(Mesh(p.vertices, p.faces, uv), texture,
                                WHITE if texture is not None else (p.color or DEFAULT_COLOR)))
    textured = [p for p in looks if p.texture is not None]
    if not textured:
        return _coloured_collada(pieces)
    mesh = Mesh.concatenate([p.mesh for p in looks])
    if not needs_atlas(looks):
        return MeshFile(mesh, WHITE, textured[0].texture)
    return MeshFile(mesh, WHITE, looks=tuple((len(p.mesh.faces), p.texture, p.color)
                                            for p in looks))
