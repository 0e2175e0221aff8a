"""The free-swing pendulum rig (jensen-benard/rotary-inverted-pendulum, MIT) as calibration
data: its text files read into trajectories, and a nominal model of the rig built from the
geometry its repository states."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .. import transforms as tf
from ..errors import FormatError
from ..model import ArticulatedObject, Inertial, Joint, Part
from .trajectory import Trajectory, csv_text

JOINT = "pendulum_hinge"
AUTHOR_DAMPING = 0.000464  # N m s/rad, the author's viscous fit (mean of the three runs)

# The rig as its repository's model states it (SI units)
ROD_MASS = 0.01225
ROD_LENGTH = 0.124
ROD_RADIUS = 0.002
HINGE_MASS = 0.00693
HINGE_COM = 0.002  # centre of the hinge piece from the axis
COUPLER_OFFSET = 0.011  # where the rod starts, from the axis


def read_run(path: str | Path, free_only: bool = True) -> Trajectory:
    """One free-swing file: a header line, its values (trigger angle in degrees, sample
    rate in Hz, duration in s), then one angle per line in degrees (0 = hanging down).

    ``free_only``: the run from where it swings free (:func:`free_start`). The pendulum
    is released by hand and the recording starts at the trigger angle, already moving,
    but the hand is still on it for the first half second."""
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as e:
        raise FormatError(path, None, f"cannot read: {e}") from e
    if len(lines) < 3:
        raise FormatError(path, None, "expected a header line, its values and samples")
    try:
        _, rate, _ = (float(x) for x in lines[1].split(","))
    except ValueError as e:
        raise FormatError(path, "header", f"not 'trigger, rate, duration': {lines[1]!r}",
                          2) from e
    angles = []
    for number, line in enumerate(lines[2:], start=3):
        if not line.strip():
            continue
        try:
            angles.append(float(line))
        except ValueError as e:
            raise FormatError(path, "angle", f"not a number: {line.strip()!r}", number) from e
    q = np.radians(np.array(angles))
    t = np.arange(len(q)) / rate
    if free_only:
        k = free_start(q, 1.0 / rate)
        q, t = q[k:], t[k:] - t[k]
    return Trajectory(str(path), t, {JOINT: q})


def turning_points(q: np.ndarray, period: float) -> np.ndarray:
    from .features import derivatives

    _, dq, _ = derivatives(q, period, window=31)
    s = np.sign(dq)
    return np.flatnonzero(s[1:] * s[:-1] < 0) + 1


def free_start(q: np.ndarray, period: float) -> int:
    """Where the swing is free: the second turning point. The energy rises until the
    first (the hand still pushes) and drops by a third within the next half swing (the
    hand brakes on letting go; see :func:`energy`); from the second on it decays
    smoothly."""
    idx = turning_points(q, period)
    return int(idx[1]) if idx.size > 1 else 0


def energy(q: np.ndarray, period: float) -> np.ndarray:
    """Mechanical energy per unit inertia of the nominal rig (J / (kg m^2)): rises while
    something still pushes the pendulum, decays once it swings free."""
    from .features import derivatives

    _, dq, _ = derivatives(q, period, window=31)
    w2 = (2 * math.pi * small_swing_frequency()) ** 2
    return 0.5 * dq**2 - w2 * np.cos(q)


def runs(folder: str | Path) -> list[Path]:
    return sorted(Path(folder).glob("free_swing_*.txt"))


def nominal_model() -> ArticulatedObject:
    """The rig from its stated geometry: a hinge piece (a point-like mass 2 mm off the
    axis) and a solid rod hung from it, starting 11 mm from the axis; the axis is
    horizontal, q = 0 hangs straight down; no friction, no damping."""
    frame = Part("frame", inertial=Inertial(1.0, [0, 0, 0], np.eye(3) * 1e-3))
    # a small sphere-like piece: its own inertia is negligible but must be positive
    r_h = 0.003
    hinge = Part("hinge_piece", inertial=Inertial(HINGE_MASS, [0, 0, -HINGE_COM],
                                                  np.eye(3) * 0.4 * HINGE_MASS * r_h**2))
    along = ROD_MASS * (3 * ROD_RADIUS**2 + ROD_LENGTH**2) / 12.0  # about a transverse axis
    axial = 0.5 * ROD_MASS * ROD_RADIUS**2
    rod = Part("rod", inertial=Inertial(ROD_MASS, [0, 0, -ROD_LENGTH / 2],
                                        np.diag([along, along, axial])))
    joints = [
        Joint(JOINT, "continuous", "frame", "hinge_piece", origin=tf.make(None, [0, 0, 0.3]),
              axis=[1.0, 0.0, 0.0], state=0.0),
        Joint("rod_mount", "fixed", "hinge_piece", "rod",
              origin=tf.make(None, [0, 0, -COUPLER_OFFSET])),
    ]
    return ArticulatedObject("free_swing_pendulum", [frame, hinge, rod], joints,
                             metadata={"source": "jensen-benard/rotary-inverted-pendulum"})


def small_swing_frequency(obj: ArticulatedObject | None = None) -> float:
    """Small-amplitude natural frequency (Hz) of the nominal rig (a check on the model)."""
    m_r, m_h = ROD_MASS, HINGE_MASS
    c_r = COUPLER_OFFSET + ROD_LENGTH / 2
    inertia = (m_r * (3 * ROD_RADIUS**2 + ROD_LENGTH**2) / 12 + m_r * c_r**2
               + m_h * HINGE_COM**2 + 0.4 * m_h * 0.003**2)
    torque = 9.81 * (m_r * c_r + m_h * HINGE_COM)
    return math.sqrt(torque / inertia) / (2 * math.pi)


def write_csv(traj: Trajectory, path: str | Path) -> Path:
    """The run as a trajectory CSV (docs/design.md), for ``real2code calibrate``."""
    from .. import atomic

    return atomic.write_text(path, csv_text(traj, [f"from {Path(traj.source).name}"]))
