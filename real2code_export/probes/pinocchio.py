"""URDF loaded in Pinocchio, posed with ``framesForwardKinematics``.

Pinocchio keeps only movable joints as joints (fixed-joint links become frames) and orders
them depth first, so joints are addressed by name (``getJointId``/``idx_q``) and parts by
their BODY frame. A continuous joint has two coordinates (cos, sin).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..errors import CheckError, NameNotFoundError
from . import JointInfo
from ._stdio import captured_c_output

LABEL = "Pinocchio (URDF)"
_CONTINUOUS = {"JointModelRUBX", "JointModelRUBY", "JointModelRUBZ",
               "JointModelRevoluteUnboundedUnaligned"}
_PRISMATIC = {"JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned"}
_REVOLUTE = {"JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned"}


class PinocchioProbe:
    label = LABEL

    def __init__(self, path: Path, model):
        import pinocchio as pin

        self._pin = pin
        self.path = path
        self.model = model
        self._data = model.createData()
        self._neutral = pin.neutral(model)  # free / spherical / planar joints stay here

        self.joints: list[JointInfo] = []
        scalar_cols, scalar_idx, cont_cols, cont_idx = [], [], [], []
        for jid in range(1, model.njoints):
            jm = model.joints[jid]
            kind_name = jm.shortname()
            name = model.names[jid]
            lo = float(model.lowerPositionLimit[jm.idx_q])
            hi = float(model.upperPositionLimit[jm.idx_q])
            if kind_name in _CONTINUOUS:
                self.joints.append(JointInfo(name, "continuous", None, None))
                cont_cols.append(len(self.joints) - 1)
                cont_idx.append(jm.idx_q)
            elif kind_name == "JointModelPlanar":  # q = (x, y, cos, sin): as MuJoCo's
                # import names it and the URDF reader reads it, two slides and a hinge
                for suffix, kind in (("TX", "prismatic"), ("TY", "prismatic")):
                    self.joints.append(JointInfo(f"{name}_{suffix}", kind, None, None))
                    scalar_cols.append(len(self.joints) - 1)
                    scalar_idx.append(jm.idx_q + (suffix == "TY"))
                self.joints.append(JointInfo(f"{name}_RZ", "continuous", None, None))
                cont_cols.append(len(self.joints) - 1)
                cont_idx.append(jm.idx_q + 2)
            elif kind_name in _REVOLUTE or kind_name in _PRISMATIC:
                kind = "revolute" if kind_name in _REVOLUTE else "prismatic"
                self.joints.append(JointInfo(name, kind, lo, hi))
                scalar_cols.append(len(self.joints) - 1)
                scalar_idx.append(jm.idx_q)
        self._scalar_cols = np.array(scalar_cols, dtype=np.int64)
        self._scalar_idx = np.array(scalar_idx, dtype=np.int64)
        self._cont_cols = np.array(cont_cols, dtype=np.int64)
        self._cont_idx = np.array(cont_idx, dtype=np.int64)
        self._column = {info.name: k for k, info in enumerate(self.joints)}

        # Every link is a BODY frame (fixed-joint links included), in URDF declaration order.
        frames = [(i, f.name) for i, f in enumerate(model.frames) if f.type == pin.FrameType.BODY]
        self._frame_ids = [i for i, _ in frames]
        self.parts = [name for _, name in frames]

    def pose_array(self, values: np.ndarray) -> np.ndarray:
        """(N, len(joints)) joint values in the order of ``joints`` -> (N, len(parts), 4, 4)."""
        values = np.atleast_2d(np.asarray(values, dtype=np.float64))
        n = len(values)
        qs = np.tile(self._neutral, (n, 1))
        qs[:, self._scalar_idx] = values[:, self._scalar_cols]
        angles = values[:, self._cont_cols]
        qs[:, self._cont_idx] = np.cos(angles)
        qs[:, self._cont_idx + 1] = np.sin(angles)

        pin, model, data, fids = self._pin, self.model, self._data, self._frame_ids
        out = np.empty((n, len(fids), 4, 4))
        for i in range(n):
            pin.framesForwardKinematics(model, data, qs[i])
            o_m_f = data.oMf
            for k, fid in enumerate(fids):
                out[i, k] = o_m_f[fid].homogeneous
        return out

    def poses(self, q: dict[str, float]) -> dict[str, np.ndarray]:
        values = np.zeros(len(self.joints))
        for name, value in q.items():
            if name not in self._column:
                raise NameNotFoundError(f"{self.path}: no movable joint named {name!r} in Pinocchio's model")
            values[self._column[name]] = value
        return dict(zip(self.parts, self.pose_array(values)[0], strict=True))


# Pinocchio's Data grows as the cube of the degrees of freedom (pinocchio 4.1, measured: 0.07 GB
# at 100, 0.5 GB at 200, 4 GB at 400; a flex's 1153 vertex slides asked for more than 21 GB):
# a file with more is not loaded in Pinocchio, and says so.
MAX_DOFS = 200


class TooManyDofs(CheckError):
    """A model whose Pinocchio data would not fit (:data:`MAX_DOFS`)."""


def build_model(path: Path):
    import pinocchio as pin

    from ..formats.urdf.xacro_file import document, is_xacro

    with captured_c_output() as printed:
        try:
            if is_xacro(path):  # the URDF it expands to (urdfdom reads no xacro)
                model = pin.buildModelFromXML(document(path).decode("utf-8"))
            else:
                model = pin.buildModelFromUrdf(str(path))
            error = None
        except (ValueError, RuntimeError) as e:
            model, error = None, e
    # urdfdom says why on stderr ("limit has no effort"); its "at line N in parser.cpp"
    # lines are about its own source, not the file.
    said = [line for line in printed.lines() if not line.startswith("at line")]
    if error is not None:
        detail = f" ({'; '.join(said)})" if said else ""
        raise CheckError(f"{path}: Pinocchio refused it: {error}{detail}") from error
    if said:
        warnings.warn(f"{path}: Pinocchio: {'; '.join(said)}", stacklevel=3)
    if model.nv > MAX_DOFS:
        raise TooManyDofs(f"{path}: not loaded in Pinocchio: {model.nv} degrees of freedom, "
                          f"whose data would take about {64e-9 * model.nv ** 3:.0f} GB "
                          f"(it grows as their cube; {MAX_DOFS} at most here)")
    return model


def open_probes(path: str | Path) -> list[PinocchioProbe]:
    """The file in Pinocchio; none, with a warning, when its data would not fit
    (:data:`MAX_DOFS`): MuJoCo's probe of the same file still checks it."""
    path = Path(path)
    try:
        model = build_model(path)
    except TooManyDofs as e:
        warnings.warn(str(e), stacklevel=2)
        return []
    return [PinocchioProbe(path, model)]
