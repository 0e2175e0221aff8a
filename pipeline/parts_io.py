"""Segmented part meshes in: a folder with one mesh file per rigid part, or a .glb/.gltf with
one mesh node per part, all in one world frame (the input of ``real2code articulate``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from real2code_export.errors import FormatError, warn
from real2code_export.formats import FORMATS, is_format
from real2code_export.meshfiles import MESH_SUFFIXES, read_mesh
from real2code_export.model import Mesh

# glTF is Y up; the model is Z up: x stays, glTF y becomes z, glTF z becomes -y.
Y_UP_TO_Z_UP = np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])


def _srgb_to_linear(c: np.ndarray) -> np.ndarray:
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _color(tm) -> tuple[float, float, float, float] | None:
    """The mesh's main colour as linear RGBA, where its file has one."""
    try:
        rgba = np.asarray(tm.visual.main_color, dtype=float) / 255.0
    except Exception:  # no visual information trimesh can summarise
        return None
    if rgba.shape != (4,) or np.allclose(rgba[:3], 102 / 255):  # trimesh's default grey
        return None
    return (*_srgb_to_linear(rgba[:3]).tolist(), float(rgba[3]))


def load_parts(path: str | Path) -> tuple[dict[str, Mesh], dict[str, tuple]]:
    """Part meshes (world frame, Z up) and their colours, by part name."""
    import trimesh

    path = Path(path)
    if not path.exists():
        raise FormatError(path, None, "no such file or folder")
    meshes: dict[str, Mesh] = {}
    colors: dict[str, tuple] = {}
    if path.is_dir():
        files = sorted(p for p in path.iterdir() if p.suffix.lower() in MESH_SUFFIXES)
        if not files:
            raise FormatError(path, None, f"no part meshes ({', '.join(MESH_SUFFIXES)}) in folder")
        for f in files:
            meshes[f.stem] = read_mesh(f)
            try:
                tm = trimesh.load(str(f), force="mesh", process=False)
                if (c := _color(tm)) is not None:
                    colors[f.stem] = c
            except Exception:  # colour is optional; the geometry was read above
                pass
    elif is_format(path, "gltf"):
        try:
            scene = trimesh.load(str(path), force="scene", process=False)
        except Exception as e:
            raise FormatError(path, None, f"cannot read glTF: {e}") from e
        skipped = []
        for node in sorted(scene.graph.nodes_geometry):
            transform, geometry = scene.graph[node]
            tm = scene.geometry[geometry]
            if not isinstance(tm, trimesh.Trimesh) or len(tm.faces) == 0:
                skipped.append(node)
                continue
            mesh = Mesh.from_trimesh(tm).transformed(Y_UP_TO_Z_UP @ transform)
            meshes[node] = mesh
            if (c := _color(tm)) is not None:
                colors[node] = c
        if skipped:  # a scan's points or a rig's lines beside the parts: said, not parts
            warn(f"{path}: node(s) {', '.join(skipped)} hold no triangles (points, lines or "
                 "an empty mesh): not read as parts")
        if not meshes:
            raise FormatError(path, None, "no mesh nodes in glTF")
    else:
        raise FormatError(path, None, "expected a folder of part meshes or a "
                          f"{'/'.join(FORMATS['gltf'].suffixes)} file")
    if len(meshes) < 2:
        raise FormatError(path, None, f"found {len(meshes)} part mesh(es); need at least two "
                          "(one per rigid part)")
    return meshes, colors
