"""Mesh files shared by every exporter: one OBJ per visual mesh and per collision piece.

Every format references the same files (``meshes/<part>.obj``,
``meshes/<part>_collision_<k>.obj``), written once per export, deterministically, so the
same model gives byte-identical files. Reading goes through trimesh (STL, OBJ, glTF, PLY,
...), Collada through ``collada_mesh`` (pycollada: scene-graph transforms and unit applied).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import FormatError
from .model import ArticulatedObject, Mesh

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
    import trimesh

    path = Path(path)
    if not path.is_file():
        raise FormatError(source or path, element, f"mesh file not found: {path}", line)
    if path.suffix.lower() == ".dae":
        mesh = _read_collada(path, source, element, line)
    else:
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
    return mesh


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
