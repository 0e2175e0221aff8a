"""MJCF (MuJoCo) through MjSpec: export checked by MuJoCo's compiler, import of any MJCF.

``save(obj, out_dir)`` writes ``out_dir/<name>.xml`` referencing the shared mesh files;
``build_spec(obj)`` gives the same model as an ``MjSpec`` that compiles with nothing on disk;
``load(path)`` reads any MJCF MuJoCo compiles (defaults, frames and orientation notations
resolved by MuJoCo itself). ``load(save(obj))`` is lossless for the model's fields: joint
states are the keyframe "observed", what MJCF has no place for is ``<custom>`` data named
``real2code:<element>:<field>``.
"""

from .. import names_from_modules

__all__ = ["CUSTOM_PREFIX", "KEYFRAME", "build_spec", "load", "save", "to_xml"]
__getattr__ = names_from_modules(__name__, {
    "CUSTOM_PREFIX": "conventions", "KEYFRAME": "conventions", "load": "read",
    "build_spec": "write", "save": "write", "to_xml": "write"})
