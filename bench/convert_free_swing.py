"""The free-swing pendulum runs (jensen-benard/rotary-inverted-pendulum, MIT) as calibration
CSVs, whole files as recorded (the hand that lets the pendulum go is in the first half
second: finding it is the calibration's job), with a nominal model of the rig built from
the geometry its repository states:

    python bench/convert_free_swing.py [--data ../shared/data/measured/pendulum_free_swing] \\
        --out DIR
    real2code calibrate DIR/object.json --data DIR/free_swing_01.csv \\
        --data DIR/free_swing_02.csv --holdout DIR/free_swing_03.csv --out DIR/calibrated

A run file: a header line ``trigger_start_deg, sample_rate, duration_sec``, its values, then
one angle per line in degrees (0 = hanging down). The CSV holds ``time, pendulum_hinge`` in
seconds and radians (no experiment file is needed: the gravity is the default one).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _convert import DataError, main_guard, source_folder, write_model, write_run  # noqa: E402

from real2code_export import atomic  # noqa: E402
from real2code_export import transforms as tf  # noqa: E402
from real2code_export.model import ArticulatedObject, Inertial, Joint, Part  # noqa: E402

JOINT = "pendulum_hinge"
AUTHOR_DAMPING = 0.000464  # N m s/rad, the author's viscous fit (mean of the three runs)

# The rig as its repository's model states it (SI units)
ROD_MASS = 0.01225
ROD_LENGTH = 0.124
ROD_RADIUS = 0.002
HINGE_MASS = 0.00693
HINGE_COM = 0.002  # centre of the hinge piece from the axis
HINGE_RADIUS = 0.003  # not stated: a small piece, its own inertia negligible but positive
COUPLER_OFFSET = 0.011  # where the rod starts, from the axis


def read_run(path: Path) -> tuple[np.ndarray, np.ndarray, float]:
    """Times (s), angles (rad) and the trigger angle (deg) of one run file."""
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as e:
        raise DataError(path, None, f"cannot read: {e}") from e
    if len(lines) < 3:
        raise DataError(path, None, "expected a header line, its values and samples")
    try:
        trigger, rate, _ = (float(x) for x in lines[1].split(","))
    except ValueError as e:
        raise DataError(path, "header", f"not 'trigger, rate, duration': {lines[1]!r}",
                        2) from e
    if not rate > 0:
        raise DataError(path, "sample_rate", f"must be positive, not {rate:g}", 2)
    angles = []
    for number, line in enumerate(lines[2:], start=3):
        if not line.strip():
            continue
        try:
            angles.append(float(line))
        except ValueError as e:
            raise DataError(path, "angle", f"not a number: {line.strip()!r}", number) from e
    q = np.radians(np.array(angles))
    return np.arange(len(q)) / rate, q, trigger


def nominal_model() -> ArticulatedObject:
    """The rig from its stated geometry: a hinge piece (a small mass 2 mm off the axis) and a
    solid rod hung from it, starting 11 mm from the axis; the axis horizontal, q = 0 hangs
    straight down; no friction, no damping."""
    frame = Part("frame", inertial=Inertial(1.0, [0, 0, 0], np.eye(3) * 1e-3))
    hinge = Part("hinge_piece", inertial=Inertial(
        HINGE_MASS, [0, 0, -HINGE_COM], np.eye(3) * 0.4 * HINGE_MASS * HINGE_RADIUS**2))
    across = ROD_MASS * (3 * ROD_RADIUS**2 + ROD_LENGTH**2) / 12.0
    along = 0.5 * ROD_MASS * ROD_RADIUS**2
    rod = Part("rod", inertial=Inertial(ROD_MASS, [0, 0, -ROD_LENGTH / 2],
                                        np.diag([across, across, along])))
    joints = [
        Joint(JOINT, "continuous", "frame", "hinge_piece", origin=tf.make(None, [0, 0, 0.3]),
              axis=[1.0, 0.0, 0.0], state=0.0),
        Joint("rod_mount", "fixed", "hinge_piece", "rod",
              origin=tf.make(None, [0, 0, -COUPLER_OFFSET])),
    ]
    return ArticulatedObject("free_swing_pendulum", [frame, hinge, rod], joints,
                             metadata={"source": "jensen-benard/rotary-inverted-pendulum"})


def inertia_about_axis() -> float:
    """kg m^2, of the stated rig (docs: set beside what the decay implies)."""
    c_rod = COUPLER_OFFSET + ROD_LENGTH / 2
    return (ROD_MASS * (3 * ROD_RADIUS**2 + ROD_LENGTH**2) / 12 + ROD_MASS * c_rod**2
            + HINGE_MASS * HINGE_COM**2 + 0.4 * HINGE_MASS * HINGE_RADIUS**2)


def small_swing_frequency() -> float:
    """Hz, of the stated rig."""
    torque = 9.81 * (ROD_MASS * (COUPLER_OFFSET + ROD_LENGTH / 2) + HINGE_MASS * HINGE_COM)
    return math.sqrt(torque / inertia_about_axis()) / (2 * math.pi)


def convert(folder: Path, out: Path) -> list[Path]:
    runs = sorted(folder.glob("free_swing_*.txt"))
    if not runs:
        raise DataError(folder, None, "no free_swing_*.txt files")
    with atomic.staged_output(out) as staging:  # every file or none
        written = [write_model(staging, nominal_model())]
        for path in runs:
            t, q, trigger = read_run(path)
            written.append(write_run(staging, path.stem, t, {JOINT: q}, [
                f"from {path.name} (trigger {trigger:g} deg) by bench/convert_free_swing.py"]))
    return [out / p.relative_to(staging) for p in written]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", help="folder with free_swing_*.txt")
    parser.add_argument("--out", required=True, type=Path)
    args = parser.parse_args()
    for path in convert(source_folder(args.data, "pendulum_free_swing"), args.out):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main_guard(main))
