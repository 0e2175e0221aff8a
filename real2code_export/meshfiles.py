"""Mesh files shared by every exporter: one OBJ per visual mesh and per collision piece.

Every format references the same files (``meshes/<part>.obj``,
``meshes/<part>_collision_<k>.obj``), written once per export, deterministically, so the
same model gives byte-identical files. Reading: OBJ through tinyobjloader (the geometry and
its MTL colours in one pass, without importing trimesh and scipy: a PartNet object is ~100
OBJ files and the export of one is a command a user waits on), Collada through
``collada_mesh`` (pycollada: scene-graph transforms and unit applied), everything else
through trimesh (STL, glTF, PLY, ...).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from .errors import FormatError
from .model import ArticulatedObject, Mesh

RGBA = tuple[float, float, float, float]

MESH_DIR = "meshes"


def visual_relpath(part_name: str) -> str:
    return f"{MESH_DIR}/{part_name}.obj"


def collision_relpath(part_name: str, k: int) -> str:
    return f"{MESH_DIR}/{part_name}_collision_{k}.obj"


def obj_bytes(mesh: Mesh, exact: bool = False) -> bytes:
    """OBJ text: 9 decimals (nanometres) for exports, or the shortest exact float64 text
    (``exact=True``, for the lossless object.json).

    Written directly rather than with trimesh's exporter, whose header and number
    formatting change between releases and would break byte-identical outputs.
    """
    lines = ["# real2code_export mesh"]
    if exact:
        lines += [f"v {x!r} {y!r} {z!r}" for x, y, z in mesh.vertices.tolist()]
    else:
        lines += [f"v {x:.9f} {y:.9f} {z:.9f}" for x, y, z in mesh.vertices.tolist()]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in mesh.faces.tolist()]
    return ("\n".join(lines) + "\n").encode("ascii")


def write_object_meshes(obj: ArticulatedObject, out_dir: Path, exact: bool = False) -> dict[str, Path]:
    """Write every mesh of ``obj`` under ``out_dir``; returns relpath -> absolute path."""
    written = {}
    for part in obj.parts:
        items = []
        if part.visual is not None:
            items.append((visual_relpath(part.name), part.visual))
        items += [(collision_relpath(part.name, k), m) for k, m in enumerate(part.collision)]
        for rel, mesh in items:
            path = out_dir / rel
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(obj_bytes(mesh, exact))
            written[rel] = path
    return written


def read_mesh(path: str | Path, *, source: str | Path | None = None, element: str | None = None,
              line: int | None = None, scale=None) -> Mesh:
    """Load a mesh file (any format trimesh reads) as one :class:`Mesh`, all pieces merged.

    ``source``/``element``/``line`` name the referencing file for the error message.
    """
    return read_mesh_file(path, source=source, element=element, line=line, scale=scale)[0]


def read_mesh_file(path: str | Path, *, source: str | Path | None = None,
                   element: str | None = None, line: int | None = None,
                   scale=None) -> tuple[Mesh, RGBA | None]:
    """:func:`read_mesh` and the file's own colour: for an OBJ the area-weighted diffuse
    colour (``Kd``) of its MTL materials, None when it names none (or other formats)."""
    path = Path(path)
    if not path.is_file():
        raise FormatError(source or path, element, f"mesh file not found: {path}", line)
    color = None
    if path.suffix.lower() == ".obj":
        mesh, color = _read_obj(path, source, element, line)
    elif path.suffix.lower() == ".dae":
        mesh = _read_collada(path, source, element, line)
    else:
        import trimesh

        try:
            loaded = trimesh.load(str(path), force="mesh", process=False, skip_materials=True)
        except Exception as e:  # trimesh raises many types for broken files
            raise FormatError(source or path, element,
                              f"cannot read mesh {path}: {type(e).__name__}: {e}", line) from e
        if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
            raise FormatError(source or path, element, f"mesh {path} has no triangles", line)
        mesh = Mesh.from_trimesh(loaded)
    if scale is not None:
        mesh = Mesh(mesh.vertices * np.asarray(scale, dtype=float), mesh.faces)
    return mesh, color


def _read_obj(path: Path, source, element, line) -> tuple[Mesh, RGBA | None]:
    """An OBJ's triangles (polygons fanned by tinyobjloader; only the vertices the faces use,
    in file order, as trimesh keeps them) and its MTL colour. A missing MTL or texture costs
    the colour only, as in trimesh and the viewers."""
    import tinyobjloader

    reader, config = tinyobjloader.ObjReader(), tinyobjloader.ObjReaderConfig()
    config.triangulate = True
    if not reader.ParseFromFile(str(path), config):
        raise FormatError(source or path, element,
                          f"cannot read mesh {path}: {reader.Error().strip()}", line)
    vertices = _exact_vertices(path, np.array(reader.GetAttrib().vertices, dtype=np.float64))
    # the list accessors: numpy_vertices()/numpy_indices() of 2.0.0rc13 return wrong values
    shapes = [s.mesh for s in reader.GetShapes()]
    faces = np.concatenate([np.zeros(0, np.int64)]
                           + [np.array(m.vertex_indices(), dtype=np.int64) for m in shapes])
    if len(faces) == 0 or len(faces) % 3:
        raise FormatError(source or path, element, f"mesh {path} has no triangles", line)
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise FormatError(source or path, element, f"mesh {path}: a face refers to vertex "
                          f"{int(faces.max()) + 1} of {len(vertices)}", line)
    used = np.zeros(len(vertices), dtype=bool)
    used[faces] = True
    renumber = np.cumsum(used) - 1  # a mask, not np.unique: no sort
    mesh = Mesh(vertices[used], renumber[faces].reshape(-1, 3))
    material = np.concatenate([np.zeros(0, np.int64)]
                              + [np.array(m.material_ids, dtype=np.int64) for m in shapes])
    return mesh, _area_weighted_color(mesh, material, reader.GetMaterials())


_VERTEX_LINE = re.compile(rb"^v[ \t]+(\S+)[ \t]+(\S+)[ \t]+(\S+)", re.MULTILINE)


def _exact_vertices(path: Path, parsed: np.ndarray) -> np.ndarray:
    """The OBJ's vertices as the nearest float64 to each number written: tinyobjloader's own
    number parser can be one unit in the last place off, which would break the lossless
    object.json round trip. Its values stand when the ``v`` lines do not read plainly."""
    try:
        exact = np.array(_VERTEX_LINE.findall(path.read_bytes()), dtype=np.float64)
    except ValueError:
        exact = np.zeros((0, 3))
    if exact.shape == (len(parsed) // 3, 3) and np.allclose(exact.ravel(), parsed, rtol=1e-6,
                                                               atol=1e-12):
        return exact
    return parsed.reshape(-1, 3)


def _area_weighted_color(mesh: Mesh, material: np.ndarray, materials) -> RGBA | None:
    """The faces' diffuse colours weighted by face area (alpha 1, as trimesh reads MTLs)."""
    known = (material >= 0) & (material < len(materials))
    if not known.any():
        return None
    diffuse = np.array([list(m.diffuse)[:3] for m in materials], dtype=np.float64)
    tri = mesh.vertices[mesh.faces[known]]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    if area.sum() <= 0:
        return None
    rgb = np.clip(area @ diffuse[material[known]] / area.sum(), 0.0, 1.0)
    return (*(float(v) for v in rgb), 1.0)


def _read_collada(path: Path, source, element, line) -> Mesh:
    try:
        import collada  # noqa: F401 - pycollada reads the file
    except ImportError as e:
        raise FormatError(source or path, element, f"cannot read Collada mesh {path}: "
                          "pycollada is not installed (pip install pycollada)", line) from e
    from .collada_mesh import read_collada

    try:
        vertices, faces, _ = read_collada(path)
    except ValueError as e:
        raise FormatError(source or path, element,
                          f"cannot read Collada (.dae) mesh {path}: {e}", line) from e
    return Mesh(vertices, faces)
