"""``real2code simulate``: every experiment in every engine, each engine from the file it
reads natively (written by our exporters), every joint's trajectory compared with MuJoCo's
from the MJCF (the reference); the contact experiments judged on their outcome in every
engine that simulates contacts, MuJoCo included (contacts.py).

Where joints meet their limits (``Experiment.stops``), MuJoCo at the step is also compared
with the motion the file describes: MuJoCo at 1/REFINE of the step, its stops as stiff as
that step takes. Engines whose stops act in the step that would cross a limit (PhysX,
Pinocchio, SAPIEN) and those whose act once a joint is at or past it (MuJoCo, Bullet)
differ at 1 ms by more than the tolerance on a stop hit at speed, and there the reference
is as often the inaccurate one (docs/engines.md, "Which motion is right"). So each joint
has one reference: MuJoCo at the step where it is within tolerance of the converged motion
(less that motion's own uncertainty), the converged motion where it is not. An engine is
never passed by being near either of two motions that are far apart."""

from __future__ import annotations

import importlib
import math
import tempfile
import time
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..formats import load, write_formats
from . import EngineUnavailable, Experiment, Trajectory
from .contacts import CONTACT_EXPERIMENTS, Judge
from .experiments import EXPERIMENTS
from .overlap import Overlap, RangeOverlap, overlaps, overlaps_along_ranges
from .venv import Outcome, simulate_each

TOL_ANGLE = 0.01  # rad
TOL_DISTANCE = 0.001  # m
# The converged motion's step, a fraction of the experiment's. A stop that acts once a joint
# is at or past it (MuJoCo's) converges only as the square root of the step (the depth the
# crossing step leaves, and the time gravity takes to pull the joint back out of it): at
# 1/64 the older demo's flap, hitting its stop at 7 rad/s, is 1.4e-3 rad from Pinocchio's
# look-ahead stop at the same step (which converges linearly), MuJoCo at 1 ms 1.9e-2.
REFINE = 64
# The converged motion's own uncertainty: its difference from the run at 1/CHECK_REFINE of
# the step (a quarter of the cost; at the square root's rate about twice its error).
CHECK_REFINE = 16


@dataclass(frozen=True)
class Engine:
    name: str  # on the command line
    label: str
    format: str  # the export format it reads natively
    module: str
    contacts: bool = True  # simulates the contact experiments

    def simulate(self, path: Path, experiment: Experiment) -> Trajectory:
        return importlib.import_module(self.module).simulate(path, experiment)


REFERENCE = Engine("mujoco", "MuJoCo (MJCF)", "mjcf", "real2code_export.dynamics.mujoco")
ENGINES: dict[str, Engine] = {e.name: e for e in (
    REFERENCE,
    Engine("mujoco-urdf", "MuJoCo (URDF)", "urdf", "real2code_export.dynamics.mujoco"),
    Engine("pinocchio", "Pinocchio (URDF)", "urdf", "real2code_export.dynamics.pinocchio",
           contacts=False),
    Engine("bullet", "Bullet (URDF)", "urdf", "real2code_export.dynamics.bullet",
           contacts=False),
    Engine("sapien", "SAPIEN (URDF)", "urdf", "real2code_export.dynamics.sapien",
           contacts=False),
    Engine("physx", "PhysX (USD)", "usd", "real2code_export.dynamics.physx"),
    Engine("newton-usd", "Newton (USD)", "usd", "real2code_export.dynamics.newton"),
    Engine("newton-mjcf", "Newton (MJCF)", "mjcf", "real2code_export.dynamics.newton"),
    Engine("newton-urdf", "Newton (URDF)", "urdf", "real2code_export.dynamics.newton"),
    Engine("newton-featherstone", "Newton Featherstone (USD)", "usd",
           "real2code_export.dynamics.newton_featherstone", contacts=False),
    Engine("genesis-urdf", "Genesis (URDF)", "urdf", "real2code_export.dynamics.genesis"),
    Engine("genesis-mjcf", "Genesis (MJCF)", "mjcf", "real2code_export.dynamics.genesis"),
)}


@dataclass
class Run:
    """One engine in one experiment, compared with the reference."""

    experiment: str
    engine: str
    file: str
    status: str  # "ok" | "disagree" | "skipped" | "failed" | "reference"
    message: str = ""
    max_angle: float = 0.0  # rad, worst angular joint
    max_distance: float = 0.0  # m, worst linear joint
    worst_joint: str | None = None
    per_joint: dict[str, float] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    seconds: float = 0.0  # the engine's wall time: loading, stepping (and its subprocess)
    # max |q - q_converged| (rad, m), where the converged motion was needed (the reference's
    # row: MuJoCo at the step against it)
    converged: tuple[float, float] | None = None


@dataclass
class DynamicsReport:
    source: str
    experiments: list[Experiment]
    runs: list[Run]
    tol_angle: float
    tol_distance: float
    # collision pieces of two parts overlapping at q = 0 (part of ``ok``: every engine would
    # push them apart, and a URDF cannot exclude the pair)
    overlaps: list[Overlap] = field(default_factory=list)
    # a joint's child against its parent somewhere along its range (reported)
    range_overlaps: list[RangeOverlap] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)  # what an experiment could not include

    @property
    def ok(self) -> bool:
        return not self.overlaps and \
            all(r.status in ("ok", "skipped", "reference") for r in self.runs)

    def to_json(self) -> dict[str, Any]:
        return {
            "source": self.source,
            "tolerance": {"angle": self.tol_angle, "distance": self.tol_distance},
            "experiments": [e.to_json() for e in self.experiments],
            "runs": [{
                "experiment": r.experiment, "engine": r.engine, "file": r.file,
                "status": r.status, "message": r.message, "max_angle": r.max_angle,
                "max_distance": r.max_distance, "worst_joint": r.worst_joint,
                "per_joint": r.per_joint, "notes": r.notes, "seconds": r.seconds,
                "against_converged": None if r.converged is None else
                {"angle": r.converged[0], "distance": r.converged[1]},
            } for r in self.runs],
            "overlaps_at_zero": [{"parts": [o.part_a, o.part_b], "depth": o.depth}
                                 for o in self.overlaps],
            "overlaps_along_ranges": [{"joint": o.joint, "value": o.value,
                                       "parts": [o.part_a, o.part_b], "depth": o.depth}
                                      for o in self.range_overlaps],
            "notes": self.notes,
            "ok": self.ok,
        }


def compare(experiment: Experiment, reference: Trajectory, other: Trajectory
            ) -> tuple[dict[str, float], float, float]:
    """Per joint max |q - q_ref| over the run; the worst angular and linear errors."""
    if other.q.shape != reference.q.shape:
        raise ValueError(f"{other.q.shape[0]} samples of {other.q.shape[1]} joints, "
                         f"the reference has {reference.q.shape}")
    errors = np.abs(other.q - reference.q).max(axis=0) if len(reference.q) else \
        np.zeros(len(experiment.joints))
    errors = np.where(np.isfinite(errors), errors, math.inf)
    per_joint = {n: float(e) for n, e in zip(experiment.joints, errors, strict=True)}
    angular = [e for e, a in zip(errors, experiment.angular, strict=True) if a]
    linear = [e for e, a in zip(errors, experiment.angular, strict=True) if not a]
    return per_joint, float(max(angular, default=0.0)), float(max(linear, default=0.0))


def simulate_file(source: str | Path, engines: list[str] | None = None,
                  experiments: list[str] | None = None, tol_angle: float = TOL_ANGLE,
                  tol_distance: float = TOL_DISTANCE, faithful_collision: bool = False
                  ) -> DynamicsReport:
    obj = load(source, faithful_collision=faithful_collision)
    chosen = [ENGINES[n] for n in (engines or list(ENGINES)) if n != REFERENCE.name]
    formats = sorted({REFERENCE.format, *(e.format for e in chosen)})
    report = DynamicsReport(str(source), [], [], tol_angle, tol_distance)
    if any(part.collision for part in obj.parts):
        with tempfile.TemporaryDirectory(prefix="real2code-simulate-") as folder:
            mjcf = write_formats(obj, folder, ["mjcf"])["mjcf"]
            report.overlaps = overlaps(mjcf)
            report.range_overlaps = overlaps_along_ranges(mjcf, obj)
    with tempfile.TemporaryDirectory(prefix="real2code-simulate-") as folder:
        planned = _plan(report, obj, experiments or [*EXPERIMENTS, *CONTACT_EXPERIMENTS],
                        Path(folder), formats)
        results = _simulate_all([REFERENCE, *chosen], planned)
        for experiment, files, judge in planned:
            if judge is None:
                _motion_runs(report, experiment, files, chosen, results)
            else:
                _contact_runs(report, experiment, files, judge, chosen, results)
    return report


# (experiment, its files by format, the contact experiment's judge or None)
Planned = tuple[Experiment, dict[str, Path], Judge | None]


def _plan(report: DynamicsReport, obj, names: list[str], folder: Path, formats: list[str]
          ) -> list[Planned]:
    """Each experiment's variant written in every format the engines read."""
    planned: list[Planned] = []
    for name in dict.fromkeys(names):
        judge = None
        if name in CONTACT_EXPERIMENTS:
            if not any(part.collision for part in obj.parts):
                report.notes.append(f"{name}: no collision geometry, nothing to collide")
                continue
            variant, experiment, judge, notes = CONTACT_EXPERIMENTS[name](obj)
            report.notes += [f"{name}: {n}" for n in notes]
            if experiment is None:
                continue
        else:
            variant, experiment = EXPERIMENTS[name](obj)
            if not experiment.joints:
                continue
        report.experiments.append(experiment)
        planned.append((experiment, write_formats(variant, folder / name, formats), judge))
    return planned


def _simulate_all(engines: list[Engine], planned: list[Planned]
                  ) -> dict[tuple[str, str], Outcome]:
    """Every engine's runs, those of engines sharing a module in one call (one process for
    an engine in its own venv), by (engine name, experiment name)."""
    groups: dict[str, list[tuple[Engine, Experiment, Path]]] = defaultdict(list)
    for experiment, files, judge in planned:
        for engine in engines:
            if judge is None or engine.contacts:
                groups[engine.module].append((engine, experiment, files[engine.format]))
    results: dict[tuple[str, str], Outcome] = {}
    for module, cases in groups.items():
        imported = importlib.import_module(module)
        many = getattr(imported, "simulate_many", None)
        runs = [(path, experiment) for _, experiment, path in cases]
        try:
            outcomes = many(runs) if many else simulate_each(imported.simulate, runs)
        except (EngineUnavailable, RuntimeError) as e:  # absent, or its process failed
            outcomes = [(e, 0.0)] * len(cases)
        for (engine, experiment, _), outcome in zip(cases, outcomes, strict=True):
            results[engine.name, experiment.name] = outcome
    return results


def _motion_runs(report: DynamicsReport, experiment: Experiment, files: dict[str, Path],
                 chosen: list[Engine], results: dict[tuple[str, str], Outcome]) -> None:
    """Every chosen engine against MuJoCo at the step, and where one is beyond tolerance,
    every one against the converged motion too."""
    mjcf = files[REFERENCE.format]
    reference, seconds = results[REFERENCE.name, experiment.name]
    if isinstance(reference, Exception):
        raise reference
    reference_run = Run(experiment.name, REFERENCE.label, mjcf.name, "reference",
                        seconds=seconds)
    runs = [_run(engine, files[engine.format], experiment, reference,
                 results[engine.name, experiment.name], report.tol_angle, report.tol_distance)
            for engine in chosen]
    if experiment.stops:
        _judge_by_converged(report, mjcf, experiment, reference_run, reference, runs)
    report.runs += [reference_run, *(run for run, _ in runs)]


def _tolerances(experiment: Experiment, tol_angle: float, tol_distance: float) -> np.ndarray:
    return np.array([tol_angle if a else tol_distance for a in experiment.angular])


def _judge_by_converged(report: DynamicsReport, mjcf: Path, experiment: Experiment,
                        reference_run: Run, reference: Trajectory,
                        runs: list[tuple[Run, Trajectory | None]]) -> None:
    """Every run judged, joint by joint, against one reference: MuJoCo at the step where it
    has converged (within tolerance of the converged motion by more than that motion's own
    uncertainty, its difference from its run at 1/CHECK_REFINE step), else the converged
    motion, which a run must then be within tolerance of by more than its uncertainty.
    Where that uncertainty is the tolerance or more the converged motion decides nothing (a
    joint grazing its stop, touching it or not deciding its next swing) and MuJoCo at the
    step stays the reference."""
    converged = importlib.import_module(REFERENCE.module).simulate_converged
    start = time.perf_counter()
    motion = converged(mjcf, experiment, REFINE)
    uncertainty = np.abs(converged(mjcf, experiment, CHECK_REFINE).q - motion.q).max(axis=0)
    reference_run.seconds += time.perf_counter() - start
    tolerance = _tolerances(experiment, report.tol_angle, report.tol_distance)
    per_joint, angle, distance = compare(experiment, motion, reference)
    reference_run.converged = (angle, distance)
    unsettled = (np.array(list(per_joint.values())) + uncertainty > tolerance) & \
        (uncertainty < tolerance)
    names = [n for n, u in zip(experiment.joints, unsettled, strict=True) if u]
    reference_run.message = (
        f"at the step {reference_run.converged[0]:.1e} rad / {reference_run.converged[1]:.1e}"
        f" m from the converged motion (MuJoCo at 1/{REFINE} step, uncertain by "
        f"{float(np.max(uncertainty / tolerance)):.0%} of the tolerance)"
        + (f"; not converged at the step, judged by the converged motion: {', '.join(names)}"
           if names else ""))
    for run, trajectory in runs:
        if trajectory is None:
            continue
        against, angle, distance = compare(experiment, motion, trajectory)
        run.converged = (angle, distance)
        if not names:
            continue
        at_step = np.array(list(run.per_joint.values()))
        errors = np.where(unsettled, np.array(list(against.values())) + uncertainty, at_step)
        beyond = [n for n, e, t in zip(experiment.joints, errors, tolerance, strict=True)
                  if e > t]
        run.status = "disagree" if beyond else "ok"
        run.message = (f"beyond tolerance of the converged motion at {', '.join(beyond)}"
                       if beyond else "within tolerance of the converged motion where MuJoCo "
                       "at the step is not, of MuJoCo at the step elsewhere")


def _contact_runs(report: DynamicsReport, experiment: Experiment, files: dict[str, Path],
                  judge: Judge, chosen: list[Engine], results: dict[tuple[str, str], Outcome]
                  ) -> None:
    """A contact experiment in the reference and every chosen engine that has contacts,
    each judged on its outcome."""
    for engine in [REFERENCE, *chosen]:
        path = files[engine.format]
        if not engine.contacts:
            report.runs.append(Run(experiment.name, engine.label, path.name, "skipped",
                                   "no contacts simulated here"))
            continue
        run, trajectory = _outcome(engine, path, experiment,
                                   results[engine.name, experiment.name])
        if trajectory is not None:
            verdict = judge(trajectory)
            run.status = "ok" if verdict.ok else "disagree"
            run.message, run.max_angle, run.max_distance = verdict.message, verdict.angle, \
                verdict.distance
        report.runs.append(run)


def _outcome(engine: Engine, path: Path, experiment: Experiment, outcome: Outcome
             ) -> tuple[Run, Trajectory | None]:
    run = Run(experiment.name, engine.label, path.name, "ok")
    trajectory, run.seconds = outcome
    if isinstance(trajectory, EngineUnavailable):
        run.status, run.message = "skipped", str(trajectory)
    elif isinstance(trajectory, Exception):  # the engine refused the file
        run.status, run.message = "failed", str(trajectory)
    else:
        run.notes = trajectory.notes
        return run, trajectory
    return run, None


def _run(engine: Engine, path: Path, experiment: Experiment, reference: Trajectory,
         outcome: Outcome, tol_angle: float, tol_distance: float
         ) -> tuple[Run, Trajectory | None]:
    run, trajectory = _outcome(engine, path, experiment, outcome)
    if trajectory is None:
        return run, None
    try:
        run.per_joint, run.max_angle, run.max_distance = compare(experiment, reference,
                                                                 trajectory)
    except ValueError as e:
        run.status, run.message = "failed", str(e)
        return run, None
    tolerance = dict(zip(experiment.joints, _tolerances(experiment, tol_angle, tol_distance),
                         strict=True))
    run.worst_joint = max(run.per_joint, key=lambda n: run.per_joint[n] / tolerance[n])
    if run.per_joint[run.worst_joint] > tolerance[run.worst_joint]:
        run.status = "disagree"
    return run, trajectory


def format_table(report: DynamicsReport) -> str:
    lines = [f"{report.source}: {len(report.experiments)} experiment(s), 2 s at 1 ms vs "
             f"MuJoCo (MJCF); tolerance {report.tol_angle:g} rad / {report.tol_distance:g} m"]
    if any(e.name in CONTACT_EXPERIMENTS for e in report.experiments):
        lines.append("contact experiments, each engine judged alone: max rad, a door's travel "
                     "past its closed value; max m, a box's distance from resting in its drawer")
    lines.append("")
    rows = [("experiment", "engine", "file", "max rad", "max m", "worst joint",
             "converged rad / m", "s", "verdict")]
    for r in report.runs:
        numbers = ("-", "-") if r.status in ("reference", "skipped", "failed") else \
            (f"{r.max_angle:.2e}", f"{r.max_distance:.2e}")
        converged = "-" if r.converged is None else \
            f"{r.converged[0]:.1e} / {r.converged[1]:.1e}"
        rows.append((r.experiment, r.engine, r.file, *numbers, r.worst_joint or "-",
                     converged, f"{r.seconds:.1f}", r.status))
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    lines += ["  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)).rstrip()
              for row in rows]
    if any(r.converged is not None for r in report.runs):
        lines.insert(1, f"converged: against MuJoCo (MJCF) at 1/{REFINE} step, its stops as "
                     "stiff as that step takes, where joints meet their limits; a joint MuJoCo "
                     "at the step has not converged on is judged by it (within tolerance, less "
                     "its own uncertainty), the others by MuJoCo at the step")
    said = sorted({f"{r.engine}: {r.message}" if r.status in ("skipped", "failed") else
                   f"{r.experiment}, {r.engine}: {r.message}" for r in report.runs if r.message}
                  | {f"{r.engine}: {n}" for r in report.runs for n in r.notes}) + report.notes
    if said:
        lines += [""] + said
    if not report.experiments:
        lines.append("(no movable joint: nothing to simulate)")
    lines += ["", f"collision pieces of two parts overlapping at q = 0: {len(report.overlaps)}"
              + (" pair(s)" if report.overlaps else "")]
    lines += [f"  {o.part_a} / {o.part_b}: {o.depth * 1000:.1f} mm" for o in report.overlaps]
    lines += [f"joints whose child meets its parent's pieces along the range: "
              f"{len(report.range_overlaps)}"]
    lines += [f"  {o.joint} at {o.value:.3g}: {o.part_a} / {o.part_b} {o.depth * 1000:.1f} mm"
              for o in report.range_overlaps]
    return "\n".join(lines)
