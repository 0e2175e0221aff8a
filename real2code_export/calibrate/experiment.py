"""The experiment file: what a measured run needs to be replayed, declared beside the CSV
(``<csv stem>.experiment.toml``) or given once with ``--experiment`` (docs/
calibration_contract.md): the CSV's units, the gravity, the window of the record to use,
which column holds each joint's position and measured effort, and a closed loop's feedback
law. Every key is optional; an unknown key, a wrong type or a bad value is a
:class:`FormatError` naming the file and the key.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import FormatError
from .feedback import Feedback

SUFFIX = ".experiment.toml"
TIME_UNITS = {"s": 1.0, "ms": 1e-3}
ANGLE_UNITS = {"rad": 1.0, "deg": math.pi / 180.0}
LENGTH_UNITS = {"m": 1.0, "mm": 1e-3}
DEFAULT_GRAVITY = (0.0, 0.0, -9.81)


@dataclass(frozen=True)
class JointColumns:
    position: str | None = None  # default: the joint's name
    effort: str | None = None  # default: "<joint>.effort" when the CSV has it
    feedback: Feedback | None = None


@dataclass(frozen=True)
class Experiment:
    source: str | None = None  # the file (None: the defaults)
    time_scale: float = 1.0  # to seconds
    angle_scale: float = 1.0  # to radians
    length_scale: float = 1.0  # to metres
    gravity: tuple[float, float, float] | None = None  # None: not declared (the default)
    start: float | None = None  # s, in the CSV's time
    end: float | None = None
    joints: dict[str, JointColumns] = field(default_factory=dict)

    def referenced(self) -> list[tuple[str, str]]:
        """(key, column) of every column this experiment names."""
        out = []
        for name, jc in self.joints.items():
            base = f"joints.{name}"
            if jc.position is not None:
                out.append((f"{base}.position", jc.position))
            if jc.effort is not None:
                out.append((f"{base}.effort", jc.effort))
            if jc.feedback is not None:
                out.append((f"{base}.feedback.reference", jc.feedback.reference))
                if jc.feedback.added is not None:
                    out.append((f"{base}.feedback.added", jc.feedback.added))
        return out


def _err(path: Path, key: str | None, message: str) -> FormatError:
    return FormatError(path, key, message)


def _table(path: Path, data: dict, key: str, allowed: set[str]) -> dict:
    value = data.get(key, {})
    if not isinstance(value, dict):
        raise _err(path, key, f"must be a table, not {type(value).__name__}")
    for k in value:
        if k not in allowed:
            raise _err(path, f"{key}.{k}", f"unknown key (expected one of: "
                       f"{', '.join(sorted(allowed))})")
    return value


def _number(path: Path, key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or \
            not math.isfinite(value):
        raise _err(path, key, f"must be a finite number, not {value!r}")
    return float(value)


def _string(path: Path, key: str, value: Any) -> str:
    if not isinstance(value, str) or not value.strip():
        raise _err(path, key, f"must be a column name (a non-empty string), not {value!r}")
    return value.strip()


def _unit(path: Path, key: str, value: Any, units: dict[str, float]) -> float:
    if value not in units:
        raise _err(path, key, f"unknown unit {value!r} (expected one of: "
                   f"{', '.join(units)})")
    return units[value]


def _feedback(path: Path, key: str, table: Any) -> Feedback:
    allowed = {"reference", "kp", "kd", "velocity_taps", "added", "saturation", "gain"}
    if not isinstance(table, dict):
        raise _err(path, key, "must be a table")
    for k in table:
        if k not in allowed:
            raise _err(path, f"{key}.{k}", f"unknown key (expected one of: "
                       f"{', '.join(sorted(allowed))})")
    if "reference" not in table:
        raise _err(path, f"{key}.reference", "missing: a feedback law needs the column of "
                   "its reference position")
    taps = table.get("velocity_taps", 1)
    if isinstance(taps, bool) or not isinstance(taps, int) or taps < 1:
        raise _err(path, f"{key}.velocity_taps", f"must be a whole number >= 1, not {taps!r}")
    sat = table.get("saturation")
    if sat is not None:
        if not isinstance(sat, list) or len(sat) != 2:
            raise _err(path, f"{key}.saturation", f"must be [low, high], not {sat!r}")
        lo, hi = (_number(path, f"{key}.saturation", v) for v in sat)
        if lo >= hi:
            raise _err(path, f"{key}.saturation", f"low {lo} is not below high {hi}")
        sat = (lo, hi)
    added = table.get("added")
    return Feedback(
        reference=_string(path, f"{key}.reference", table["reference"]),
        kp=_number(path, f"{key}.kp", table.get("kp", 0.0)),
        kd=_number(path, f"{key}.kd", table.get("kd", 0.0)),
        velocity_taps=taps,
        added=_string(path, f"{key}.added", added) if added is not None else None,
        saturation=sat,
        gain=_number(path, f"{key}.gain", table.get("gain", 1.0)),
    )


def read_experiment(path: str | Path) -> Experiment:
    """Parse and check an experiment file (its columns are checked against each CSV when
    the CSV is read)."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError as e:
        raise _err(path, None, "no such file") from e
    except (OSError, UnicodeDecodeError) as e:
        raise _err(path, None, f"cannot read: {e}") from e
    except tomllib.TOMLDecodeError as e:
        raise _err(path, None, f"not valid TOML: {e}") from e
    for k in data:
        if k not in ("units", "world", "window", "joints"):
            raise _err(path, k, "unknown key (expected one of: joints, units, window, world)")
    units = _table(path, data, "units", {"time", "angle", "length"})
    world = _table(path, data, "world", {"gravity"})
    win = _table(path, data, "window", {"start", "end"})
    gravity = None
    if "gravity" in world:
        g = world["gravity"]
        if not isinstance(g, list) or len(g) != 3:
            raise _err(path, "world.gravity", f"must be [x, y, z] in m/s^2, not {g!r}")
        gravity = tuple(_number(path, "world.gravity", v) for v in g)
    start = _number(path, "window.start", win["start"]) if "start" in win else None
    end = _number(path, "window.end", win["end"]) if "end" in win else None
    if start is not None and end is not None and end <= start:
        raise _err(path, "window.end", f"{end} is not after window.start {start}")
    joints_table = data.get("joints", {})
    if not isinstance(joints_table, dict):
        raise _err(path, "joints", "must be a table of joint tables")
    joints = {}
    for name, table in joints_table.items():
        key = f"joints.{name}"
        if not isinstance(table, dict):
            raise _err(path, key, "must be a table")
        for k in table:
            if k not in ("position", "effort", "feedback"):
                raise _err(path, f"{key}.{k}", "unknown key (expected one of: effort, "
                           "feedback, position)")
        joints[name] = JointColumns(
            position=_string(path, f"{key}.position", table["position"])
            if "position" in table else None,
            effort=_string(path, f"{key}.effort", table["effort"])
            if "effort" in table else None,
            feedback=_feedback(path, f"{key}.feedback", table["feedback"])
            if "feedback" in table else None)
    return Experiment(
        source=str(path),
        time_scale=_unit(path, "units.time", units.get("time", "s"), TIME_UNITS),
        angle_scale=_unit(path, "units.angle", units.get("angle", "rad"), ANGLE_UNITS),
        length_scale=_unit(path, "units.length", units.get("length", "m"), LENGTH_UNITS),
        gravity=gravity, start=start, end=end, joints=joints)


def beside(csv: str | Path) -> Path:
    """Where a CSV's own experiment file would be."""
    csv = Path(csv)
    return csv.with_name(csv.stem + SUFFIX)


def experiment_for(csv: str | Path, given: Experiment | None) -> Experiment | None:
    """The CSV's own experiment file if it has one, else the one given for every run."""
    own = beside(csv)
    if own.is_file():
        return read_experiment(own)
    return given
