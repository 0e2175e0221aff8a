"""Meshes and materials: a part's visual mesh (UsdGeom.Mesh bound to a UsdPreviewSurface
with the part's linear colour, its normals split along creases) and its convex collision pieces (UsdGeom.Mesh with
PhysicsCollisionAPI + PhysicsMeshCollisionAPI, approximation convexHull, purpose guide so
renderers skip them). Geometry is in the part frame. A visual of several colours binds a
material per colour: to GeomSubsets of the mesh's triangles (family materialBind) and to
its shapes; the reader takes colours from materials bound to the visual prims and their
subsets, else from a constant displayColor.
Shapes (box, sphere, ellipsoid, cylinder, capsule) are UsdGeom Cube / Sphere / Cylinder /
Capsule prims, placed by double-precision xformOps (a box is a unit cube scaled, an ellipsoid
a unit sphere scaled); as colliders they have the CollisionAPI alone (analytic shapes), except
the ellipsoid: UsdPhysics has none and refuses a sphere scaled unevenly as a collider (PhysX
cannot scale one; UsdValidation's ColliderNonUniformScale), so a colliding ellipsoid is its
tessellation as a convex mesh, with its radii in our namespace for the reader.

Mesh prims are named after their part (``<part>/<part>``, ``<part>/<part>_collision_<k>``),
never a generic ``visual``: importers that fold a single-mesh Xform into one object (Blender's
does) name it after the mesh prim, and should show the part's name. The reader tells visual
from collision by the PhysicsCollisionAPI, not by name.

The mesh arrays (points, triangles, texture coordinates) are written to a binary layer of
their own, ``meshes/<object>.usdc``, which the .usda sublayers (:func:`move_mesh_arrays`): the
.usda keeps everything else as text (every prim, schema, joint, mass, material, extent),
the arrays are in the binary (crate) format USD reads lazily and writes in a tenth of the
time, as the converters lay out their assets (a Geometry layer in .usdc beside the text).

A mesh's data is in the file once: a collider or visual mesh equal to a visual mesh written
before it (a collision that is the visual, as most robots' files give it; a left and a right
finger) is an internal reference to that prim (``_define_mesh_once``). A mesh asset the model
says is placed more than once (``Mesh.placements``: an MJCF mesh used by several geoms, in one
part or in several) is written once, under the class ``MeshAssets`` (never drawn or simulated
itself), and each placement is a prim referring to it with its own pose (:class:`MeshAssets`):
a part's visual is then a prim per placement (``<part>`` for one, ``<part>_mesh_<k>`` for
several), each of one colour, which the reader joins back into the part's mesh.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ... import transforms as tf
from ...errors import FormatError, warn
from ...model import (
    DEFAULT_COLOR,
    ArticulatedObject,
    Mesh,
    Part,
    Placement,
    Texture,
    corner_bounds,
)
from ...normals import CreasedNormals, creased_normals
from ...placements import placed_pieces, shared_assets, whole_placement
from ...primitives import Primitive, ShapeKind
from .conventions import MESH_ASSETS, NAMESPACE
from .layer import apply, attribute, connect, define, extent, place, relationship

ST = "st"  # the texture-coordinate primvar's name, as UsdPreviewSurface's examples use


def visual_name(part: Part) -> str:
    return part.name


def collision_name(part: Part, k: int) -> str:
    return f"{part.name}_collision_{k}"


def _define_mesh(layer, path: str, mesh: Mesh, *schemas: str):
    from pxr import Vt

    prim = define(layer, path, "Mesh", *schemas)
    vertices = np.ascontiguousarray(mesh.vertices, dtype=np.float32)
    attribute(prim, "points", "Point3fArray", Vt.Vec3fArray.FromNumpy(vertices))
    attribute(prim, "faceVertexCounts", "IntArray",
              Vt.IntArray.FromNumpy(np.full(len(mesh.faces), 3, np.int32)))
    attribute(prim, "faceVertexIndices", "IntArray",
              Vt.IntArray.FromNumpy(np.ascontiguousarray(mesh.faces.reshape(-1), dtype=np.int32)))
    attribute(prim, "extent", "Float3Array", extent(*corner_bounds(vertices)))
    # flat triangles, not Catmull-Clark
    attribute(prim, "subdivisionScheme", "Token", "none", uniform=True)
    return prim


# what UsdGeom.Mesh holds per vertex or face, the bulk of a file: the binary layer's
MESH_ARRAYS = ("points", "faceVertexCounts", "faceVertexIndices", f"primvars:{ST}",
               "primvars:normals", "primvars:normals:indices",
               "indices")  # (a GeomSubset's faces)


def move_mesh_arrays(layer):
    """A new anonymous binary (.usdc) layer holding every mesh's :data:`MESH_ARRAYS`, moved
    out of ``layer`` to the same prim paths: ``layer`` sublayered over it composes the meshes
    it had, and an internal reference to a mesh prim brings its arrays as before (it reads
    the whole layer stack). Every prim of ``layer`` is an ``over`` in the new one, in the
    same order: USD orders a prim's children from the weakest layer up, so an over missing
    there would move its prim behind its siblings. None when ``layer`` has no mesh."""
    from pxr import Sdf

    data = Sdf.Layer.CreateAnonymous("meshes.usdc")
    moved = 0
    with Sdf.ChangeBlock():
        todo = [(child, data.pseudoRoot) for child in reversed(layer.rootPrims)]
        while todo:
            spec, parent = todo.pop()
            over = Sdf.PrimSpec(parent, spec.name, Sdf.SpecifierOver)
            for name in MESH_ARRAYS:
                if name in spec.attributes:
                    path = spec.path.AppendProperty(name)
                    Sdf.CopySpec(layer, path, data, path)
                    spec.RemoveProperty(spec.attributes[name])
                    moved += 1
            todo.extend((child, over) for child in reversed(spec.nameChildren))
    return data if moved else None


ELLIPSOID_RADII = f"{NAMESPACE}:ellipsoid:radii"


def _define_ellipsoid_collider(layer, path: str, shape: Primitive):
    """A colliding ellipsoid as a convex mesh: its tessellation in its own frame, placed
    rigidly at the shape's pose, the radii in ``real2code:ellipsoid:radii``."""
    from pxr import Gf

    own = Mesh(*Primitive(shape.kind, shape.size).tessellation())
    prim = _define_mesh(layer, path, own, "PhysicsCollisionAPI", "PhysicsMeshCollisionAPI")
    attribute(prim, "physics:approximation", "Token", "convexHull", uniform=True)
    attribute(prim, ELLIPSOID_RADII, "Double3", Gf.Vec3d(*(float(r) for r in shape.size)),
              uniform=True, custom=True)
    place(prim, shape.pose)
    return prim


def ellipsoid_collider(prim, to_part: np.ndarray) -> Mesh | None:
    """The ellipsoid :func:`_define_ellipsoid_collider` wrote, in the part frame (``to_part``:
    the prim's frame -> part), or None where the prim is no such mesh or is placed with a
    scale (then it is read as the mesh it is)."""
    radii = prim.GetAttribute(ELLIPSOID_RADII)
    if not radii or radii.Get() is None:
        return None
    matrix = np.asarray(to_part, dtype=np.float64)
    if not tf.is_rotation(matrix[:3, :3]):
        return None
    return Mesh.of_primitive(Primitive(ShapeKind.ELLIPSOID, list(radii.Get()), matrix))


class MeshAssets:
    """The mesh assets whose data an object would otherwise hold more than once
    (:func:`real2code_export.placements.shared_assets`), each written once as ``mesh_<k>``
    under the class ``/<object>/MeshAssets`` when first placed, with creased normals (and
    texture coordinates) once a visual places it. Every other mesh is written where it is
    placed, as before (``_define_mesh_once`` writes equal meshes once)."""

    def __init__(self, layer, object_path: str, obj: ArticulatedObject,
                 normals: LateNormals | None = None) -> None:
        self.shared = shared_assets(obj)  # id(asset) -> asset
        self.layer, self.scope = layer, f"{object_path}/{MESH_ASSETS}"
        self.normals = normals
        self.written: dict[int, str] = {}  # id(asset) -> its prim
        self.shaded: set[int] = set()  # those with normals (placed by a visual)

    def shares(self, asset: Mesh) -> bool:
        return id(asset) in self.shared

    def path(self, asset: Mesh, *, visual: bool) -> str:
        """The asset's prim, written the first time it is asked for."""
        from pxr import Sdf

        key = id(asset)
        if key not in self.written:
            if not self.written:  # the class holding them, after the object's scopes
                parent = self.layer.GetPrimAtPath(Sdf.Path(self.scope).GetParentPath())
                Sdf.PrimSpec(parent, MESH_ASSETS, Sdf.SpecifierClass, "Scope")
            self.written[key] = f"{self.scope}/mesh_{len(self.written)}"
            _define_mesh(self.layer, self.written[key], asset)
        if visual and key not in self.shaded:
            self.shaded.add(key)
            prim = self.layer.GetPrimAtPath(self.written[key])
            _creased_normals(prim, asset, self.normals)
            if asset.uv is not None:
                _texture_coordinates(prim, asset.uv)
        return self.written[key]


def _place_asset(layer, path: str, placement: Placement, assets: MeshAssets, *schemas: str,
                 visual: bool):
    """A mesh prim at ``placement``'s pose holding its asset: a reference to the asset's one
    prim where it is placed more than once, else the asset's own data here."""
    from pxr import Sdf

    asset = placement.asset
    if assets.shares(asset):
        prim = define(layer, path, "Mesh", *schemas)
        prim.referenceList.prependedItems.append(
            Sdf.Reference(primPath=assets.path(asset, visual=visual)))
    else:
        prim = _define_mesh(layer, path, asset, *schemas)
        if visual:
            _creased_normals(prim, asset, assets.normals)
            if asset.uv is not None:
                _texture_coordinates(prim, asset.uv)
    place(prim, placement.pose)
    return prim


def write_part_geometry(layer, part: Part, body_path: str, material_path: str,
                        visuals_written: dict[str, Mesh] | None = None,
                        assets: MeshAssets | None = None) -> None:
    """Visual mesh, collision pieces and the part's material (bound on the part prim, so the
    colour is kept even for a part without a visual mesh). ``visuals_written`` (prim path ->
    mesh: the visual meshes of the layer so far, this part's added): a mesh whose data one
    of them already holds refers to it (:func:`_define_mesh_once`). ``assets``: the object's
    mesh assets placed more than once, placed by reference (:class:`MeshAssets`)."""
    from pxr import Gf

    visuals_written = {} if visuals_written is None else visuals_written
    _material(layer, material_path, part.color, part)
    body = layer.GetPrimAtPath(body_path)
    bind(body, material_path)
    # a visual of several colours: a material per other colour, bound to the shapes and to
    # GeomSubsets of the mesh's faces (UsdShade's material per face set)
    colours: dict[tuple, str] = {tuple(part.color): material_path}
    runs = part.visual.colors if part.visual is not None else ()
    for rgba in dict.fromkeys(rgba for _, rgba in runs):
        if rgba not in colours:
            colours[rgba] = f"{material_path}_colour_{len(colours)}"
            _material(layer, colours[rgba], rgba, None)

    visuals = []  # (prim, its colour: None for the part's)
    own = part.visual.remainder() if part.visual is not None else None
    pieces = placed_pieces(own, part, assets.shared) if own is not None and assets \
        else None
    for k, (placement, rgba) in enumerate(pieces or ()):  # an asset's prim per placement
        name = visual_name(part) if len(pieces) == 1 else f"{part.name}_mesh_{k}"
        prim = _place_asset(layer, f"{body_path}/{name}", placement, assets, visual=True)
        visuals.append((prim, rgba))
        if rgba is not None and colours[rgba] != material_path:
            bind(prim, colours[rgba])
    if own is not None and pieces is None:
        prim = _define_mesh_once(layer, f"{body_path}/{visual_name(part)}", own,
                                 visuals_written, visual=True,
                                 normals=assets.normals if assets else None)
        if own.colors:  # (its displayColor, for importers that read no material: the part's)
            _face_subsets(layer, prim, own, colours)
        visuals.append((prim, None))
    shapes = part.visual.primitives if part.visual is not None else ()
    for k, (shape, rgba) in enumerate(zip(shapes, part.visual.shape_colors() if shapes
                                          else (), strict=True)):
        prim = define_shape(layer, f"{body_path}/{part.name}_visual_{k}", shape)
        visuals.append((prim, rgba))
        if rgba is not None and colours[rgba] != material_path:
            bind(prim, colours[rgba])
    for visual, rgba in visuals:  # displayColor too, for viewers and importers (MuJoCo's)
        r, g, b, a = (float(c) for c in (part.color if rgba is None else rgba))
        attribute(visual, "primvars:displayColor", "Color3fArray", [Gf.Vec3f(r, g, b)])
        attribute(visual, "primvars:displayOpacity", "FloatArray", [a])  # read no materials
    for k, piece in enumerate(part.collision):
        where = f"{body_path}/{collision_name(part, k)}"
        if piece.primitive is not None and piece.primitive.kind is ShapeKind.ELLIPSOID:
            geom = _define_ellipsoid_collider(layer, where, piece.primitive)
        elif piece.primitive is not None:  # an analytic collider
            geom = define_shape(layer, where, piece.primitive, "PhysicsCollisionAPI")
        elif assets and (placement := whole_placement(piece, assets.shared)) is not None:
            geom = _place_asset(layer, where, placement, assets, "PhysicsCollisionAPI",
                                "PhysicsMeshCollisionAPI", visual=False)
            attribute(geom, "physics:approximation", "Token", "convexHull", uniform=True)
        else:
            geom = _define_mesh_once(layer, where, piece, visuals_written, visual=False)
            attribute(geom, "physics:approximation", "Token", "convexHull", uniform=True)
        attribute(geom, "purpose", "Token", "guide", uniform=True)


def _material(layer, material_path: str, rgba, part: Part | None) -> None:
    """A UsdPreviewSurface material of colour ``rgba`` (``part``: with its images)."""
    from pxr import Gf

    r, g, b, a = (float(c) for c in rgba)
    material = define(layer, material_path, "Material")
    surface = f"{material_path}/PreviewSurface"
    shader = define(layer, surface, "Shader")
    attribute(shader, "info:id", "Token", "UsdPreviewSurface", uniform=True)
    attribute(shader, "inputs:diffuseColor", "Color3f", Gf.Vec3f(r, g, b))
    attribute(shader, "inputs:opacity", "Float", a)
    attribute(shader, "inputs:roughness", "Float", 0.6)
    if part is not None and (part.texture is not None or part.maps):
        _texture_network(layer, material, material_path, shader, part)
    attribute(shader, "outputs:surface", "Token")
    connect(material, "outputs:surface", "Token", f"{surface}.outputs:surface")


def bind(prim, material_path: str) -> None:
    apply(prim, "MaterialBindingAPI")
    relationship(prim, "material:binding", material_path)


def _face_subsets(layer, prim, mesh: Mesh, materials: dict[tuple, str]) -> None:
    """A mesh of several colours: a GeomSubset of its faces per colour bound to that
    colour's material (family materialBind, a partition)."""
    from pxr import Vt

    faces_of: dict[tuple, list[np.ndarray]] = {}
    for start, end, rgba in mesh.face_color_runs():
        faces_of.setdefault(rgba, []).append(np.arange(start, end, dtype=np.int32))
    attribute(prim, "subsetFamily:materialBind:familyType", "Token", "partition",
              uniform=True)
    for k, (rgba, faces) in enumerate(faces_of.items()):
        subset = define(layer, f"{prim.path}/colour_{k}", "GeomSubset")
        attribute(subset, "elementType", "Token", "face", uniform=True)
        attribute(subset, "familyName", "Token", "materialBind", uniform=True)
        attribute(subset, "indices", "IntArray", Vt.IntArray.FromNumpy(np.concatenate(faces)))
        bind(subset, materials[rgba])


def _define_mesh_once(layer, path: str, mesh: Mesh, visuals_written: dict[str, Mesh], *,
                      visual: bool, normals: LateNormals | None = None):
    """A visual mesh (with its texture coordinates) or a convex collider's mesh, its data
    written once: where a visual mesh already written has the same points and triangles (a
    part whose collision is its visual, as most robots' files give it; a robot's left and
    right fingers), the prim is an internal reference to it instead of a second copy.
    Composed, it has that mesh's points, indices, extent, texture coordinates (a visual
    refers only to one with the same) and display colour (a visual authors its own; a
    collider's consumers read none). Every reader that composes the stage (UsdPhysics,
    PhysX, Newton, UsdValidation, ours) sees the same mesh either way; only visuals are
    referred to, so no collider's schemas reach another prim. ``normals``: where its
    normals are computed (:class:`LateNormals`; None: here)."""
    from pxr import Sdf

    schemas = () if visual else ("PhysicsCollisionAPI", "PhysicsMeshCollisionAPI")
    source = next((where for where, seen in visuals_written.items()
                   if _same_data(seen, mesh, uv=visual)), None)
    if source is not None:
        prim = define(layer, path, "Mesh", *schemas)
        prim.referenceList.prependedItems.append(Sdf.Reference(primPath=source))
        return prim
    prim = _define_mesh(layer, path, mesh, *schemas)
    if visual:
        _creased_normals(prim, mesh, normals)
        if mesh.uv is not None:
            _texture_coordinates(prim, mesh.uv)
        visuals_written[path] = mesh
    return prim


def _same_data(a: Mesh, b: Mesh, *, uv: bool) -> bool:
    """Whether ``a`` and ``b`` are written as the same points (float32) and triangles (and,
    with ``uv``, texture coordinates)."""
    if a.vertices.shape != b.vertices.shape or a.faces.shape != b.faces.shape \
            or not np.array_equal(a.faces, b.faces) \
            or not np.array_equal(a.vertices.astype(np.float32), b.vertices.astype(np.float32)):
        return False
    if not uv or (a.uv is None and b.uv is None):
        return True
    return a.uv is not None and b.uv is not None and a.uv.shape == b.uv.shape \
        and np.array_equal(a.uv.astype(np.float32), b.uv.astype(np.float32))


def _creased_normals(prim, mesh: Mesh, later: LateNormals | None = None) -> None:
    """Normals split along creases, as glTF's (:mod:`real2code_export.normals`), as an
    indexed face-varying primvar: one value per (vertex, smoothing group), one index per
    corner. Without them a renderer smooths every shared vertex (Storm, Blender's importer):
    a box would shade as a blob. Colliders get none: they are guides, never rendered.
    ``later``: the primvars authored here, their values when :class:`LateNormals` has them."""
    normals = attribute(prim, "primvars:normals", "Normal3fArray")
    normals.SetInfo("interpolation", "faceVarying")
    indices = attribute(prim, "primvars:normals:indices", "IntArray")
    if later is None:
        _fill_normals(normals, indices, creased_normals(mesh))
    else:
        later.ask(mesh, normals, indices)


def _fill_normals(normals, indices, split: CreasedNormals) -> None:
    from pxr import Vt

    normals.default = Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(split.normals))
    indices.default = Vt.IntArray.FromNumpy(
        np.ascontiguousarray(split.indices.reshape(-1), dtype=np.int32))


class LateNormals:
    """The visual meshes' creased normals computed on other threads while the layer is
    authored: each mesh's primvars are authored where it is written (so the layer's
    properties keep their order: the same text) and filled by :meth:`finish`. Sorting a
    mesh's edges and corners, most of the work and about a sixth of a robot's USD export,
    runs in numpy without the GIL, so it goes on beside the authoring, on a second core
    where there is one (docs/benchmarks.md). A context: its threads end
    with it (a later fork, :mod:`real2code_export.forked`, needs none alive)."""

    def __init__(self, workers: int = 2) -> None:
        from concurrent.futures import ThreadPoolExecutor

        self.pool = ThreadPoolExecutor(workers, thread_name_prefix="creased-normals")
        self.asked: dict[int, tuple[Mesh, object]] = {}  # id(mesh) -> (mesh, its future)
        self.waiting: list[tuple[object, object, object]] = []  # (future, normals, indices)

    def __enter__(self) -> LateNormals:
        return self

    def __exit__(self, *exc) -> None:
        self.pool.shutdown(wait=True, cancel_futures=True)

    def ask(self, mesh: Mesh, normals, indices) -> None:
        """Fill the primvars ``normals`` and ``indices`` with ``mesh``'s, once they are
        computed (a mesh asked for again is computed once)."""
        if id(mesh) not in self.asked:  # (the mesh is kept: its id is not reused meanwhile)
            self.asked[id(mesh)] = (mesh, self.pool.submit(creased_normals, mesh))
        self.waiting.append((self.asked[id(mesh)][1], normals, indices))

    def finish(self) -> None:
        """Every primvar asked for, filled (a computation's error raised here)."""
        for future, normals, indices in self.waiting:
            _fill_normals(normals, indices, future.result())
        self.waiting.clear()


def _texture_coordinates(prim, uv: np.ndarray) -> None:
    from pxr import Vt

    st = attribute(prim, f"primvars:{ST}", "TexCoord2fArray",
                   Vt.Vec2fArray.FromNumpy(np.ascontiguousarray(uv, dtype=np.float32)))
    st.SetInfo("interpolation", "vertex")


# role -> (UsdPreviewSurface input and its type, the image's colour space, the outputs read)
_MAP_INPUTS = {
    "texture": ("diffuseColor", "Color3f", "sRGB", ("rgb",)),
    "metallic_roughness": (("roughness", "metallic"), "Float", "raw", ("g", "b")),
    "normal": ("normal", "Normal3f", "raw", ("rgb",)),
    "occlusion": ("occlusion", "Float", "raw", ("r",)),
    "emissive": ("emissiveColor", "Color3f", "sRGB", ("rgb",)),
}
_SHADER_NAMES = {"texture": "Image", "metallic_roughness": "MetallicRoughness",
                 "normal": "Normal", "occlusion": "Occlusion", "emissive": "Emissive"}


def _texture_network(layer, material, material_path: str, surface, part: Part) -> None:
    """UsdPreviewSurface's inputs from UsdUVTextures of the part's images (files beside the
    meshes, relative to the layer) through the ``st`` primvar: the base colour into
    diffuseColor, glTF's metallic-roughness map's G and B into roughness and metallic, the
    normal map (scaled and biased to -1..1) into normal, occlusion's R, emissive's RGB."""
    from pxr import Gf, Sdf

    from ...meshfiles import map_relpath, texture_relpath

    coordinates = f"{material_path}/TexCoords"
    reader = define(layer, coordinates, "Shader")
    attribute(reader, "info:id", "Token", "UsdPrimvarReader_float2", uniform=True)
    attribute(reader, "outputs:result", "Float2")  # read by each image's st
    # (varname is a string since UsdPreviewSurface 2.3; a token before, which UsdValidation
    # now calls an error)
    attribute(material, "inputs:frame:stPrimvarName", "String", ST)
    connect(reader, "inputs:varname", "String", f"{material_path}.inputs:frame:stPrimvarName")
    images = {"texture": texture_relpath(part)} if part.texture is not None else {}
    images |= {role: map_relpath(part, role) for role in part.maps}
    # Coordinates past [0, 1] repeat the image (glTF's sampler, MuJoCo's and OBJ viewers'
    # default); UsdUVTexture's default (useMetadata, none in a PNG or JPEG) draws black there.
    uv = part.visual.uv if part.visual is not None else None
    repeats = uv is not None and len(uv) > 0 and (uv.min() < 0.0 or uv.max() > 1.0)
    for role, relpath in images.items():
        inputs, kind, colorspace, outputs = _MAP_INPUTS[role]
        image_path = f"{material_path}/{_SHADER_NAMES[role]}"
        image = define(layer, image_path, "Shader")
        attribute(image, "info:id", "Token", "UsdUVTexture", uniform=True)
        attribute(image, "inputs:file", "Asset", Sdf.AssetPath(f"./{relpath}"))
        attribute(image, "inputs:sourceColorSpace", "Token", colorspace)
        if repeats:
            attribute(image, "inputs:wrapS", "Token", "repeat")
            attribute(image, "inputs:wrapT", "Token", "repeat")
        connect(image, "inputs:st", "Float2", f"{coordinates}.outputs:result")
        if role == "normal":  # stored 0..1, a normal is -1..1
            attribute(image, "inputs:scale", "Float4", Gf.Vec4f(2, 2, 2, 1))
            attribute(image, "inputs:bias", "Float4", Gf.Vec4f(-1, -1, -1, 0))
        if role == "texture" and tuple(part.color[:3]) != (1.0, 1.0, 1.0):
            # the part's colour tints its image, as glTF's baseColorFactor, MTL's Kd and
            # MuJoCo's material rgba do (the diffuseColor value is not drawn where connected)
            r, g, b = (float(c) for c in part.color[:3])
            attribute(image, "inputs:scale", "Float4", Gf.Vec4f(r, g, b, 1))
        names = (inputs,) if isinstance(inputs, str) else inputs
        for name, channel in zip(names, outputs, strict=True):
            output = f"outputs:{channel}"
            attribute(image, output, "Float3" if channel == "rgb" else "Float")
            connect(surface, f"inputs:{name}", kind, f"{image_path}.{output}")


# -- reading ---------------------------------------------------------------------------------
def read_mesh(prim, to_part: np.ndarray, path, element: str) -> Mesh:
    """A UsdGeom.Mesh as triangles in the part frame (``to_part``: mesh -> part, metres;
    polygons fanned, left-handed winding flipped)."""
    from pxr import UsdGeom

    geom = UsdGeom.Mesh(prim)
    points = geom.GetPointsAttr().Get()
    counts = geom.GetFaceVertexCountsAttr().Get()
    indices = geom.GetFaceVertexIndicesAttr().Get()
    if points is None or counts is None or indices is None or len(counts) == 0:
        raise FormatError(path, element, "mesh has no points or faces")
    v = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    counts = np.asarray(counts, dtype=np.int64)
    indices = np.asarray(indices, dtype=np.int64)
    if counts.sum() != len(indices) or counts.min() < 3:
        raise FormatError(path, element, "faceVertexCounts do not match faceVertexIndices")
    if indices.min() < 0 or indices.max() >= len(v):
        raise FormatError(path, element, "face vertex index out of range")
    if np.all(counts == 3):
        corners = np.arange(len(indices)).reshape(-1, 3)
    else:  # each polygon fanned; a corner is a position in faceVertexIndices
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        corners = np.array([[s, s + k, s + k + 1]
                            for s, n in zip(starts, counts, strict=True) for k in range(1, n - 1)])
    mirrored = np.linalg.det(to_part[:3, :3]) < 0
    if (geom.GetOrientationAttr().Get() == UsdGeom.Tokens.leftHanded) != mirrored:
        corners = corners[:, [0, 2, 1]]  # keep outward normals
    if not np.array_equal(to_part, np.eye(4)):
        v = v @ to_part[:3, :3].T + to_part[:3, 3]
    faces = indices[corners]
    uv = _read_texture_coordinates(prim, len(v), len(indices), path, element)
    if uv is None:
        return Mesh(v, faces)
    if len(uv) == len(v):  # one per point
        return Mesh(v, faces, uv)
    # one per face corner: a point seen with two coordinates becomes two vertices
    keys = np.concatenate([faces.reshape(-1, 1).astype(np.float64), uv[corners.reshape(-1)]],
                          axis=1)
    unique, inverse = np.unique(keys, axis=0, return_inverse=True)
    return Mesh(v[unique[:, 0].astype(np.int64)], inverse.reshape(-1, 3), unique[:, 1:])


def read_placed_mesh(prim, to_part: np.ndarray, path, element: str,
                     assets: dict[str, Mesh]) -> Mesh:
    """:func:`read_mesh`, saying which mesh it places (``Mesh.placements``) where the prim is
    placed rigidly: its own data, or, where it is an asset placed by reference
    (:class:`MeshAssets`: its one internal reference is to an abstract mesh prim, whose
    arrays it composes unchanged), that asset, read once (``assets``: by prim path). A file
    that wrote an asset once reads back as placing it, and is written so again."""
    matrix = np.asarray(to_part, dtype=np.float64)
    if np.linalg.det(matrix[:3, :3]) <= 0 or not tf.is_rotation(matrix[:3, :3]):
        return read_mesh(prim, matrix, path, element)
    target = _asset_prim(prim)
    if target is None:
        asset = read_mesh(prim, np.eye(4), path, element)
    else:
        key = str(target.GetPath())
        if key not in assets:
            assets[key] = read_mesh(target, np.eye(4), path, f"prim <{key}>")
        asset = assets[key]
    return Mesh.placed(asset, None if np.array_equal(matrix, np.eye(4)) else matrix)


def _asset_prim(prim):
    """The abstract mesh prim that ``prim``'s one internal reference brings, whose arrays
    (points, triangles, texture coordinates) and orientation it composes unchanged, or None."""
    from pxr import UsdGeom

    items = [r for spec in prim.GetPrimStack()
             for r in spec.referenceList.GetAddedOrExplicitItems()]
    if len(items) != 1 or items[0].assetPath or items[0].primPath.isEmpty:
        return None
    target = prim.GetStage().GetPrimAtPath(items[0].primPath)
    if not target or not target.IsAbstract() or not target.IsA(UsdGeom.Mesh):
        return None
    for name in (*MESH_ARRAYS, f"primvars:{ST}:indices", "orientation"):
        stack = prim.GetAttribute(name).GetPropertyStack() if prim.HasAttribute(name) else []
        if stack and stack[0].path.GetPrimPath() != target.GetPath():
            return None
    return target


def _read_texture_coordinates(prim, n_points: int, n_corners: int, path,
                              element: str) -> np.ndarray | None:
    """The ``st`` primvar (or the first texture-coordinate primvar), flattened: one per point
    (vertex, varying) or one per face corner (faceVarying); None where there is none."""
    from pxr import Sdf, UsdGeom

    api = UsdGeom.PrimvarsAPI(prim)
    primvar = api.GetPrimvar(ST)
    if not primvar or not primvar.HasValue():
        primvar = next((pv for pv in api.GetPrimvarsWithValues()
                        if pv.GetTypeName().role == Sdf.ValueTypeNames.TexCoord2f.role), None)
    if primvar is None:
        return None
    values = primvar.ComputeFlattened()
    if values is None:
        return None
    uv = np.asarray(values, dtype=np.float64).reshape(-1, 2)
    interpolation = primvar.GetInterpolation()
    if interpolation in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying) and len(uv) == n_points:
        return uv
    if interpolation == UsdGeom.Tokens.faceVarying and len(uv) == n_corners:
        return uv
    warn(f"{path}: {element}: texture coordinates {primvar.GetPrimvarName()!r} "
         f"({interpolation}, {len(uv)} values) do not match the mesh; not kept")
    return None


def read_images(prim, mesh_prims, path) -> dict[str, Texture]:
    """role ("texture" for the base colour, or a ``PBR_MAPS`` role) -> image, from the
    UsdUVTextures that feed the bound UsdPreviewSurface (the part prim's material or its first
    visual mesh's), read from their files. Roughness and metallic are kept as glTF's one
    map when they are the G and B of one image; otherwise they are not (packing them would
    re-encode), with a warning."""
    from pxr import UsdShade

    for p in [prim, *mesh_prims]:
        material, _ = UsdShade.MaterialBindingAPI(p).ComputeBoundMaterial()
        shader = material.ComputeSurfaceSource()[0] if material else None
        if shader:
            return _surface_images(shader, path)
    return {}


def _surface_images(shader, path) -> dict[str, Texture]:
    from pxr import UsdShade

    from ...meshfiles import texture_from_file

    def source(name: str):
        """(UsdUVTexture, output name, image file) feeding input ``name``, or None."""
        put = shader.GetInput(name)
        for attr in (put.GetValueProducingAttributes() if put else []):
            if not UsdShade.Output.IsOutput(attr):
                continue
            texture = UsdShade.Shader(attr.GetPrim())
            if texture.GetIdAttr().Get() != "UsdUVTexture":
                continue
            file = texture.GetInput("file")
            asset = _value(file) if file else None
            if asset is None or not asset.path:
                continue
            image = Path(asset.resolvedPath or "")
            if not asset.resolvedPath or not image.is_file():
                warn(f"{path}: <{texture.GetPath()}>: image {asset.path!r} not found; the "
                     f"{name} image is not kept")
                return None
            return texture, UsdShade.Output(attr).GetBaseName(), image
        return None

    out = {}
    for role, (inputs, _, _, outputs) in _MAP_INPUTS.items():
        if role == "metallic_roughness":
            rough, metal = source("roughness"), source("metallic")
            if rough is None and metal is None:
                continue
            if rough is None or metal is None or rough[2] != metal[2] \
                    or (rough[1], metal[1]) != outputs:
                warn(f"{path}: <{shader.GetPath()}>: roughness and metallic are not the G "
                     "and B of one image (glTF's metallic-roughness map); not kept")
                continue
            found = rough
        else:
            found = source(inputs)
            if found is None:
                continue
        out[role] = texture_from_file(found[2])
    return out


def _axis_rotation(axis: str) -> np.ndarray:
    """The rotation taking z to a USD shape's ``axis`` (the model's round shapes are along z)."""
    if axis == "X":
        return tf.make(rotation=tf.axis_angle_matrix([0.0, 1.0, 0.0], np.pi / 2))
    if axis == "Y":
        return tf.make(rotation=tf.axis_angle_matrix([1.0, 0.0, 0.0], -np.pi / 2))
    return np.eye(4)


# How far apart a shape's scales across its axes may be and still be one scale: a rotation
# authored in float32 (Newton's ant: a leg capsule turned 45 degrees) has columns of norm
# 1 +- 1e-7, which a tighter test took for a squash, the capsule read as its bare
# tessellation (2.6 % light beside Newton's exact solid).
EVEN_SCALE = 1e-6


def shape_mesh(prim, to_part: np.ndarray) -> Mesh | None:
    """A UsdGeom Cube, Sphere, Cylinder or Capsule as the model's shape in the part frame
    (``to_part``: the prim's own frame -> part, its scale included: a scaled cube is a box, a
    sphere scaled unevenly an ellipsoid); a scale no shape holds (a cylinder squashed across
    its axis, a mirror) gives the tessellation alone. None for other prim types."""
    from pxr import UsdGeom

    matrix = np.asarray(to_part, dtype=np.float64)
    scale = np.linalg.norm(matrix[:3, :3], axis=0)
    rotation = matrix[:3, :3] / np.where(scale > 0, scale, 1.0)
    rigid = tf.make(rotation, matrix[:3, 3])
    if prim.IsA(UsdGeom.Cube):
        shape = Primitive(ShapeKind.BOX, float(UsdGeom.Cube(prim).GetSizeAttr().Get()) * scale,
                          rigid)
    elif prim.IsA(UsdGeom.Sphere):
        radii = float(UsdGeom.Sphere(prim).GetRadiusAttr().Get()) * scale
        even = np.allclose(radii, radii[0], rtol=EVEN_SCALE, atol=0.0)
        shape = Primitive(ShapeKind.SPHERE if even else ShapeKind.ELLIPSOID,
                          radii[:1] if even else radii, rigid)
    elif prim.IsA(UsdGeom.Capsule) or prim.IsA(UsdGeom.Cylinder):
        g = UsdGeom.Capsule(prim) if prim.IsA(UsdGeom.Capsule) else UsdGeom.Cylinder(prim)
        kind = ShapeKind.CAPSULE if prim.IsA(UsdGeom.Capsule) else ShapeKind.CYLINDER
        to_axis = _axis_rotation(str(g.GetAxisAttr().Get()))
        along = np.abs(to_axis[:3, :3].T @ scale)  # the scale in the shape's own x, y, z
        size = [float(g.GetRadiusAttr().Get()) * along[0],
                float(g.GetHeightAttr().Get()) * along[2]]
        shape = Primitive(kind, size, rigid @ to_axis)
        if not np.isclose(along[0], along[1], rtol=EVEN_SCALE, atol=0.0):
            unscaled = Primitive(kind, [float(g.GetRadiusAttr().Get()),
                                        float(g.GetHeightAttr().Get())], to_axis)
            return Mesh(*unscaled.tessellation()).transformed(matrix)
    else:
        return None
    if np.linalg.det(matrix[:3, :3]) < 0:
        return Mesh(*shape.tessellation())  # mirrored: the same surface, not a rigid pose
    return Mesh.of_primitive(shape)


def define_shape(layer, path: str, shape: Primitive, *schemas: str):
    """A UsdGeom Cube (scaled to the box), Sphere (scaled for an ellipsoid), Cylinder or
    Capsule (axis Z) at the shape's pose, in double precision, with its extent (what
    UsdGeom's ComputeExtent gives for the shape's own size, before the scale op)."""
    s = [float(v) for v in shape.size]
    scale = None
    if shape.kind is ShapeKind.BOX:
        prim = define(layer, path, "Cube", *schemas)
        attribute(prim, "size", "Double", 1.0)
        half = [0.5, 0.5, 0.5]
        scale = s
    elif shape.kind in (ShapeKind.SPHERE, ShapeKind.ELLIPSOID):
        prim = define(layer, path, "Sphere", *schemas)
        radius = s[0] if shape.kind is ShapeKind.SPHERE else 1.0
        attribute(prim, "radius", "Double", radius)
        half = [radius] * 3
        scale = s if shape.kind is ShapeKind.ELLIPSOID else None
    else:
        capsule = shape.kind is ShapeKind.CAPSULE
        prim = define(layer, path, "Capsule" if capsule else "Cylinder", *schemas)
        radius, height = s[0], s[1]
        attribute(prim, "radius", "Double", radius)
        attribute(prim, "height", "Double", height)
        attribute(prim, "axis", "Token", "Z", uniform=True)
        half = [radius, radius, height * 0.5 + (radius if capsule else 0.0)]
    place(prim, shape.pose, scale)
    attribute(prim, "extent", "Float3Array", extent([-h for h in half], half))
    return prim


def read_color(prim, mesh_prims, path) -> tuple[float, float, float, float]:
    """The part colour: diffuseColor/opacity of the material bound to the part prim or its
    first visual mesh (constant inputs only), else displayColor, else the default."""
    from pxr import UsdGeom

    for p in [prim, *mesh_prims]:
        rgba = _bound_color(p, path)
        if rgba is not None:
            return rgba
    for p in mesh_prims:
        gprim = UsdGeom.Gprim(p)
        colors = gprim.GetDisplayColorAttr().Get()
        if colors:
            opacity = gprim.GetDisplayOpacityAttr().Get()
            return _clamped((*colors[0], opacity[0] if opacity else 1.0), path, str(p.GetPath()))
    return DEFAULT_COLOR


def _bound_color(p, path) -> tuple[float, float, float, float] | None:
    """diffuseColor/opacity (constant inputs) of the material bound to prim ``p``."""
    from pxr import UsdShade

    material, _ = UsdShade.MaterialBindingAPI(p).ComputeBoundMaterial()
    shader = material.ComputeSurfaceSource()[0] if material else None
    if not shader:
        return None
    diffuse, opacity = shader.GetInput("diffuseColor"), shader.GetInput("opacity")
    rgb = _value(diffuse) if diffuse else None
    image = _diffuse_image(diffuse) if diffuse else None
    if image is not None:  # an image draws it: its tint is the image's scale, not the value
        scale = image.GetInput("scale")
        value = _value(scale) if scale else None
        rgb = tuple(value)[:3] if value is not None else (1.0, 1.0, 1.0)
    if rgb is None:
        return None
    alpha = _value(opacity) if opacity else None
    alpha = 1.0 if alpha is None else alpha
    return _clamped((*rgb, alpha), path, str(p.GetPath()))


def _diffuse_image(diffuse):
    """The UsdUVTexture shader whose output gives a diffuseColor input its value, or None."""
    from pxr import UsdShade

    for attr in diffuse.GetValueProducingAttributes():
        if UsdShade.Output.IsOutput(attr):
            shader = UsdShade.Shader(attr.GetPrim())
            if shader and shader.GetIdAttr().Get() == "UsdUVTexture":
                return shader
    return None


def _value(put):
    """A shader input's value through its connections (a Material's interface inputs, as the
    NVIDIA converters write them: ``diffuseColor.connect = </Mat.inputs:diffuseColor>``): the
    value of the input that produces it; None where a shader output produces it or none is
    authored. (``UsdShade.Input.Get`` reads the input's own value only.)"""
    from pxr import UsdShade

    for attr in put.GetValueProducingAttributes():
        return None if UsdShade.Output.IsOutput(attr) else attr.Get()
    return put.Get()


def color_runs(prim, n_faces: int, path) -> list[tuple[int, tuple | None]]:
    """A visual prim's colours over its ``n_faces`` triangles as runs (face count, RGBA;
    None where it states none): its bound material's colour, else a constant displayColor,
    per face where GeomSubsets of the materialBind family bind materials to its faces
    (:func:`bound_runs`)."""
    from pxr import UsdGeom

    own = _bound_color(prim, path)
    if own is None:
        gprim = UsdGeom.Gprim(prim)
        colors = gprim.GetDisplayColorAttr().Get()
        if colors is not None and len(colors) == 1:
            opacity = gprim.GetDisplayOpacityAttr().Get()
            own = _clamped((*colors[0], opacity[0] if opacity else 1.0), path,
                           str(prim.GetPath()))
    return [(n, own if p == prim else _bound_color(p, path))
            for n, p in bound_runs(prim, n_faces)]


def bound_runs(prim, n_faces: int) -> list[tuple[int, object]]:
    """Which prim's bound material draws each of a visual prim's ``n_faces`` triangles, as
    runs (face count, prim): a GeomSubset of the materialBind family where it binds them (a
    mesh of triangles only: the subsets index its faces), the prim itself elsewhere."""
    from pxr import UsdGeom, UsdShade

    subsets = UsdShade.MaterialBindingAPI(prim).GetMaterialBindSubsets() \
        if prim.IsA(UsdGeom.Mesh) else []
    counts = UsdGeom.Mesh(prim).GetFaceVertexCountsAttr().Get() if subsets else None
    if not subsets or counts is None or len(counts) != n_faces or np.any(np.asarray(counts) != 3):
        return [(n_faces, prim)]
    owners = [prim]  # per face, as an index in this list
    label = np.zeros(n_faces, dtype=np.int64)
    for subset in subsets:
        faces = np.asarray(subset.GetIndicesAttr().Get() or [], dtype=np.int64)
        owners.append(subset.GetPrim())
        label[faces[(faces >= 0) & (faces < n_faces)]] = len(owners) - 1
    starts = np.flatnonzero(np.r_[True, label[1:] != label[:-1]]) if n_faces else []
    ends = np.r_[starts[1:], n_faces] if n_faces else []
    return [(int(e - b), owners[label[b]]) for b, e in zip(starts, ends, strict=True)]


def _clamped(rgba, path, where: str) -> tuple[float, float, float, float]:
    values = tuple(float(c) for c in rgba)
    clipped = tuple(min(1.0, max(0.0, c)) for c in values)
    if clipped != values:
        warn(f"{path}: {where}: colour {list(values)} clamped to [0, 1]")
    return clipped
