"""The user's own input file as the reference of ``check --reference``: loaded in its own
tools (MuJoCo; Pinocchio too for a URDF; Newton for USD), its names made the identifiers our importers make."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..errors import CheckError, Real2CodeError, Real2CodeWarning
from . import JointInfo, Probe

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
        self.model = getattr(probe, "model", None)  # (MuJoCo's, which the dynamics reuse)
        self.dynamics = getattr(probe, "dynamics", None)  # (Newton's of a USD source)
        self.parts = [sanitize_name(n) for n in probe.parts]
        self.joints = [_as_imported(JointInfo(sanitize_name(j.name), j.kind, j.lower, j.upper))
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


def _as_imported(joint: JointInfo) -> JointInfo:
    """A hinge whose range is empty (a URDF <limit> giving only effort and velocity, its range
    left at 0), as our importers and MuJoCo read it: unlimited (Pinocchio keeps [0, 0]); a
    range with lower > upper (Bullet's "no limit", which Pinocchio keeps and MuJoCo refuses)
    as our importers read it: unlimited."""
    if joint.lower is None or joint.upper is None:
        return joint
    if joint.kind == "revolute" and joint.lower >= joint.upper:
        return JointInfo(joint.name, "continuous", None, None)
    if joint.kind == "prismatic" and joint.lower > joint.upper:
        return JointInfo(joint.name, "prismatic", None, None)
    return joint


def open_source_probes(path: str | Path) -> list[Probe]:
    """Probes of a user's input file as the reference: MJCF in MuJoCo; URDF in MuJoCo (its
    kinematics: MuJoCo reads neither ``package://`` nor Collada) and in Pinocchio; USD in
    Newton (``probes.newton``: its importer and its joint law)."""
    path = Path(path)
    if not path.exists():
        raise CheckError(f"{path}: no such file")
    from ..formats import format_for_path

    try:
        kind = format_for_path(path).name
    except Real2CodeError:
        kind = None
    if kind not in ("urdf", "mjcf", "usd"):
        raise CheckError(f"{path}: a reference must be a URDF, MJCF or USD file, "
                         f"not {path.suffix.lower()!r}")
    if kind == "usd":  # in Newton's own importer, in the engines venv (probes/newton.py)
        from ..dynamics import EngineUnavailable
        from . import newton as newton_probe

        try:
            return [SourceProbe(p) for p in newton_probe.open_probes(path)]
        except EngineUnavailable as e:
            raise CheckError(str(e)) from e
    from . import mujoco as mujoco_probe

    if kind == "mjcf":
        return [SourceProbe(p) for p in mujoco_probe.open_probes(path, source=True)]
    from . import pinocchio as pinocchio_probe

    # A file one tool refuses and the other loads is compared in the one that loads it (a
    # tensor MuJoCo's balanceinertia does not mend; a joint type urdfdom does not know, such
    # as pybullet's "spherical"), said in a warning; both refusing it is an error.
    probes: list[Probe] = []
    refused: list[CheckError] = []
    for opener in (lambda: mujoco_probe.open_probes(path, source=True),
                   lambda: pinocchio_probe.open_probes(path)):
        try:
            probes += opener()
        except CheckError as e:
            refused.append(e)
    if not probes:
        raise refused[0]
    for e in refused:
        kept = " and ".join(p.label for p in probes)
        warnings.warn(f"{e}; the source is compared in {kept} only", Real2CodeWarning,
                      stacklevel=2)
    return [SourceProbe(p) for p in probes]
