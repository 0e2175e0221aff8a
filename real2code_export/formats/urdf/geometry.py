"""<visual>/<collision> contents: origins, shapes (mesh files or primitives) and colours.

Mesh filenames are relative to the URDF (or, failing that, to the folder a MuJoCo
``<mujoco><compiler meshdir>`` extension names, as MuJoCo reads them, or to an asset root
above the URDF or on the search path, warned), ``file://`` paths, or
``package://name/rest`` /
``model://name/rest`` (resolved by searching the URDF's parent folders, then
``ROS_PACKAGE_PATH``, for one named ``name`` or holding a folder ``name``, else, as ROS finds
a package, the folder whose ``package.xml`` names it: there is no ROS package index here). Primitives are kept as the model's shapes (with their fixed
tessellation, :mod:`real2code_export.primitives`). A visual's colour is its URDF material, else the area-weighted diffuse
colour of the OBJ's own MTL materials (PartNet ships MTLs; read with the geometry), else
none.
"""

from __future__ import annotations

import re
from pathlib import Path
from urllib.parse import unquote

import numpy as np
from lxml import etree

from ... import transforms as tf
from ...meshfiles import read_ahead, read_mesh_file, texture_from_file
from ...model import Mesh, Texture
from ...primitives import SIZE_COUNT, Primitive, ShapeKind
from .context import Context, label
from .conventions import PREFIX, ns
from .packages import find_package, manifest_packages, package_search_path

RGBA = tuple[float, float, float, float]
# A URI of another scheme than package://, model:// or file:// (https://...)
_URL = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*://")


def origin_matrix(ctx: Context, el: etree._Element, owner: str) -> np.ndarray:
    """The 4x4 transform of ``el``'s <origin> child (identity when absent)."""
    o = el.find("origin")
    if o is None:
        return np.eye(4)
    xyz = ctx.floats(o, "xyz", owner, count=3, default=(0.0, 0.0, 0.0))
    rpy = ctx.floats(o, "rpy", owner, count=3, default=(0.0, 0.0, 0.0))
    return tf.make(tf.rpy_to_matrix(rpy), xyz)


def mesh_area(mesh: Mesh) -> float:
    tri = mesh.vertices[mesh.faces]
    return 0.5 * float(np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]),
                                      axis=1).sum())


SHAPE_TAGS = ("mesh", "box", "cylinder", "sphere", "capsule")


def shape_mesh(ctx: Context, el: etree._Element,
               owner: str) -> tuple[Mesh | None, Path | None]:
    """The mesh of a <visual>/<collision> element in ITS OWN frame (origin not applied),
    and the mesh file it came from (None for primitives); no mesh for a shape of zero size
    (warned: it has no surface)."""
    geometry = el.find("geometry")
    if geometry is None:
        raise ctx.error(owner, f"<{el.tag}> has no <geometry>", el.sourceline)
    children = [c for c in geometry if isinstance(c.tag, str)]
    if len(children) > 1 and children[0].tag in SHAPE_TAGS and not any(
            c.tag in SHAPE_TAGS for c in children[1:]):
        # urdfdom reads the first child of <geometry> as the shape and ignores the rest
        # (pybullet's racecar has its <material> there): so does this reader.
        ctx.warn(owner, f"<geometry> holds {', '.join(f'<{c.tag}>' for c in children[1:])} "
                 f"after its <{children[0].tag}>: ignored, as urdfdom ignores it",
                 children[1].sourceline)
        children = children[:1]
    if len(children) != 1:
        raise ctx.error(owner, f"<geometry> must hold exactly one shape, found "
                        f"{len(children)}", geometry.sourceline)
    shape = children[0]
    if shape.tag == "mesh":
        marked = _marked_shape(ctx, shape, owner)
        return (marked, None) if marked is not None else _file_mesh(ctx, shape, owner)
    return _primitive(ctx, shape, owner), None


def _positive(ctx: Context, el: etree._Element, attr: str, owner: str, count: int = 1):
    values = ctx.floats(el, attr, owner, count=count)
    if np.any(values <= 0):
        raise ctx.error(owner, f"<{el.tag}> {attr} must be > 0, got {el.get(attr)!r}",
                        el.sourceline)
    return values if count > 1 else float(values[0])


def _primitive(ctx: Context, shape: etree._Element, owner: str) -> Mesh | None:
    """A URDF shape (and ``<capsule>``, which MuJoCo's and other readers take) kept as the
    model's shape; URDF cylinders and capsules are centred, along z, as the model's are.
    None for a shape with a zero size and no negative one (urdfdom, Pinocchio and Bullet
    load it; it has no surface and no volume, so nothing is lost), warned."""
    sizes = {"box": ("size",), "sphere": ("radius",), "cylinder": ("radius", "length"),
             "capsule": ("radius", "length")}.get(shape.tag, ())
    values = [ctx.floats(shape, a, owner, count=3 if a == "size" else 1) for a in sizes]
    if values and all(np.all(v >= 0) for v in values) and any(np.any(v == 0) for v in values):
        ctx.warn(owner, f"<{shape.tag}> of zero size "
                 f"({', '.join(f'{a}={shape.get(a)!r}' for a in sizes)}) has no surface: "
                 "left out", shape.sourceline)
        return None
    if shape.tag == "box":
        primitive = Primitive(ShapeKind.BOX, _positive(ctx, shape, "size", owner, 3))
    elif shape.tag == "sphere":
        primitive = Primitive(ShapeKind.SPHERE, [_positive(ctx, shape, "radius", owner)])
    elif shape.tag in ("cylinder", "capsule"):
        primitive = Primitive(ShapeKind(shape.tag), [_positive(ctx, shape, "radius", owner),
                                                     _positive(ctx, shape, "length", owner)])
    else:
        raise ctx.error(owner, f"unknown geometry <{shape.tag}> (expected mesh, box, cylinder, "
                        "sphere)", shape.sourceline)
    return Mesh.of_primitive(primitive)


def _marked_shape(ctx: Context, shape: etree._Element, owner: str) -> Mesh | None:
    """A <mesh> our writer marked as a shape URDF has no element for (capsule, ellipsoid:
    ``real2code:shape`` and ``real2code:size``): the shape, not the file's triangles."""
    kind = shape.get(ns("shape"))
    if kind is None:
        return None
    if kind not in {k.value for k in ShapeKind}:
        raise ctx.error(owner, f"<mesh {PREFIX}:shape={kind!r}>: unknown shape",
                        shape.sourceline)
    size = _positive(ctx, shape, ns("size"), owner, SIZE_COUNT[ShapeKind(kind)])
    return Mesh.of_primitive(Primitive(kind, np.atleast_1d(size)))


def resolve_filename(ctx: Context, filename: str, owner: str, line: int | None, *,
                     quiet: bool = False) -> Path | None:
    """The file a mesh ``filename`` refers to (existence is checked by the reader).

    ``package://NAME/REST`` and ``model://NAME/REST``: the first folder named NAME holding
    REST, looked for in the URDF's own folder and its parents (a package inside a source or
    install tree), then in the search path (:func:`package_search_path`); failing that, the
    nearest of those parents holding REST itself (warned). ``quiet``: None where it would
    warn, note or refuse (a look ahead, :func:`read_meshes_ahead`)."""
    scheme = next((s for s in ("package://", "model://") if filename.startswith(s)), None)
    if scheme is not None:
        if filename in ctx.packaged:
            return ctx.packaged[filename]
        package, _, rest = filename[len(scheme):].partition("/")
        here = ctx.folder()
        search = package_search_path()
        for folder in (here, *here.parents, *search):
            if folder.name == package and (folder / rest).exists():
                ctx.packaged[filename] = folder / rest
                return folder / rest
            if (folder / package / rest).exists():
                ctx.packaged[filename] = folder / package / rest
                return folder / package / rest
        # ROS's own rule: the folder whose package.xml names the package
        if scheme == "package://" and package not in ctx.manifests:
            ctx.manifests[package] = list(manifest_packages(package, here))
        for folder in ctx.manifests.get(package, []):
            if (folder / rest).exists():
                ctx.packaged[filename] = folder / rest
                return folder / rest
        # No such package, but REST lies under a folder above the URDF (a package renamed
        # or copied without its name): the nearest one, as yourdfpy resolves it.
        found = next((f for f in (here, *here.parents) if (f / rest).is_file()), None)
        if quiet:
            return None
        if found is not None:
            ctx.warn(owner, f"{filename!r}: no package {package!r} found; {rest!r} taken from "
                     f"{found}, the nearest folder above the URDF holding it", line)
            return found / rest
        package_folder = find_package(package, here)
        if package_folder is not None:  # the package is there, the file is not
            raise ctx.error(owner, f"cannot resolve {filename!r}: package {package!r} is "
                            f"{package_folder}, which holds no {rest!r} (mesh file not found)",
                            line)
        raise ctx.error(owner, f"cannot resolve {filename!r}: no parent folder of the URDF is "
                        f"named {package!r} (or holds one, or has a package.xml naming it) "
                        f"with {rest!r} in it, nor any folder of the search path "
                        f"{[str(f) for f in search]} (ROS_PACKAGE_PATH, --package-path)", line)
    if filename.startswith("file://"):
        path = Path(unquote(filename[len("file://"):]))
        if path.is_absolute():
            return path
        # 'file://meshes/a.stl' is no file URI (its path would start with '/'; 'meshes'
        # would be a host): read relative to the URDF, as urdf-usd-converter reads it, where
        # the working folder decided before
        if not quiet:
            ctx.warn(owner, f"{filename!r}: a file:// URI with a relative path; read "
                     "relative to the URDF", line)
    elif _URL.match(filename):
        if quiet:
            return None
        raise ctx.error(owner, f"mesh filename {filename!r} is a URL: mesh files are read "
                        "from disk, not downloaded (download it and name the file)", line)
    else:
        path = Path(filename)
    if path.is_absolute():
        return path
    beside = ctx.path.parent / path
    if beside.exists():
        return beside
    if ctx.meshdir is not None:  # where MuJoCo looks for it
        inside = ctx.path.parent / ctx.meshdir / path
        if inside.exists():
            if quiet:
                return None
            ctx.note("meshdir", repr(filename))
            return inside
    # Asset collections name meshes from the folder their loader is given (an asset root
    # above the file: 'robot_description/meshes/link.obj' from the URDF in
    # robot_description/), not from the URDF: the nearest folder above it, or on the search
    # path, holding the path (never one climbing out with '..'), warned.
    if ".." not in path.parts:
        found = next((f for f in (*ctx.folder().parents, *package_search_path())
                      if (f / path).is_file()), None)
        if found is not None:
            if quiet:
                return None
            named = ctx.asset_roots.setdefault(found, [])
            if repr(filename) not in named:  # a visual and its collision name the same file
                named.append(repr(filename))
            return found / path
    return beside


def read_meshes_ahead(ctx: Context, links) -> None:
    """The STL files the ``links`` (their elements) name, parsed two at a time before the
    links are read (:func:`~real2code_export.meshfiles.read_ahead`), where their filenames
    resolve plainly; the rest are read, warned about or refused in turn, as before."""
    paths = []
    for link in links:
        for shape in link.iterfind("*/geometry/mesh"):
            filename = shape.get("filename")
            path = resolve_filename(ctx, filename, "", None, quiet=True) if filename else None
            if path is not None:
                paths.append(path)
    read_ahead(paths)


def _file_mesh(ctx: Context, shape: etree._Element, owner: str) -> tuple[Mesh, Path]:
    filename = shape.get("filename")
    if not filename:
        raise ctx.error(owner, "<mesh> has no filename", shape.sourceline)
    path = resolve_filename(ctx, filename, owner, shape.sourceline)
    scale = ctx.floats(shape, "scale", owner, count=(1, 3), default=(1.0, 1.0, 1.0))
    scale = np.broadcast_to(scale, (3,)).copy()
    if np.any(scale == 0):
        raise ctx.error(owner, f"<mesh> scale {shape.get('scale')!r} has a zero", shape.sourceline)
    key = (path, tuple(scale.tolist()))
    if key not in ctx.meshes:
        ctx.files[path] = read_mesh_file(path, source=ctx.path, element=owner,
                                         line=shape.sourceline,
                                         scale=None if np.all(scale == 1.0) else scale)
        mesh = ctx.files[path].mesh
        if np.prod(scale) < 0:  # a mirroring scale turns the faces inside out: turn them back
            mesh = Mesh(mesh.vertices, mesh.faces[:, ::-1], mesh.uv)
        ctx.meshes[key] = mesh
    return ctx.meshes[key], path


# -- colours -----------------------------------------------------------------------------------
def rgba(ctx: Context, color_el: etree._Element, owner: str) -> RGBA:
    values = ctx.floats(color_el, "rgba", owner, count=4)
    if np.any((values < 0) | (values > 1)):
        ctx.warn(owner, f"<color> rgba {color_el.get('rgba')!r} is outside [0, 1]; clipped",
                 color_el.sourceline)
        values = np.clip(values, 0.0, 1.0)
    return tuple(float(v) for v in values)


def robot_materials(ctx: Context, robot: etree._Element) -> dict[str, RGBA | None]:
    """Materials defined at robot level, by name (None: defined without a colour)."""
    out: dict[str, RGBA | None] = {}
    for m in robot.iterchildren("material"):
        color = m.find("color")
        out[m.get("name", "")] = None if color is None else rgba(ctx, color, label(m))
    return out


def material_image(ctx: Context, visual: etree._Element, robot: etree._Element, owner: str,
                   mesh: Mesh) -> Texture | None:
    """The image a visual's <material> names (``<texture filename>``, inline or in the
    robot's material of that name), placed by the mesh's texture coordinates as rviz places
    it; None where it names none, or (warned) where the mesh has no coordinates to place it
    or the file is not there: the colour is kept, as viewers draw it."""
    m = visual.find("material")
    if m is None:
        return None
    texture = m.find("texture")
    if texture is None and m.get("name"):
        named = next((r for r in robot.iterchildren("material")
                      if r.get("name") == m.get("name")), None)
        texture = None if named is None else named.find("texture")
    filename = None if texture is None else texture.get("filename")
    if not filename:  # (an empty <texture/> holds nothing)
        return None
    if mesh.uv is None:
        ctx.warn(owner, f"<texture filename='{filename}'> not read: the visual's mesh has no "
                 "texture coordinates to place it (a shape, or a file without them); the "
                 "material's colour is kept", texture.sourceline)
        return None
    path = resolve_filename(ctx, filename, owner, texture.sourceline, quiet=True)
    if path is None or not path.is_file():
        ctx.warn(owner, f"<texture filename='{filename}'>: image not found; the material's "
                 "colour is kept", texture.sourceline)
        return None
    return texture_from_file(path)


def material_color(ctx: Context, visual: etree._Element, materials: dict[str, RGBA | None],
                   owner: str) -> RGBA | None:
    """The colour a visual's <material> gives (inline, or by name), or None."""
    m = visual.find("material")
    if m is None:
        return None
    name = m.get("name")
    color = m.find("color")
    if color is not None:
        value = rgba(ctx, color, owner)
        if name:  # urdfdom lets later visuals refer to a material defined inline
            materials.setdefault(name, value)
        return value
    if name and name not in materials:
        ctx.warn(owner, f"<material name='{name}'> is not defined; the colour comes from the "
                 "mesh file or the default", m.sourceline)
    return materials.get(name) if name else None


def file_colors(ctx: Context, path: Path, n_faces: int) -> list[tuple[int, RGBA | None]]:
    """A mesh file's own colours (an OBJ's MTL ``Kd``, a Collada material's diffuse) as
    runs over its ``n_faces`` triangles, the colour None where it has none, as read with the
    file's geometry (:func:`_file_mesh`: each file is read once)."""
    read = ctx.files[path]
    return list(read.runs) or [(n_faces, read.color)]


def average_color(colored: list[tuple[RGBA, Mesh]]) -> RGBA | None:
    """Area-weighted average of (colour, mesh) pairs, each weighed by its mesh's area;
    exactly the colour when all agree (then no area is computed: a robot's visuals mostly
    agree, and summing their triangles' areas was a twentieth of its USD export)."""
    if not colored:
        return None
    first = colored[0][0]
    if all(c == first for c, _ in colored):
        return first
    weights = np.array([max(mesh_area(m), 0.0) for _, m in colored])
    colors = np.array([c for c, _ in colored])
    if weights.sum() <= 0:
        weights = np.ones(len(colored))
    mean = np.clip((weights @ colors) / weights.sum(), 0.0, 1.0)  # round-off can pass 1
    return tuple(float(v) for v in mean)
