"""real2code_export: scans of articulated objects in, simulation-ready digital twins out.

The light core is importable without any simulator: the model, its validation and
kinematics, and the format registry (formats import their heavy tools only when used).
"""

from .errors import FormatError, ModelError, Real2CodeError, Real2CodeWarning
from .model import (
    ArticulatedObject,
    Dynamics,
    Inertial,
    Joint,
    JointType,
    Limits,
    Mesh,
    Part,
    differences,
    forward_kinematics,
    validate,
)

__version__ = "0.1.0"

__all__ = [
    "ArticulatedObject",
    "Dynamics",
    "FormatError",
    "Inertial",
    "Joint",
    "JointType",
    "Limits",
    "Mesh",
    "ModelError",
    "Part",
    "Real2CodeError",
    "Real2CodeWarning",
    "differences",
    "forward_kinematics",
    "validate",
]
