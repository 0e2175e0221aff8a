"""Measured joint trajectories: the CSV contract (docs/design.md), read and checked.

A header row; ``time`` in seconds; one column per measured joint, named as the joint, holding
its position (rad or m); optional ``<joint>.effort`` (applied torque or force). Lines starting
with ``#`` are comments. Every problem is a :class:`FormatError` naming the file, the column
and the line, raised before anything is simulated or written.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..errors import FormatError
from ..model import ArticulatedObject
from .experiment import Experiment, experiment_for
from .features import noise_level, sensor_noise_level
from .feedback import Feedback
from .feedback import controller as feedback_controller

EFFORT_SUFFIX = ".effort"
# Fewer samples than this cannot fit even one effect plus the initial velocity, let alone
# tell two candidates apart.
MIN_SAMPLES = 20

# A closed-loop law (adapters only; a CSV cannot carry one): called once per sample k with
# the simulated positions so far (joint -> array of samples 0..k) and returns the applied
# effort per joint for the interval [t_k, t_k+1).
Controller = Callable[[int, dict[str, np.ndarray]], dict[str, float]]


@dataclass(eq=False)
class Trajectory:
    """One measured run: sample times, positions per joint, efforts where measured.

    ``controller`` (optional) closes the loop in the replay: the effort is then computed
    from the simulated positions, and ``efforts`` holds the measured controller output,
    compared with the simulated one. ``feedback`` declares such a loop as data (the
    experiment file), on the extra ``columns`` it reads (a reference, an added pulse
    train); ``gravity`` (m/s^2, world frame) where the experiment declares it.
    """

    source: str
    time: np.ndarray
    positions: dict[str, np.ndarray]
    efforts: dict[str, np.ndarray] = field(default_factory=dict)
    controller: Controller | None = None
    feedback: dict[str, Feedback] = field(default_factory=dict)
    columns: dict[str, np.ndarray] = field(default_factory=dict)
    gravity: tuple[float, float, float] | None = None
    window: tuple[float | None, float | None] = (None, None)  # the experiment's (s)
    # a piece of a longer run that starts on the previous piece's last sample (multiple
    # shooting: the fit keeps the two joined)
    continues: bool = False
    # joints whose measured effort a digital loop computed each sample from the sampled
    # position and held over the interval (:func:`held_efforts`): replayed as steps
    held: tuple[str, ...] = ()

    def law(self) -> Controller | None:
        """The closed loop the replay runs (None: open loop, the measured effort)."""
        if self.controller is not None:
            return self.controller
        if self.feedback:
            return feedback_controller(self.feedback, self.columns, self.sample_period)
        return None

    def with_encoder_noise(self) -> Trajectory:
        """This run with each declared loop told the noise of the position it reads (its
        own noise level, where not set): the replay applies the clipped command's mean
        under it (feedback.py)."""
        if not any(f.encoder_noise == 0 and j in self.positions
                   for j, f in self.feedback.items()):
            return self
        return replace(self, feedback={
            j: replace(f, encoder_noise=noise_level(self.positions[j]))
            if f.encoder_noise == 0 and j in self.positions else f
            for j, f in self.feedback.items()})

    @property
    def joints(self) -> list[str]:
        return list(self.positions)

    @property
    def n(self) -> int:
        return len(self.time)

    @property
    def duration(self) -> float:
        return float(self.time[-1] - self.time[0])

    @property
    def sample_period(self) -> float:
        return float(np.median(np.diff(self.time)))


def _error(path: Path, element: str | None, message: str, line: int | None = None) -> FormatError:
    return FormatError(path, element, message, line)


def _data_lines(path: Path) -> list[tuple[int, list[str]]]:
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError as e:
        raise _error(path, None, "no such file") from e
    except (OSError, UnicodeDecodeError) as e:
        raise _error(path, None, f"cannot read: {e}") from e
    rows = []
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        rows.append((number, next(csv.reader([stripped]))))
    return rows


def read_csv(path: str | Path, obj: ArticulatedObject,
             experiment: Experiment | None = None) -> Trajectory:
    """Read and check one trajectory CSV against the model ``obj`` (and the experiment
    that declares its columns and units, if any), converted to SI."""
    path = Path(path)
    rows = _data_lines(path)
    if not rows:
        raise _error(path, None, "empty file (expected a header row: time,<joint>,...)")
    header_line, header = rows[0]
    header = [h.strip() for h in header]
    if "time" not in header:
        raise _error(path, "header", f"no 'time' column (columns: {', '.join(header)})",
                     header_line)
    seen: set[str] = set()
    for h in header:
        if h in seen:
            raise _error(path, f"column {h!r}", "appears twice", header_line)
        seen.add(h)
    position_of, effort_of, extra = _columns(path, header, header_line, obj, experiment)
    values = np.empty((len(rows) - 1, len(header)))
    for i, (line, cells) in enumerate(rows[1:]):
        if len(cells) != len(header):
            raise _error(path, "row", f"has {len(cells)} values, the header has {len(header)}",
                         line)
        for c, (name, cell) in enumerate(zip(header, cells, strict=True)):
            try:
                v = float(cell)
            except ValueError as e:
                raise _error(path, f"column {name!r}", f"not a number: {cell.strip()!r}",
                             line) from e
            if not math.isfinite(v):
                raise _error(path, f"column {name!r}", f"value is {cell.strip()} (NaN or "
                             "infinite values cannot be fitted; remove the row)", line)
            values[i, c] = v
    lines = [line for line, _ in rows[1:]]
    n = len(values)
    if n < MIN_SAMPLES:
        raise _error(path, None, f"only {n} samples: at least {MIN_SAMPLES} are needed to fit")
    t = values[:, header.index("time")]
    steps = np.diff(t)
    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        raise _error(path, "column 'time'", f"time does not increase ({t[k]!r} after "
                     f"{t[k - 1]!r})", lines[k])
    col = {h: values[:, i] for i, h in enumerate(header)}
    exp = experiment
    time_scale = exp.time_scale if exp is not None else 1.0

    def position_scale(joint: str) -> float:
        if exp is None:
            return 1.0
        return exp.angle_scale if movable_type(obj, joint) else exp.length_scale

    columns = {}
    feedback = {}
    if exp is not None:
        for joint, jc in exp.joints.items():
            if jc.feedback is None:
                continue
            feedback[joint] = jc.feedback
            # the reference is a position (the joint's unit); the added column a command
            columns[jc.feedback.reference] = col[jc.feedback.reference] * position_scale(joint)
            if jc.feedback.added is not None:
                columns[jc.feedback.added] = col[jc.feedback.added].copy()
    positions = {j: col[c] * position_scale(j) for j, c in position_of.items()}
    efforts = {j: col[c].copy() for j, c in effort_of.items()}
    return Trajectory(
        source=str(path),
        time=t * time_scale,
        positions=positions,
        efforts=efforts,
        feedback=feedback, columns=columns,
        gravity=exp.gravity if exp is not None else None,
        window=(exp.start, exp.end) if exp is not None else (None, None),
        held=held_efforts(positions, efforts),
    )


# the effort's jitter this many times its sensor's: most of it (8/9 of its variance) is a
# loop's reaction to the sampled position (open-loop efforts measure 1.0-1.1, loops 9 and up)
HELD_JITTER = 3.0


def held_efforts(positions: dict[str, np.ndarray], efforts: dict[str, np.ndarray]
                 ) -> tuple[str, ...]:
    """The joints whose measured effort a loop computed from the sampled position: its
    jitter is the encoder's noise turned into command (features.sensor_noise_level), so a
    digital controller set it once a sample and held it over the interval. Replayed linear
    between samples instead, the command's sample-to-sample jitter averages out and the
    joint is driven by a smoother force than it felt (dry friction it dithered is fitted
    high, a drawer's inertia low: the suite's drift cases)."""
    out = []
    for j, x in efforts.items():
        if j not in positions:
            continue
        sensor = sensor_noise_level(x, positions[j])
        if noise_level(x) > HELD_JITTER * sensor:
            out.append(j)
    return tuple(out)


def movable_type(obj: ArticulatedObject, joint: str) -> bool:
    """Whether ``joint`` is angular (its positions in radians, else metres)."""
    return obj.joint(joint).type.angular


def _columns(path: Path, header: list[str], header_line: int, obj: ArticulatedObject,
             experiment: Experiment | None
             ) -> tuple[dict[str, str], dict[str, str], set[str]]:
    """joint -> position column, joint -> effort column, and the other columns the
    experiment names (references, added commands)."""
    movable = {j.name: j for j in obj.movable_joints}
    fixed = {j.name for j in obj.joints if not j.type.movable}
    position_of: dict[str, str] = {}
    effort_of: dict[str, str] = {}
    extra: set[str] = set()
    if experiment is not None:
        exp_path = Path(experiment.source) if experiment.source else path
        for name in experiment.joints:
            if name not in movable:
                known = ", ".join(sorted(movable)) or "none"
                raise FormatError(exp_path, f"joints.{name}", f"names no movable joint of "
                                  f"model {obj.name!r} (its movable joints: {known})")
        for key, column in experiment.referenced():
            if column not in header:
                raise FormatError(exp_path, key, f"column {column!r} is not in {path} "
                                  f"(its columns: {', '.join(header)})")
        for name, jc in experiment.joints.items():
            position_of[name] = jc.position or name
            if jc.effort is not None:
                effort_of[name] = jc.effort
            elif name + EFFORT_SUFFIX in header:
                effort_of[name] = name + EFFORT_SUFFIX
            if jc.feedback is not None:
                extra.add(jc.feedback.reference)
                if jc.feedback.added is not None:
                    extra.add(jc.feedback.added)
    used = set(position_of.values()) | set(effort_of.values()) | extra
    for h in header:
        if h == "time" or h in used:
            continue
        joint = h[: -len(EFFORT_SUFFIX)] if h.endswith(EFFORT_SUFFIX) else h
        if joint in fixed:
            raise _error(path, f"column {h!r}", f"joint {joint!r} of model {obj.name!r} is "
                         "fixed: it has no motion to calibrate", header_line)
        if joint not in movable:
            known = ", ".join(sorted(movable)) or "none"
            raise _error(path, f"column {h!r}", f"names no joint of model {obj.name!r} "
                         f"(its movable joints: {known})", header_line)
        if h.endswith(EFFORT_SUFFIX):
            effort_of.setdefault(joint, h)
        else:
            position_of.setdefault(joint, h)
    for joint, h in effort_of.items():
        if joint not in position_of:
            raise _error(path, f"column {h!r}", f"effort without a position column {joint!r}",
                         header_line)
    for joint, h in position_of.items():
        if h not in header:
            raise _error(path, f"column {h!r}", f"missing: the position of joint {joint!r}",
                         header_line)
    if not position_of:
        raise _error(path, "header", "no joint position column (expected time,<joint>,...)",
                     header_line)
    return position_of, effort_of, extra


def read_all(paths: Sequence[str | Path], obj: ArticulatedObject,
             experiment: Experiment | None = None) -> list[Trajectory]:
    """Read every file (each with its own experiment file beside it, else ``experiment``);
    all must measure the same joints."""
    trajectories = [read_csv(p, obj, experiment_for(p, experiment)) for p in paths]
    if trajectories:
        first = set(trajectories[0].joints)
        for tr in trajectories[1:]:
            if set(tr.joints) != first:
                raise _error(Path(tr.source), "header", f"measures joints {sorted(tr.joints)}, "
                             f"but {trajectories[0].source} measures {sorted(first)}")
    return trajectories


def csv_text(traj: Trajectory, comments: Sequence[str] = ()) -> str:
    """The CSV form of a trajectory (the adapters write real data this way)."""
    cols = ["time"]
    data = [traj.time]
    for j, q in traj.positions.items():
        cols.append(j)
        data.append(q)
        if j in traj.efforts:
            cols.append(j + EFFORT_SUFFIX)
            data.append(traj.efforts[j])
    lines = [f"# {c}" for c in comments]
    lines.append(",".join(cols))
    for row in np.column_stack(data):
        lines.append(",".join(repr(float(v)) for v in row))
    return "\n".join(lines) + "\n"
