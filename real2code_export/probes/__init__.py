"""Kinematic probes: a file loaded in its own tool, posed by joint name, asked for the world
pose of every part. ``real2code check`` compares probes; it never asks our own writer.

Each probe module offers ``open_probes(path) -> list[Probe]`` (a URDF yields two: MuJoCo and
Pinocchio). Modules are imported only when a file of their kind is checked.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from ..errors import CheckError, Real2CodeError


@dataclass(frozen=True)
class JointInfo:
    """A movable joint as the tool sees it: name, kind and range (None: unbounded)."""

    name: str
    kind: str  # "revolute", "prismatic" or "continuous"
    lower: float | None
    upper: float | None


class Probe(Protocol):
    label: str  # e.g. "MuJoCo (MJCF)"
    path: Path
    joints: list[JointInfo]  # the movable joints the tool found
    parts: list[str]  # the part (body/link/prim/node) names the tool found

    def poses(self, q: dict[str, float]) -> dict[str, np.ndarray]:
        """World pose (4x4) of every part at joint values ``q`` (by joint name; joints not
        named are at 0)."""
        ...

    # Optional, used by check when present (one call instead of one per configuration):
    # pose_array(values: (N, len(joints)) array in the order of ``joints``)
    #   -> (N, len(parts), 4, 4) world poses in the order of ``parts``.


def joint_motions(kind: str, axis, values: np.ndarray) -> np.ndarray:
    """(N, 4, 4) motions of a joint at ``values``: a rotation about the unit ``axis``
    (revolute, continuous; Rodrigues, the very arithmetic of ``transforms.axis_angle_matrix``),
    a translation along it (prismatic), the identity for any other kind (held at rest)."""
    values = np.asarray(values, dtype=float)
    out = np.broadcast_to(np.eye(4), (len(values), 4, 4)).copy()
    if kind in ("revolute", "continuous"):
        x, y, z = np.asarray(axis, dtype=float)
        k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
        s, c = np.sin(values)[:, None, None], np.cos(values)[:, None, None]
        out[:, :3, :3] = np.eye(3) + s * k + (1.0 - c) * (k @ k)
    elif kind == "prismatic":
        out[:, :3, 3] = np.asarray(axis, dtype=float) * values[:, None]
    return out


def open_probes(path: str | Path) -> list[Probe]:
    """Every probe for ``path``: the registry's probe modules for its format, in report
    order (chosen by suffix)."""
    from ..formats import FORMATS, format_for_path

    path = Path(path)
    if not path.exists():
        raise CheckError(f"{path}: no such file")
    try:
        fmt = format_for_path(path)
    except Real2CodeError:
        fmt = None
    if fmt is None or not fmt.probes:
        known = sorted(s for f in FORMATS.values() if f.probes for s in f.suffixes)
        raise CheckError(f"{path}: cannot check files of type {path.suffix!r} "
                         f"(known: {', '.join(known)})")
    # What a probe needs is its tool, imported when it opens the file, not the format's reader
    # and writer (the glTF probe reads the file's JSON: pygltflib, 0.1 s of CPU to import, is
    # the reader's); a tool that fails to import is said as the format's unavailability is.
    probes: list[Probe] = []
    for name in fmt.probes:
        module = _probe_module(name, path)
        try:
            probes.extend(module.open_probes(path))
        except ImportError as e:
            raise CheckError(f"{path}: {fmt.name} files cannot be checked here: its tool "
                             f"cannot be loaded ({type(e).__name__}: {e})") from e
    return probes


def _probe_module(name: str, path: Path):
    try:
        return importlib.import_module(name)
    except Exception as e:  # noqa: BLE001 - a broken tool fails in any way it likes
        raise CheckError(f"{path}: its tool cannot be loaded here: {name} "
                         f"({type(e).__name__}: {e})") from e
