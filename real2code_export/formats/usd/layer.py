"""Authoring the file we write through Sdf, USD's layer API: prim, attribute and relationship
specs. The concept modules (body, geometry, joint) give each property the type and
variability its schema (UsdGeom, UsdShade, UsdPhysics, Newton's) declares: restated there,
because writing through those schema modules would import them.

Why not ``Usd``/``UsdGeom``/``UsdPhysics``/``UsdShade``: importing them and building the
first stage's schema registry cost 0.05 to 0.07 s of CPU, a fifth of a whole ``real2code
export`` of a PartNet-Mobility object to USD (docs/benchmarks.md); the layer is the same
either way (the .usda text is byte-identical: properties are written sorted by name, prims
in the order defined, as a stage writes them). Reading (``read.py``) stays on ``Usd`` and
UsdPhysics' own parser.
"""

from __future__ import annotations

import numpy as np

from ... import transforms as tf


def new_layer(name: str, scene: str):
    """An anonymous layer with Z up, metres, kilograms, the object prim ``/<name>`` (an
    Xform, the defaultPrim) and its Geometry, Physics and Looks scopes, and a PhysicsScene
    ``/<scene>`` (gravity -Z, 9.81 m/s^2, PhysX's PGS solver, MuJoCo's multiccd). Returns
    (layer, object prim)."""
    from pxr import Gf, Sdf

    from ...engine_settings import MULTICCD, PHYSX_SOLVER
    from .. import FORMATS
    from .conventions import GEOMETRY, LOOKS, PHYSICS

    # (the tag's suffix picks the layer's file format: the one the export writes)
    layer = Sdf.Layer.CreateAnonymous(f"{name}{FORMATS['usd'].output_suffix}")
    info = layer.pseudoRoot
    info.SetInfo("upAxis", "Z")
    info.SetInfo("metersPerUnit", 1.0)
    info.SetInfo("kilogramsPerUnit", 1.0)  # UsdPhysics' layer metadata
    layer.documentation = f"{name}: written by real2code_export"
    layer.defaultPrim = name
    root = define(layer, f"/{name}", "Xform")
    for scope in (GEOMETRY, PHYSICS, LOOKS):
        define(layer, f"/{name}/{scope}", "Scope")
    physics_scene = define(layer, f"/{scene}", "PhysicsScene")
    attribute(physics_scene, "physics:gravityDirection", "Vector3f", Gf.Vec3f(0.0, 0.0, -1.0))
    attribute(physics_scene, "physics:gravityMagnitude", "Float", 9.81)
    # PhysX's default TGS solver lets a freely swinging door drift 0.36 rad from MuJoCo in
    # 2 s at 1 ms; PGS integrates it as MuJoCo does (1e-4 rad; `real2code simulate`).
    # (PhysxSceneAPI is codeless here: usd-core has no PhysxSchema, the tokens suffice.)
    apply(physics_scene, "PhysxSceneAPI")
    attribute(physics_scene, "physxScene:solverType", "Token", PHYSX_SOLVER)
    # MuJoCo's several contact points per convex pair, which Newton turns off unless told
    apply(physics_scene, "MjcSceneAPI")
    attribute(physics_scene, "mjc:flag:multiccd", "Bool", MULTICCD, uniform=True)
    return layer, root


def define(layer, path: str, type_name: str, *schemas: str):
    """``def <type_name>`` at ``path`` (its parent already defined), with API ``schemas``."""
    from pxr import Sdf

    sdf_path = Sdf.Path(path)
    parent = layer.GetPrimAtPath(sdf_path.GetParentPath())
    spec = Sdf.PrimSpec(parent, sdf_path.name, Sdf.SpecifierDef, type_name)
    if schemas:
        apply(spec, *schemas)
    return spec


def apply(spec, *schemas: str) -> None:
    """Add API ``schemas`` to the prim's ``prepend apiSchemas``, after those it has (what
    ``UsdPrim.ApplyAPI`` authors)."""
    from pxr import Sdf

    have = list(spec.GetInfo("apiSchemas").prependedItems) if spec.HasInfo("apiSchemas") else []
    spec.SetInfo("apiSchemas", Sdf.TokenListOp.Create(
        prependedItems=have + [s for s in schemas if s not in have]))


_VALUE_TYPES: dict[str, object] = {}  # "Float" -> Sdf.ValueTypeNames.Float, looked up once


def attribute(spec, name: str, type_name: str, value=None, *, uniform: bool = False,
              custom: bool = False):
    """An attribute of Sdf value type ``type_name`` ("Float", "Point3fArray", ...), with
    ``value`` as its default unless None."""
    from pxr import Sdf

    value_type = _VALUE_TYPES.get(type_name)
    if value_type is None:
        value_type = _VALUE_TYPES[type_name] = getattr(Sdf.ValueTypeNames, type_name)
    attr = Sdf.AttributeSpec(spec, name, value_type,
                             Sdf.VariabilityUniform if uniform else Sdf.VariabilityVarying,
                             declaresCustom=custom)
    if value is not None:
        attr.default = value
    return attr


def connect(spec, name: str, type_name: str, source: str):
    """An attribute (a shader's input or output; the one the prim has by that name, if any)
    connected to the attribute at ``source`` (what ``UsdShadeInput.ConnectToSource``
    authors: one connection, explicit)."""
    from pxr import Sdf

    attr = spec.attributes[name] if name in spec.attributes else \
        attribute(spec, name, type_name)
    attr.connectionPathList.explicitItems = [Sdf.Path(source)]
    return attr


def relationship(spec, name: str, *targets: str):
    from pxr import Sdf

    rel = Sdf.RelationshipSpec(spec, name, custom=False)
    rel.targetPathList.explicitItems = [Sdf.Path(t) for t in targets]
    return rel


def place(spec, pose: np.ndarray, scale=None) -> None:
    """UsdGeomXformable's translate, orient (and scale) ops in double precision, and the
    xformOpOrder naming them."""
    from pxr import Gf

    attribute(spec, "xformOp:translate", "Double3",
              Gf.Vec3d(*(float(v) for v in pose[:3, 3])))
    w, x, y, z = (float(c) for c in tf.matrix_to_quat(pose[:3, :3]))
    attribute(spec, "xformOp:orient", "Quatd", Gf.Quatd(w, x, y, z))
    order = ["xformOp:translate", "xformOp:orient"]
    if scale is not None:
        attribute(spec, "xformOp:scale", "Double3", Gf.Vec3d(*(float(v) for v in scale)))
        order.append("xformOp:scale")
    attribute(spec, "xformOpOrder", "TokenArray", order, uniform=True)


def extent(low, high):
    """A float3[2] extent from float64 corners (rounded to float, as UsdGeom's do)."""
    from pxr import Gf, Vt

    return Vt.Vec3fArray([Gf.Vec3f(*(float(v) for v in low)),
                          Gf.Vec3f(*(float(v) for v in high))])
