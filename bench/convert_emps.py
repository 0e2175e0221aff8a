"""The EMPS benchmark's MATLAB files (Janot, Gautier, Brunot 2019: one prismatic axis in a
position loop, real friction) as calibration CSVs, their experiment files and a nominal
model, for ``real2code calibrate``:

    python bench/convert_emps.py [--data ../shared/data/measured/emps] --out DIR
    real2code calibrate DIR/object.json --data DIR/DATA_EMPS.csv \\
        --holdout DIR/DATA_EMPS_PULSES.csv --out DIR/calibrated

Each file ``X.mat`` becomes ``X.csv`` (``time, carriage`` = the encoder position ``qm``,
``carriage.effort`` = the force on the load ``gtau * vir``, ``reference`` = ``qg``,
``pulse`` = the validation file's ``pulses_N``) and ``X.experiment.toml``, which declares
the loop the data were recorded in (the benchmark's README): u = kv (kp (qg - q) - v) with v
from a 2-tap difference, plus the pulses, saturated at 10 V, force = gtau u. The pulses
enter the command in volts: the recorded ``vir`` minus the law is ``pulses_N`` itself.

Also here: the benchmark's own inverse-model metric (its scripts in Python), used by the
docs and tests to set the calibrated values beside the published figures.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _convert import DataError, main_guard, source_folder, write_model, write_run  # noqa: E402

from real2code_export import atomic  # noqa: E402
from real2code_export import transforms as tf  # noqa: E402
from real2code_export.model import ArticulatedObject, Inertial, Joint, Limits, Part  # noqa: E402

JOINT = "carriage"
SATURATION_V = 10.0
FILES = ("DATA_EMPS.mat", "DATA_EMPS_PULSES.mat")
# The published reference (IDIM-LS on DATA_EMPS.mat): tau = M ddq + Fv dq + Fc sgn(dq) + OF
PUBLISHED = {"M": 95.1089, "Fv": 203.5034, "Fc": 20.3935, "OF": -3.1648}
PUBLISHED_FORCE_ERROR = {"estimation": 4.08, "cross_validation": 5.98}  # percent
NOMINAL_MASS = 50.0  # a designer's guess: the drive's reflected inertia is what is unknown


@dataclass
class EmpsRecord:
    path: Path
    t: np.ndarray
    qm: np.ndarray  # measured position (m)
    qg: np.ndarray  # reference (m)
    vir: np.ndarray  # controller output (V)
    pulses: np.ndarray  # added to the command (zero in the estimation file)
    gtau: float
    kp: float
    kv: float

    @property
    def force(self) -> np.ndarray:
        return self.gtau * self.vir


def read_mat(path: Path) -> EmpsRecord:
    import scipy.io

    try:
        d = scipy.io.loadmat(path)
    except (OSError, ValueError) as e:
        raise DataError(path, None, f"not a MATLAB file: {e}") from e
    for key in ("t", "qm", "qg", "vir", "gtau", "kp", "kv"):
        if key not in d:
            raise DataError(path, key, "missing from the EMPS file")

    def col(key):
        return np.asarray(d[key], float).ravel()

    n = len(col("t"))
    for key in ("qm", "qg", "vir") + (("pulses_N",) if "pulses_N" in d else ()):
        if len(col(key)) != n:
            raise DataError(path, key, f"has {len(col(key))} samples, t has {n}")
    pulses = col("pulses_N") if "pulses_N" in d else np.zeros(n)
    return EmpsRecord(path, col("t"), col("qm"), col("qg"), col("vir"), pulses,
                      float(col("gtau")[0]), float(col("kp")[0]), float(col("kv")[0]))


def experiment(rec: EmpsRecord) -> dict[str, dict]:
    feedback = {"reference": "reference", "kp": rec.kp * rec.kv, "kd": rec.kv,
                "velocity_taps": 2, "saturation": [-SATURATION_V, SATURATION_V],
                "gain": rec.gtau}
    if np.any(rec.pulses):
        feedback["added"] = "pulse"
    return {f"joints.{JOINT}": {"position": JOINT, "effort": f"{JOINT}.effort"},
            f"joints.{JOINT}.feedback": feedback}


def nominal_model(mass: float = NOMINAL_MASS) -> ArticulatedObject:
    """The axis as a designer would first model it: a carriage of a guessed ``mass`` on a
    frictionless horizontal slide (reflected inertia, friction and any bias are what
    calibration is for)."""
    base = Part("base", inertial=Inertial(200.0, [0, 0, 0.05], np.diag([10.0, 10.0, 10.0])))
    x, y, z = 0.3, 0.2, 0.1
    inertia = mass / 12.0 * np.diag([y * y + z * z, x * x + z * z, x * x + y * y])
    carriage = Part("carriage_body", inertial=Inertial(mass, [0, 0, 0], inertia))
    joint = Joint(JOINT, "prismatic", "base", "carriage_body",
                  origin=tf.make(None, [0, 0, 0.15]), axis=[1, 0, 0],
                  limits=Limits(-0.05, 0.35), state=0.0)
    return ArticulatedObject("emps_axis", [base, carriage], [joint],
                             metadata={"source": "EMPS benchmark (Janot, Gautier, Brunot 2019)"})


def convert(folder: Path, out: Path) -> list[Path]:
    with atomic.staged_output(out) as staging:  # every file or none
        written = [write_model(staging, nominal_model())]
        for name in FILES:
            rec = read_mat(folder / name)
            columns = {JOINT: rec.qm, f"{JOINT}.effort": rec.force, "reference": rec.qg}
            if np.any(rec.pulses):
                columns["pulse"] = rec.pulses
            written.append(write_run(staging, Path(name).stem, rec.t - rec.t[0], columns,
                                     [f"from {name} (EMPS benchmark) by bench/convert_emps.py"],
                                     experiment(rec)))
    return [out / p.relative_to(staging) for p in written]


# -- the benchmark's own inverse-model force error (its scripts, in Python) -------------------
def _diffcent(y: np.ndarray, h: float) -> np.ndarray:
    return np.concatenate([[y[1] - y[0]], (y[2:] - y[:-2]) / 2, [y[-1] - y[-2]]]) / h


def relative_force_error(rec: EmpsRecord, mass: float, damping, friction,
                         resistive_offset: float, border: int = 50) -> float:
    """Percent: 4th-order Butterworth at 100 Hz (zero phase), central differences, the first
    ``border`` samples dropped, decimated by 10, as the benchmark publishes it. The model
    tau = M ddq + Fv dq + Fc sgn(dq) + OF (``resistive_offset`` = OF); ``damping`` and
    ``friction`` either one value or (moving forward, moving back) pairs."""
    from scipy.signal import butter, decimate, filtfilt

    h = float(np.median(np.diff(rec.t)))
    b, a = butter(4, 100.0 / (0.5 / h))
    q = filtfilt(b, a, rec.qm)
    dq = _diffcent(q, h)
    ddq = _diffcent(dq, h)
    s = slice(border - 1, None)
    forward = dq > 0
    fv = np.where(forward, *damping) if np.ndim(damping) else damping
    fc = np.where(forward, *friction) if np.ndim(friction) else friction
    predicted = mass * ddq + fv * dq + fc * np.sign(dq) + resistive_offset
    measured = decimate(rec.force[s], 10, ftype="iir", zero_phase=True)
    predicted = decimate(predicted[s], 10, ftype="iir", zero_phase=True)
    return 100.0 * float(np.linalg.norm(measured - predicted) / np.linalg.norm(measured))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", help="folder with DATA_EMPS.mat and DATA_EMPS_PULSES.mat")
    parser.add_argument("--out", required=True, type=Path)
    args = parser.parse_args()
    for path in convert(source_folder(args.data, "emps"), args.out):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main_guard(main))
