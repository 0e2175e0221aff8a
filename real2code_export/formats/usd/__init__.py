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

from .. import names_from_modules

__all__ = ["load", "mesh_layer_path", "save"]
# (an export to USD imports no reader: its parsed tree, and through the registry's
# ``read_requires`` pxr.Usd and the schema modules)
__getattr__ = names_from_modules(__name__, {
    "load": "read", "save": "write", "mesh_layer_path": "write"})
