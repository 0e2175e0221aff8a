"""Geoms of a compiled MuJoCo model as triangle meshes in their body's frame.

Mesh geoms are read from their files (float64, faces as written) where trimesh reads the
format, else taken from the compiled model (float32); OBJ and STL files are read once, before
MuJoCo compiles, and MuJoCo is given their vertices (:func:`give_meshes`). Primitives are kept as
the model's shapes (box, sphere, ellipsoid, capsule, cylinder), with their fixed
tessellation. MuJoCo moves a mesh to its own inertial frame when it compiles and folds that
move into the geom pose; it is undone here, so a file mesh keeps its own coordinates.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ... import transforms as tf
from ...errors import FormatError, NoTrianglesError, warn
from ...meshfiles import MESH_SUFFIXES, STL_HEADER, binary_stl_triangles, read_ahead, read_mesh
from ...model import Mesh, corner_bounds
from ...primitives import Primitive, ShapeKind

# Mesh files (meshfiles.MESH_SUFFIXES) are read here as MuJoCo does; others (e.g. MuJoCo's
# own .msh) come from the model.
# Read here and given to MuJoCo as vertices and faces (MjSpec's uservert, userface), so each
# file is read once: MuJoCo parsing an OBJ's text costs more than compiling the same numbers
# given (the 25 Menagerie models' compile, kuka_iiwa_14 0.12 -> 0.04 s of CPU; every body's
# mass, inertia and frame and every geom's pose and size compile bit-identical). An STL is
# given welded, its equal corners one vertex in the order MuJoCo's own reading keeps them
# (meshfiles._welded), so the compiled meshes are MuJoCo's bit for bit; read by MuJoCo too,
# it was read twice (docs/benchmarks.md, session 19). Only an STL MuJoCo reads itself is
# given (:func:`_mujoco_reads_stl`): a file it refuses stays refused, with its message.
_GIVEN_FORMATS = (".obj", ".stl")
_EYE4 = np.eye(4)
_EYE4.flags.writeable = False
_MUJOCO_STL_FACES = 200_000  # MuJoCo's STL decoder refuses more faces (and ASCII files)


def _mujoco_reads_stl(path: Path) -> bool:
    """Whether MuJoCo reads the STL ``path`` itself: binary, with 1 to
    :data:`_MUJOCO_STL_FACES` triangles."""
    with path.open("rb") as f:
        count = binary_stl_triangles(f.read(STL_HEADER), path.stat().st_size)
    return count is not None and 1 <= count <= _MUJOCO_STL_FACES


def give_meshes(spec, files: dict) -> list[tuple[object, Mesh, list]]:
    """Read the OBJ and STL files of ``spec``'s meshes (``files``: spec mesh -> resolved path)
    and put their vertices and faces into the spec in place of the file, before it is
    compiled: the spec mesh, the mesh as the file has it (unscaled: MuJoCo applies the mesh's
    ``scale``), and the warnings reading it gave (said when a geom uses the mesh, as before).
    A file this reader refuses, a mesh of fewer than 4 vertices, or an STL MuJoCo would
    refuse, is left to MuJoCo, which then reads it or names it."""
    import warnings

    from ...errors import Real2CodeError

    given = []
    readable = {spec_mesh: path for spec_mesh, path in files.items()
                if path.suffix.lower() in _GIVEN_FORMATS and path.is_file()
                and (path.suffix.lower() != ".stl" or _mujoco_reads_stl(path))}
    keys = read_ahead(readable.values())  # (its STL files, two at a time)
    for spec_mesh, path in readable.items():
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always")
            try:
                mesh = read_mesh(path, key=keys.get(path))
            except Real2CodeError:
                continue
        if len(mesh.vertices) < 4:  # MuJoCo counts the file's unused vertices too
            continue  # (meshfiles.obj_bytes pads a one-triangle mesh so): left to it
        # (MuJoCo's binding converts them element by element from any sequence: from a
        # memoryview of the float32 and int32 it keeps, in half the time of a list of
        # Python's numbers and a third of an array's; the same float32 either way)
        spec_mesh.uservert = memoryview(mesh.vertices.astype(np.float32).reshape(-1))
        spec_mesh.userface = memoryview(mesh.faces.astype(np.int32).reshape(-1))
        spec_mesh.file = ""
        given.append((spec_mesh, mesh, said))
    return given


def pose(pos, quat) -> np.ndarray:
    return tf.make(tf.quat_to_matrix(quat), pos)


def geom_pose(model, g: int) -> np.ndarray:
    """Pose of geom ``g`` in its body, for the geometry :func:`geom_mesh` returns."""
    return pose(model.geom_pos[g], model.geom_quat[g])


def geom_mesh(model, g: int, source: Path, element: str,
              mesh_cache: dict[int, tuple[Mesh, np.ndarray]],
              given: dict[int, tuple[Mesh, list]] | None = None) -> Mesh | None:
    """Geom ``g`` as a mesh in its body's frame; None for what has no finite surface
    (planes, height fields, SDFs), which the caller reports. ``given``: mesh id -> the mesh
    read before compiling and its warnings (:func:`give_meshes`)."""
    import mujoco

    kind = int(model.geom_type[g])
    size = np.asarray(model.geom_size[g], dtype=np.float64)
    placed = geom_pose(model, g)
    G = mujoco.mjtGeom
    if kind == G.mjGEOM_MESH:
        mesh_id = int(model.geom_dataid[g])
        if mesh_id not in mesh_cache:
            mesh_cache[mesh_id] = _mesh_asset(model, mesh_id, source, element,
                                              (given or {}).get(mesh_id))
        mesh, mesh_frame = mesh_cache[mesh_id]
        if mesh.uv is None:
            uv = projected_uv(model, g, mesh.vertices @ mesh_frame[:3, :3].T + mesh_frame[:3, 3])
            if uv is not None:
                mesh = Mesh(mesh.vertices, mesh.faces, uv)
        transform = placed @ mesh_frame
        # (each geom says which asset it places: a writer that can place one mesh several
        # times writes the asset once, Mesh.placements)
        if tf.allclose_to_finite(transform, _EYE4, rtol=0.0, atol=1e-12):
            return Mesh.placed(mesh)  # the usual case (our own files): the numbers exactly
        return Mesh.placed(mesh, transform)
    shape = geom_primitive(kind, size, placed)
    return None if shape is None else Mesh.of_primitive(shape)


def projected_uv(model, g: int, vertices: np.ndarray) -> np.ndarray | None:
    """The texture coordinates MuJoCo draws a 2D colour image with on mesh geom ``g``, a mesh
    without its own (``vertices``: in the compiled mesh frame); None where its material has
    no 2D colour image. MuJoCo's renderer (``settexture`` in render_gl3.c) generates them
    from each vertex's position, OpenGL's object-linear mapping: the image projected along
    the z of the compiled mesh frame (centred at the mesh's centre of mass, on its principal
    axes), ``s = x r_x / (2 size_x) - 1/2`` and ``t = -y r_y / (2 size_y) - 1/2``
    with the material's ``texrepeat`` r and the geom's size (the largest |x|, |y| of the
    mesh; with ``texuniform``, 1: r copies per metre), the image repeated, t down the image.
    Returned as the model's (v up the image), moved by whole copies (which change nothing a
    repeating image draws) to start in the first."""
    import mujoco

    mat = int(model.geom_matid[g])
    if mat < 0:
        return None
    tex = int(model.mat_texid[mat, mujoco.mjtTextureRole.mjTEXROLE_RGB])
    if tex < 0 or int(model.tex_type[tex]) != mujoco.mjtTexture.mjTEXTURE_2D:
        return None
    repeat = np.asarray(model.mat_texrepeat[mat], dtype=np.float64)
    size = np.asarray(model.geom_size[g][:2], dtype=np.float32).astype(np.float64)
    scale = repeat.copy()
    if not model.mat_texuniform[mat]:  # (texuniform multiplies the size back in)
        scale = np.where(size > 0, repeat / np.maximum(size, mujoco.mjMINVAL), repeat)
    s = 0.5 * scale[0] * vertices[:, 0] - 0.5
    t = -0.5 * scale[1] * vertices[:, 1] - 0.5
    uv = np.column_stack([s, 1.0 - t])
    return uv - np.floor(uv.min(axis=0))


def geom_primitive(kind: int, size: np.ndarray, placed: np.ndarray) -> Primitive | None:
    """A primitive geom (MuJoCo's sizes: half extents, half lengths) as the model's shape."""
    import mujoco

    G = mujoco.mjtGeom
    if kind == G.mjGEOM_BOX:
        return Primitive(ShapeKind.BOX, 2.0 * size, placed)
    if kind == G.mjGEOM_SPHERE:
        return Primitive(ShapeKind.SPHERE, size[:1], placed)
    if kind == G.mjGEOM_ELLIPSOID:
        return Primitive(ShapeKind.ELLIPSOID, size, placed)
    if kind == G.mjGEOM_CAPSULE:  # radius, half-length of the cylinder part
        return Primitive(ShapeKind.CAPSULE, [size[0], 2.0 * size[1]], placed)
    if kind == G.mjGEOM_CYLINDER:  # radius, half-height
        return Primitive(ShapeKind.CYLINDER, [size[0], 2.0 * size[1]], placed)
    return None


def mjcf_geom(shape: Primitive) -> tuple[int, list[float]]:
    """The MuJoCo geom type and size of a model shape (the inverse of :func:`geom_primitive`)."""
    import mujoco

    G = mujoco.mjtGeom
    s = np.concatenate([shape.size, [0.0, 0.0]])  # MuJoCo's size has 3 slots
    kind = shape.kind
    if kind is ShapeKind.BOX:
        return G.mjGEOM_BOX, list(0.5 * s[:3])
    if kind is ShapeKind.SPHERE:
        return G.mjGEOM_SPHERE, [s[0], 0.0, 0.0]
    if kind is ShapeKind.ELLIPSOID:
        return G.mjGEOM_ELLIPSOID, list(s[:3])
    return (G.mjGEOM_CAPSULE if kind is ShapeKind.CAPSULE else G.mjGEOM_CYLINDER,
            [s[0], 0.5 * s[1], 0.0])


def _mesh_asset(model, mesh_id: int, source: Path, element: str,
                given: tuple[Mesh, list] | None) -> tuple[Mesh, np.ndarray]:
    """The mesh in its own file coordinates (scaled), and the transform from those to the
    compiled geom frame (the inverse of MuJoCo's centring)."""
    start, count = int(model.mesh_vertadr[mesh_id]), int(model.mesh_vertnum[mesh_id])
    fstart, fcount = int(model.mesh_faceadr[mesh_id]), int(model.mesh_facenum[mesh_id])
    compiled = np.asarray(model.mesh_vert[start:start + count], dtype=np.float64)
    mesh = _file_mesh(model, mesh_id, source, element, given)
    if mesh is not None:
        centring = pose(model.mesh_pos[mesh_id], model.mesh_quat[mesh_id])
        # Same place as MuJoCo's vertices (float32)? Else (legacy refpos/refquat, a reader
        # that saw another file) MuJoCo's own vertices are the truth.
        # (the file's vertices moved as Mesh.transformed moves them, without the mesh)
        to_geom = np.asarray(tf.inverse(centring), dtype=np.float64)
        moved = np.stack(corner_bounds(mesh.vertices @ to_geom[:3, :3].T + to_geom[:3, 3]))
        scale = max(float(np.abs(compiled).max(initial=0.0)), 1e-3)
        if len(compiled) and np.allclose(moved, np.stack(corner_bounds(compiled)), rtol=0.0,
                                         atol=1e-5 * scale):
            return mesh, tf.inverse(centring)
    faces = np.asarray(model.mesh_face[fstart:fstart + fcount], dtype=np.int64)
    if len(faces) == 0:
        raise FormatError(source, element, "mesh has no triangles")
    return Mesh(compiled, faces), np.eye(4)


def _file_mesh(model, mesh_id: int, source: Path, element: str,
               given: tuple[Mesh, list] | None) -> Mesh | None:
    """The mesh as its file has it (float64), scaled as MuJoCo scales it; None when the file
    is in a format read from the compiled model only."""
    import warnings

    scale = np.asarray(model.mesh_scale[mesh_id], dtype=np.float64)
    if given is not None:
        mesh, said = given
        for w in said:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        return Mesh(mesh.vertices * scale, mesh.faces, mesh.uv)
    path = _mesh_path(model, mesh_id)
    if path is not None and path.suffix.lower() in MESH_SUFFIXES:
        try:
            return read_mesh(path, source=source, element=element, scale=scale)
        except NoTrianglesError:
            if not model.mesh_facenum[mesh_id]:
                raise
            # vertices only: MuJoCo meshes them as their convex hull
            warn(f"{source}: {element}: mesh {path} has vertices but no triangles: their "
                 f"convex hull taken as MuJoCo takes it ({int(model.mesh_facenum[mesh_id])} "
                 "triangles)")
    return None


def _mesh_path(model, mesh_id: int) -> Path | None:
    adr = int(model.mesh_pathadr[mesh_id])
    if adr < 0:
        return None
    raw = bytes(model.paths[adr:]).split(b"\0", 1)[0].decode("utf-8", errors="replace")
    return Path(raw) if raw else None
