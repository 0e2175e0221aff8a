"""URDF: export for ROS, Pinocchio, MuJoCo, Isaac, Gazebo; import that survives real files.

``load(path)`` reads a URDF (PartNet-Mobility's quirks included) into the model;
``save(obj, out_dir)`` writes ``out_dir/<name>.urdf`` referencing the shared mesh files.
``load(save(obj))`` is lossless: what URDF has no place for is kept in attributes of the
namespace ``urn:real2code-export:urdf:1`` (prefix ``real2code``), which other tools ignore.
"""

from .. import names_from_modules

__all__ = ["DEFAULT_EFFORT", "DEFAULT_VELOCITY", "NAMESPACE", "load", "save",
           "to_bytes"]
__getattr__ = names_from_modules(__name__, {
    "DEFAULT_EFFORT": "conventions", "DEFAULT_VELOCITY": "conventions",
    "NAMESPACE": "conventions", "load": "read", "save": "write", "to_bytes": "write"})
