"""glTF 2.0 (.glb / .gltf): export for viewers and physics-aware tools, import back.

- ``save(obj, out_dir)`` writes ``out_dir/<name>.glb``: a node tree following the
  kinematic tree (each joint's motion is one node's rotation or translation), PBR
  materials, one animation per movable joint, the physics in KHR_physics_rigid_bodies
  and every model value in ``extras`` (namespace ``real2code``). Y up: the scene root node
  carries the Z-up -> Y-up rotation (see ``conventions``).
- ``load(path)`` reads our files losslessly (vertices are float32), other files from their
  KHR_physics_rigid_bodies joints or, failing that, as parts on fixed joints.
- ``validate_gltf(path)`` runs the Khronos glTF validator (npm ``gltf-validator``).
"""

from __future__ import annotations

from .. import names_from_modules

__all__ = ["ValidatorUnavailable", "load", "save", "validate_gltf",
           "validate_gltf_files"]
# (the validator, which ``real2code check`` of a .glb runs, imports no reader or writer:
# their modules were 0.09 s of a check under cProfile at load 20; the check's glTF
# probe reads the file's JSON itself)
__getattr__ = names_from_modules(__name__, {
    "load": "read", "save": "write", "ValidatorUnavailable": "validator",
    "validate_gltf": "validator", "validate_gltf_files": "validator"})
