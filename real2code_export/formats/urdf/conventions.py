"""What the URDF reader and writer agree on: our namespace, defaults, number text."""

from __future__ import annotations

from .. import FORMATS

# Data URDF has no place for (joint state, stiffness, spring reference, armature, unknown
# effort/velocity, object metadata, deliberately absent collision/inertial) is kept in
# attributes of this namespace: URDF tools ignore them, our reader restores them.
NAMESPACE = "urn:real2code-export:urdf:1"
PREFIX = "real2code"

# URDF requires effort and velocity on every <limit>. When the model does not know them we
# write these (generous for household articulations: doors, drawers, lids) and mark the
# attribute real2code:effort="none" / real2code:velocity="none", so a reader of ours gets
# "unknown" back. 0 would be worse: MuJoCo turns effort into an actuator force range.
DEFAULT_EFFORT = 1000.0  # N m (revolute) or N (prismatic)
DEFAULT_VELOCITY = 100.0  # rad/s or m/s
UNKNOWN = "none"

# The link MuJoCo's URDF import takes as its world body (the only parent it allows a free
# joint); the writer adds one, marked real2code:added, above a root part of another name
# whose free bodies hang from it (write.world_link), and the reader takes it out again.
WORLD_LINK = "world"
ADDED = "added"

# The children of <robot> the model has no place for (<transmission>, <gazebo>, Drake's
# <frame>, ...) are kept, as XML text in document order, under this key of the object's
# metadata: every format carries the metadata, and the URDF writer writes them back.
ELEMENTS_KEY = FORMATS["urdf"].kept_elements
# Children of a <link> or <joint> the model has no place for (a joint's <safety_controller>
# and <calibration>, ROS's soft limits and homing references) are kept in the same list,
# each wrapped in <real2code:in link|joint="NAME">, which the writer unwraps into that
# element (or, where the object has no element of that name any more, writes as it is),
KEPT_IN = "in"
# and marks each so written back real2code:kept="true": our reader keeps it again unwarned
KEPT = "kept"
# Attributes without which urdfdom refuses such a child (and the whole file: "joint safety:
# no k_velocity"): one kept from a file urdfdom refused stays wrapped, in <robot>, where
# URDF's readers ignore it, so that the export loads (warned by the reader).
URDFDOM_REQUIRES = {"safety_controller": ("k_velocity",)}


def ns(name: str) -> str:
    """Clark notation of an attribute in our namespace (for lxml)."""
    return f"{{{NAMESPACE}}}{name}"


def number(value: float) -> str:
    """Shortest text that reads back to the same float64 (Python's repr)."""
    return repr(float(value))


def numbers(values) -> str:
    return " ".join(number(v) for v in values)
