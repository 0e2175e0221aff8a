"""The DFKI torque-limited simple pendulum's measured runs (dfki-ric-underactuated-lab,
BSD-3) as calibration CSVs, with a nominal model of the rig built from what its authors
state:

    python bench/convert_dfki_pendulum.py [--data ../shared/data/measured/dfki_pendulum] \\
        --out DIR
    real2code calibrate DIR/object.json --data DIR/pd_system_identification.csv \\
        --holdout DIR/energy_shaping.csv --holdout DIR/ilqr.csv --holdout DIR/sac.csv \\
        --out DIR/calibrated
    real2code calibrate DIR/object.json --data DIR/gravity_compensation.csv --out DIR/hand

Each ``control_method_X.csv`` (``time, position, velocity, torque``) becomes ``X.csv`` with
``time, shoulder, shoulder.effort`` (the motor's current-derived torque, spikes and all: what
to make of them is the calibration's job). The motor's own velocity estimate is left out:
the CSV contract carries positions and efforts. No experiment file is needed: gravity is the
default one, the units are SI.

The authors' own URDF (``simplependul_dfki_pino_Modi.urdf``) is not used as the nominal
model: its inertial is not the rig (twice the stated inertia about the axis; see
docs/calibration.md); the model written here is the rig as the data set's README states it.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _convert import DataError, main_guard, source_folder, write_model, write_run  # noqa: E402

from real2code_export import atomic  # noqa: E402
from real2code_export import transforms as tf  # noqa: E402
from real2code_export.model import (  # noqa: E402
    ArticulatedObject,
    Dynamics,
    Inertial,
    Joint,
    Limits,
    Part,
)

JOINT = "shoulder"
COLUMNS = ("time", "position", "velocity", "torque")
# The rig as its authors describe it (SI units)
BOB_MASS = 0.546  # a point mass ...
BOB_DISTANCE = 0.5  # ... this far from the axis
ROD_MASS = 0.13  # rod and mounts
TOTAL_COM = 0.45  # centre of mass of the whole arm from the axis
ROTOR_INERTIA = 6.07e-5  # AK80-6, before its 6:1 gearing
GEAR_RATIO = 6.0
BOB_RADIUS = 0.02  # not stated: a small bob, its own inertia is small but positive
# The authors' published fit (published_fit.txt): tau = J ddq + m cx g sin q + Fv dq
# + Fc atan(100 dq) + offset
PUBLISHED = {"J": 0.06259, "m_cx": 0.1022, "Fv": 0.04707, "Fc": 0.1839, "offset": -0.07586}


def rod_com() -> float:
    """Where the rod and mounts' centre of mass must be for the stated total one (m)."""
    return ((BOB_MASS + ROD_MASS) * TOTAL_COM - BOB_MASS * BOB_DISTANCE) / ROD_MASS


def stated_rig() -> dict[str, float]:
    """Inertia about the axis (kg m^2, arm and reflected rotor) and first moment m cx
    (kg m) of the rig as stated: what the docs set the fitted values beside."""
    rod_length = 2 * rod_com()  # a uniform rod from the axis out
    arm = (BOB_MASS * (BOB_DISTANCE**2 + 0.4 * BOB_RADIUS**2)
           + ROD_MASS * rod_length**2 / 3.0)
    return {"J": arm + ROTOR_INERTIA * GEAR_RATIO**2,
            "m_cx": BOB_MASS * BOB_DISTANCE + ROD_MASS * rod_com()}


def nominal_model() -> ArticulatedObject:
    """A bob on a rod, hung from a horizontal motor shaft (q = 0 hangs straight down), the
    motor's rotor inertia reflected through its gearing as the joint's armature; no
    friction, no damping."""
    rod_length = 2 * rod_com()
    total = BOB_MASS + ROD_MASS
    com = (BOB_MASS * BOB_DISTANCE + ROD_MASS * rod_com()) / total
    # inertia about the arm's centre of mass (axis y: the hinge axis; x likewise; z along)
    about_com_y = (BOB_MASS * ((BOB_DISTANCE - com) ** 2 + 0.4 * BOB_RADIUS**2)
                   + ROD_MASS * (rod_length**2 / 12.0 + (rod_com() - com) ** 2))
    along = 0.4 * BOB_MASS * BOB_RADIUS**2 + 1e-6
    motor = Part("motor", inertial=Inertial(0.5, [0, 0, 0], np.eye(3) * 1e-3))
    arm = Part("arm", inertial=Inertial(total, [0, 0, -com],
                                        np.diag([about_com_y, about_com_y, along])))
    joint = Joint(JOINT, "revolute", "motor", "arm", origin=tf.make(None, [0, 0, 1.0]),
                  axis=[0.0, 1.0, 0.0], limits=Limits(-4 * math.pi, 4 * math.pi), state=0.0,
                  dynamics=Dynamics(armature=ROTOR_INERTIA * GEAR_RATIO**2))
    return ArticulatedObject("dfki_simple_pendulum", [motor, arm], [joint], metadata={
        "source": "dfki-ric-underactuated-lab/torque_limited_simple_pendulum (stated rig)"})


def read_run(path: Path) -> dict[str, np.ndarray]:
    try:
        with path.open(encoding="utf-8", newline="") as f:
            rows = list(csv.reader(f))
    except (OSError, UnicodeDecodeError) as e:
        raise DataError(path, None, f"cannot read: {e}") from e
    if not rows or [h.strip() for h in rows[0]] != list(COLUMNS):
        raise DataError(path, "header", f"expected {','.join(COLUMNS)}", 1)
    values = np.empty((len(rows) - 1, len(COLUMNS)))
    for i, row in enumerate(rows[1:]):
        if len(row) != len(COLUMNS):
            raise DataError(path, "row", f"has {len(row)} values, expected {len(COLUMNS)}",
                            i + 2)
        try:
            values[i] = [float(x) for x in row]
        except ValueError as e:
            raise DataError(path, "row", f"not a number: {e}", i + 2) from e
    return {name: values[:, k] for k, name in enumerate(COLUMNS)}


def convert(folder: Path, out: Path) -> list[Path]:
    runs = sorted(folder.glob("control_method_*.csv"))
    if not runs:
        raise DataError(folder, None, "no control_method_*.csv files")
    with atomic.staged_output(out) as staging:  # every file or none
        written = [write_model(staging, nominal_model())]
        for path in runs:
            d = read_run(path)
            stem = path.stem.removeprefix("control_method_")
            written.append(write_run(
                staging, stem, d["time"], {JOINT: d["position"], f"{JOINT}.effort": d["torque"]},
                [f"from {path.name} by bench/convert_dfki_pendulum.py (velocity column left out)"]))
    return [out / p.relative_to(staging) for p in written]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", help="folder with control_method_*.csv")
    parser.add_argument("--out", required=True, type=Path)
    args = parser.parse_args()
    for path in convert(source_folder(args.data, "dfki_pendulum"), args.out):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main_guard(main))
