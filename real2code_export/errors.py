"""One exception hierarchy for the project.

Every message names where the problem is: the file (when there is one), the element
(``joint 'hinge_1'``, ``<joint> 'hinge_1'``), the line where the format has lines, and what
is wrong. The CLI prints ``str(error)`` and exits non-zero.
"""

from __future__ import annotations

import warnings
from pathlib import Path


class Real2CodeError(Exception):
    """Base of every error this project raises on purpose."""


class InputError(Real2CodeError, ValueError):
    """A value handed to the library is unusable (an option out of range, geometry a step
    cannot work on); a ValueError too, for callers that catch those."""


class NameNotFoundError(Real2CodeError, KeyError):
    """A part or joint name that is not there; a KeyError too, for callers that catch those."""

    def __str__(self) -> str:  # KeyError's own would quote the message
        return str(self.args[0]) if self.args else ""


class ModelError(Real2CodeError):
    """The articulated-object model is invalid (names the part or joint and what is wrong)."""

    def __init__(self, element: str, message: str):
        self.element = element
        self.message = message
        super().__init__(f"{element}: {message}")


class FormatError(Real2CodeError):
    """A file cannot be read or written: names the file, the element and, if known, the line."""

    def __init__(
        self,
        path: str | Path | None,
        element: str | None,
        message: str,
        line: int | None = None,
    ):
        self.path = str(path) if path is not None else None
        self.element = element
        self.message = message
        self.line = line
        where = self.path or "<input>"
        if line is not None:
            where += f":{line}"
        text = f"{where}: "
        if element:
            text += f"{element}: "
        super().__init__(text + message)


class NoTrianglesError(FormatError):
    """A mesh file with no triangles (vertices only: MuJoCo takes their convex hull)."""


class UnavailableError(Real2CodeError):
    """A format (or tool) whose dependencies do not import here: says which and why."""


class ExportError(Real2CodeError):
    """A model could not be written to a format (the format's own tool refused it)."""


class CheckError(Real2CodeError):
    """A file could not be loaded for checking."""


class Real2CodeWarning(UserWarning):
    """Something in the input was repaired; the message says what and where."""


def warn(message: str) -> None:
    """Issue a repair warning (one place, so the CLI can collect and print them)."""
    warnings.warn(message, Real2CodeWarning, stacklevel=2)
