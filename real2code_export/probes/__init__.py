"""Kinematic probes: a file loaded in its own tool, posed by joint name, asked for the world
pose of every part. ``real2code check`` compares probes; it never asks our own writer.

Each probe module offers ``open_probes(path) -> list[Probe]`` (a URDF yields two: MuJoCo and
Pinocchio). Modules are imported only when a file of their kind is checked.
"""

from __future__ import annotations

import importlib
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from ..errors import CheckError, Real2CodeError, Real2CodeWarning


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


def open_probes(path: str | Path) -> list[Probe]:
    """Every probe for ``path``: the registry's probe modules for its format, in report
    order (chosen by suffix)."""
    from ..formats import FORMATS, format_for_path, unavailable_reason

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
    problem = unavailable_reason(fmt.name)
    if problem:
        raise CheckError(f"{path}: {fmt.name} files cannot be checked here: {problem}")
    probes: list[Probe] = []
    for name in fmt.probes:
        probes.extend(_probe_module(name, path).open_probes(path))
    return probes


def _probe_module(name: str, path: Path):
    try:
        return importlib.import_module(name)
    except Exception as e:  # noqa: BLE001 - a broken tool fails in any way it likes
        raise CheckError(f"{path}: its tool cannot be loaded here: {name} "
                         f"({type(e).__name__}: {e})") from e


SOURCE_LABEL = "source"  # the label of every probe of a user's own file starts with it


class SourceProbe:
    """A probe of the user's own input file (``check --reference``), its names made the
    identifiers our importers make of them (``model.sanitize_name``), so that each part and
    joint of the source is compared with the part or joint it became."""

    def __init__(self, probe: Probe):
        from ..model import sanitize_name

        self._probe = probe
        self.label = f"{SOURCE_LABEL} {probe.label}"
        self.path = probe.path
        self.parts = [sanitize_name(n) for n in probe.parts]
        self.joints = [JointInfo(sanitize_name(j.name), j.kind, j.lower, j.upper)
                       for j in probe.joints]
        self._raw = {new.name: old.name for new, old in zip(self.joints, probe.joints,
                                                              strict=True)}

    def pose_array(self, values: np.ndarray) -> np.ndarray:
        if hasattr(self._probe, "pose_array"):
            return self._probe.pose_array(values)
        rows = [self.poses(dict(zip((j.name for j in self.joints), row, strict=True)))
                for row in np.atleast_2d(values)]
        return np.array([[r[p] for p in self.parts] for r in rows])

    def poses(self, q: dict[str, float]) -> dict[str, np.ndarray]:
        raw = self._probe.poses({self._raw[name]: v for name, v in q.items()})
        return dict(zip(self.parts, (raw[p] for p in self._probe.parts), strict=True))


def open_source_probes(path: str | Path) -> list[Probe]:
    """Probes of a user's input file as the reference: MJCF in MuJoCo; URDF in MuJoCo (its
    kinematics: MuJoCo reads neither ``package://`` nor Collada) and in Pinocchio."""
    path = Path(path)
    if not path.exists():
        raise CheckError(f"{path}: no such file")
    from ..formats import format_for_path

    try:
        kind = format_for_path(path).name
    except Real2CodeError:
        kind = None
    if kind not in ("urdf", "mjcf"):
        raise CheckError(f"{path}: a reference must be a URDF or MJCF file, "
                         f"not {path.suffix.lower()!r}")
    from . import mujoco as mujoco_probe

    if kind == "mjcf":
        return [SourceProbe(p) for p in mujoco_probe.open_probes(path, source=True)]
    from . import pinocchio as pinocchio_probe

    probes: list[Probe] = []
    try:
        probes += mujoco_probe.open_probes(path, source=True)
    except CheckError as e:  # a tensor MuJoCo's balanceinertia does not mend: Pinocchio loads it
        warnings.warn(f"{e}; the source is compared in Pinocchio only", Real2CodeWarning,
                      stacklevel=2)
    probes += pinocchio_probe.open_probes(path)
    return [SourceProbe(p) for p in probes]
