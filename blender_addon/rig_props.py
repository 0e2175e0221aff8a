"""Where a rig keeps the model's facts: the custom-property names shared by import and export.

Every object the importer makes carries ``real2code_role`` (``object``, ``part``, ``joint`` or
``collision``) and its model name (Blender may add ``.001`` to the object name; the model name
stays). A joint's value is its Empty's own motion channel (the Z rotation of a hinge, the Z location
of a slide), so the gizmo, keyframes and the panel's slider all pose the same thing. Joint
facts an artist may edit are visible custom properties in SI units (radians or metres); the exact float64 values read from the file sit in ``_real2code_exact`` (hidden: a
leading underscore hides a property in Blender's UI), used on export wherever the rig still
shows them up to Blender's float32 precision, so an unedited rig exports exactly what it read.
"""

from __future__ import annotations

import json
import re

PREFIX = "real2code_"
ROLE = PREFIX + "role"
NAME = PREFIX + "name"
TYPE = PREFIX + "type"
AXIS = PREFIX + "axis"
LOWER = PREFIX + "lower"
UPPER = PREFIX + "upper"
EFFORT = PREFIX + "effort"
VELOCITY = PREFIX + "velocity"
STATE = PREFIX + "state"
DYNAMICS = ("damping", "friction", "stiffness", "spring_ref", "armature")
MASS = PREFIX + "mass"
COM = PREFIX + "com"
INERTIA = PREFIX + "inertia"
INDEX = PREFIX + "index"  # position in the model's list: of parts, of joints, of a part's pieces
METADATA = PREFIX + "metadata"
SOURCE = PREFIX + "source"
EXACT = "_" + PREFIX + "exact"
CHECK = "_" + PREFIX + "check"  # the last check report (JSON) of an object's rig

ROLE_OBJECT, ROLE_PART, ROLE_JOINT, ROLE_COLLISION = "object", "part", "joint", "collision"

# An edit smaller than this is taken as float32 rounding of the exact value (metres/radians).
SNAP_TOLERANCE = 1e-5

_BLENDER_SUFFIX = re.compile(r"\.\d{3,}$")


def dynamics_key(name: str) -> str:
    return PREFIX + name


def role(obj) -> str | None:
    return obj.get(ROLE)


def base_name(obj) -> str:
    """The object's name without the ``.001`` Blender adds to keep names unique."""
    return _BLENDER_SUFFIX.sub("", obj.name)


def exact(obj) -> dict:
    text = obj.get(EXACT)
    return json.loads(text) if isinstance(text, str) else {}


def set_exact(obj, values: dict) -> None:
    obj[EXACT] = json.dumps(values)


def model_order(obj) -> tuple[int, str]:
    """Sort key: the position the object had in the model, new objects last, by name."""
    return (obj.get(INDEX, 1 << 30), obj.name)


def joint_kind(je) -> str | None:
    """The joint type a joint Empty was built for (its motion channel follows it)."""
    return exact(je).get("type", je.get(TYPE))


def motion_channel(je) -> tuple[str, int] | None:
    """(property, index) of a joint Empty's motion channel; None for a fixed joint."""
    kind = joint_kind(je)
    if kind in ("revolute", "continuous"):
        return "rotation_euler", 2
    if kind == "prismatic":
        return "location", 2
    return None


def joint_value(je) -> float:
    path, index = motion_channel(je)
    return float(getattr(je, path)[index])


def set_joint_value(je, value: float) -> None:
    """Pose a joint, held inside the range its custom properties give now (an edited limit
    takes effect at once); a continuous joint is not held."""
    path, index = motion_channel(je)
    if joint_kind(je) != "continuous" and LOWER in je and UPPER in je:
        value = min(max(value, float(je[LOWER])), float(je[UPPER]))
    getattr(je, path)[index] = value
