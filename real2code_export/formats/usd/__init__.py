"""USD (UsdPhysics) export and import with usd-core.

``save(obj, out_dir)`` writes ``out_dir/<name>.usda`` over the binary layer of its mesh
arrays, ``out_dir/meshes/<name>.usdc``: Z up, metres, kilograms; one rigid body per part with
its meshes, a UsdPreviewSurface colour and convex collision pieces;
UsdPhysics joints (revolute limits in degrees) with NewtonJointAPI and MjcJointAPI dynamics;
the object fixed to the world and posed at its observed state. ``load(path)`` reads any
.usda/.usd/.usdc through UsdPhysics' own parser. Module map, as in every format package:
read (load, with a ``Context``), write (save), conventions (layout, stage metadata and units,
value conversions); and the concepts both directions share: geometry (meshes, materials),
body (rigid bodies, mass), joint (joints, units), articulation (the parsed tree).
"""

__all__ = ["load", "mesh_layer_path", "save"]


def __getattr__(name: str):
    """``load`` from ``read``, ``save`` and ``mesh_layer_path`` from ``write``, each imported
    when first asked for: an export to USD imports no reader (its parsed tree, and through
    the registry's ``read_requires`` pxr.Usd and the schema modules)."""
    if name == "load":
        from .read import load

        return load
    if name in ("save", "mesh_layer_path"):
        from . import write

        return getattr(write, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
