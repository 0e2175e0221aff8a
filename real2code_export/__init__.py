"""real2code_export: scans of articulated objects in, simulation-ready digital twins out.

The light core is importable without any simulator: the model, its validation and
kinematics, and the format registry (formats import their heavy tools only when used).
Importing the package itself imports nothing but the errors: the model's names are loaded
on first use, so the command line starts quickly.
"""

from .errors import FormatError, ModelError, Real2CodeError, Real2CodeWarning

__version__ = "0.1.0"

_MODEL_NAMES = ("ArticulatedObject", "Dynamics", "Inertial", "Joint", "JointType", "Limits",
                "Mesh", "Part", "differences", "forward_kinematics", "validate")

__all__ = ["FormatError", "ModelError", "Real2CodeError", "Real2CodeWarning", *_MODEL_NAMES]


def __getattr__(name: str):
    if name in _MODEL_NAMES:  # PEP 562: numpy and the model only when asked for
        from . import model

        return getattr(model, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
