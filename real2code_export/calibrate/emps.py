"""The EMPS benchmark (Janot, Gautier, Brunot 2019: an electro-mechanical positioning
system, one prismatic axis in closed loop) as calibration data: the ``.mat`` files read
into trajectories, the known feedback law in the loop, a nominal model of the axis, and the
benchmark's own metrics (inverse-dynamics force error, closed-loop relative errors).

The controller, recovered exactly from the recorded signals: every millisecond
v = kv * (kp * (qg - q) - (q - q[k-2]) / (2 h)) + pulse, saturated at 10 V, and the
force on the carriage is gtau * v; q is the encoder position. (The validation file's
``pulses_N`` enter the voltage: the recorded v minus the law is the pulse train.)
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import transforms as tf
from ..errors import FormatError
from ..model import ArticulatedObject, Inertial, Joint, Limits, Part
from .trajectory import Trajectory

JOINT = "carriage_slide"
SATURATION_V = 10.0

# The published reference (IDIM-LS on DATA_EMPS.mat), tau = M ddq + Fv dq + Fc sgn(dq) + OF
PUBLISHED = {"M": 95.1089, "Fv": 203.5034, "Fc": 20.3935, "OF": -3.1648}
PUBLISHED_ERRORS = {  # percent
    "force_estimation": 4.08, "force_cross_validation": 5.98,
    "closed_loop_position_estimation": 0.0138, "closed_loop_position_validation": 0.0080,
    "closed_loop_force_validation": 5.85,
}


@dataclass
class EmpsRecord:
    path: Path
    t: np.ndarray
    qm: np.ndarray  # measured position (m)
    qg: np.ndarray  # reference (m)
    vir: np.ndarray  # controller output (V)
    pulses: np.ndarray  # added to the voltage (zero in the estimation file)
    gtau: float
    kp: float
    kv: float

    @property
    def force(self) -> np.ndarray:
        return self.gtau * self.vir

    @property
    def period(self) -> float:
        return float(np.median(np.diff(self.t)))


def read_mat(path: str | Path) -> EmpsRecord:
    import scipy.io

    path = Path(path)
    try:
        d = scipy.io.loadmat(path)
    except (OSError, ValueError) as e:
        raise FormatError(path, None, f"not a MATLAB file: {e}") from e
    for key in ("t", "qm", "qg", "vir", "gtau", "kp", "kv"):
        if key not in d:
            raise FormatError(path, key, "missing from the EMPS file")

    def col(key):
        return np.asarray(d[key], float).ravel()

    pulses = col("pulses_N") if "pulses_N" in d else np.zeros_like(col("t"))
    return EmpsRecord(path, col("t"), col("qm"), col("qg"), col("vir"), pulses,
                      float(col("gtau")[0]), float(col("kp")[0]), float(col("kv")[0]))


class Controller:
    """The EMPS position loop, evaluated on the simulated encoder positions."""

    def __init__(self, rec: EmpsRecord):
        self.rec = rec
        self.h = rec.period
        self.force0 = rec.force[:2].copy()  # the loop's history before t = 0 is not recorded

    def __call__(self, k: int, q: dict[str, np.ndarray]) -> dict[str, float]:
        rec = self.rec
        if k < 2:
            return {JOINT: float(self.force0[k])}
        x = q[JOINT]
        v = rec.kv * (rec.kp * (rec.qg[k] - x[k]) - (x[k] - x[k - 2]) / (2 * self.h))
        v = min(max(v + rec.pulses[k], -SATURATION_V), SATURATION_V)
        return {JOINT: rec.gtau * v}


def trajectory(rec: EmpsRecord, closed_loop: bool = True) -> Trajectory:
    """The record as a trajectory: encoder position, force on the carriage, and (closed
    loop) the controller that produced it."""
    return Trajectory(str(rec.path), rec.t.copy(), {JOINT: rec.qm.copy()},
                      {JOINT: rec.force.copy()}, Controller(rec) if closed_loop else None)


def nominal_model(mass: float = 50.0) -> ArticulatedObject:
    """The axis as a designer would first model it: a carriage of a guessed ``mass`` on a
    frictionless horizontal slide (the drive's reflected inertia, the friction and any
    bias are what calibration is for)."""
    base = Part("base", inertial=Inertial(200.0, [0, 0, 0.05], np.diag([10.0, 10.0, 10.0])))
    extent = np.array([0.3, 0.2, 0.1])
    inertia = mass / 12.0 * np.diag([extent[1] ** 2 + extent[2] ** 2,
                                     extent[0] ** 2 + extent[2] ** 2,
                                     extent[0] ** 2 + extent[1] ** 2])
    carriage = Part("carriage", inertial=Inertial(mass, [0, 0, 0], inertia))
    joint = Joint(JOINT, "prismatic", "base", "carriage", origin=tf.make(None, [0, 0, 0.15]),
                  axis=[1, 0, 0], limits=Limits(-0.05, 0.35), state=0.0)
    return ArticulatedObject("emps_axis", [base, carriage], [joint],
                             metadata={"source": "EMPS benchmark (Janot, Gautier, Brunot 2019)"})


# -- the benchmark's metrics ----------------------------------------------------------------
def _diffcent(y: np.ndarray, h: float) -> np.ndarray:
    return np.concatenate([[y[1] - y[0]], (y[2:] - y[:-2]) / 2, [y[-1] - y[-2]]]) / h


@dataclass
class Filtered:
    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    force: np.ndarray


def benchmark_signals(rec: EmpsRecord, border: int = 50) -> Filtered:
    """The benchmark's processing: 4th-order Butterworth at 100 Hz (zero phase), central
    differences, the first ``border`` samples dropped."""
    from scipy.signal import butter, filtfilt

    b, a = butter(4, 100.0 / (0.5 / rec.period))
    q = filtfilt(b, a, rec.qm)
    dq = _diffcent(q, rec.period)
    ddq = _diffcent(dq, rec.period)
    s = slice(border - 1, None)
    return Filtered(q[s], dq[s], ddq[s], rec.force[s])


def decimate(x: np.ndarray, factor: int = 10) -> np.ndarray:
    """MATLAB's ``decimate``: 8th-order Chebyshev I low-pass, zero phase, every factor-th."""
    from scipy.signal import decimate as sp_decimate

    return sp_decimate(x, factor, ftype="iir", zero_phase=True)


def inverse_model_force(f: Filtered, params: dict[str, float]) -> np.ndarray:
    """Force predicted by the inverse dynamic model from measured motion: rigid mass,
    friction (symmetric or direction-dependent) and a constant force; ``params`` in the
    model's terms (mass, damping, friction, offset as an applied force, or the four
    direction-dependent friction values)."""
    pos = f.dq > 0
    if "friction_pos" in params:
        c = np.where(pos, params["friction_pos"], params["friction_neg"])
        b = np.where(pos, params["damping_pos"], params["damping_neg"])
    else:
        c, b = params.get("friction", 0.0), params.get("damping", 0.0)
    return params["mass"] * f.ddq + b * f.dq + c * np.sign(f.dq) - params.get("offset", 0.0)


def relative_force_error(rec: EmpsRecord, params: dict[str, float]) -> float:
    """The benchmark's inverse-model force error (%): decimated by 10, as published."""
    f = benchmark_signals(rec)
    measured = decimate(f.force)
    predicted = decimate(inverse_model_force(f, params))
    return 100.0 * float(np.linalg.norm(measured - predicted) / np.linalg.norm(measured))


def relative_errors(rec: EmpsRecord, q_sim: np.ndarray, force_sim: np.ndarray,
                    border: int = 50) -> dict[str, float]:
    """The benchmark's closed-loop relative errors (%): simulated position against the
    filtered measured position, simulated force against the measured force."""
    f = benchmark_signals(rec, border)
    s = slice(border - 1, None)
    q_s, u_s = q_sim[s], force_sim[s]
    return {"position": 100.0 * float(np.linalg.norm(f.q - q_s) / np.linalg.norm(f.q)),
            "force": 100.0 * float(np.linalg.norm(f.force - u_s) / np.linalg.norm(f.force))}


def published_inverse_fit(rec: EmpsRecord, asymmetric: bool = False) -> dict[str, float]:
    """The benchmark's IDIM-LS (its scripts, in Python): linear least squares of the
    decimated force on the decimated regressors. Model terms, offset as applied force."""
    f = benchmark_signals(rec)
    sgn = np.sign(f.dq)
    if asymmetric:
        pos, neg = (1 + sgn) / 2, (1 - sgn) / 2
        cols = [f.ddq, f.dq * pos, sgn * pos, f.dq * neg, sgn * neg]
        names = ["mass", "damping_pos", "friction_pos", "damping_neg", "friction_neg"]
    else:
        cols = [f.ddq, f.dq, sgn, np.ones_like(f.q)]
        names = ["mass", "damping", "friction", "offset_resistive"]
    x = np.column_stack([decimate(c) for c in cols])
    y = decimate(f.force)
    beta, *_ = np.linalg.lstsq(x, y, rcond=None)
    out = dict(zip(names, beta.tolist(), strict=True))
    if not asymmetric:
        out["offset"] = -out.pop("offset_resistive")
    return out
