"""USD (UsdPhysics) export and import with usd-core.

``save(obj, out_dir)`` writes ``out_dir/<name>.usda``: Z up, metres, kilograms; one rigid
body per part with inline meshes, a UsdPreviewSurface colour and convex collision pieces;
UsdPhysics joints (revolute limits in degrees) with NewtonJointAPI and MjcJointAPI dynamics;
the object fixed to the world and posed at its observed state. ``load(path)`` reads any
.usda/.usd/.usdc through UsdPhysics' own parser. Module map: stage (layout, metadata,
value conversions), geometry (meshes, materials), body (rigid bodies, mass), joint (joints,
units), articulation (the parsed tree), convert (save/load).
"""

from .convert import load, save, to_usda

__all__ = ["load", "save", "to_usda"]
