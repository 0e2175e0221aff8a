"""``real2code simulate``: every experiment in every engine, each engine from the file it
reads natively (written by our exporters), every joint's trajectory compared with MuJoCo's
from the MJCF (the reference); the contact experiments judged on their outcome in every
engine that simulates contacts, MuJoCo included (contacts.py)."""

from __future__ import annotations

import importlib
import math
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..formats import load, write_formats
from . import EngineUnavailable, Experiment, Trajectory
from .contacts import CONTACT_EXPERIMENTS, Judge
from .experiments import EXPERIMENTS
from .overlap import Overlap, RangeOverlap, overlaps, overlaps_along_ranges

TOL_ANGLE = 0.01  # rad
TOL_DISTANCE = 0.001  # m


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
    for name in experiments or [*EXPERIMENTS, *CONTACT_EXPERIMENTS]:
        if name in CONTACT_EXPERIMENTS:
            _contact_runs(report, obj, name, chosen, formats)
            continue
        variant, experiment = EXPERIMENTS[name](obj)
        if not experiment.joints:
            continue
        report.experiments.append(experiment)
        with tempfile.TemporaryDirectory(prefix="real2code-simulate-") as folder:
            files = write_formats(variant, folder, formats)
            start = time.perf_counter()
            reference = REFERENCE.simulate(files[REFERENCE.format], experiment)
            report.runs.append(Run(name, REFERENCE.label, files[REFERENCE.format].name,
                                   "reference", seconds=time.perf_counter() - start))
            for engine in chosen:
                report.runs.append(_run(engine, files[engine.format], experiment, reference,
                                        tol_angle, tol_distance))
    return report


def _contact_runs(report: DynamicsReport, obj, name: str, chosen: list[Engine],
                  formats: list[str]) -> None:
    """A contact experiment in the reference and every chosen engine that has contacts."""
    if not any(part.collision for part in obj.parts):
        report.notes.append(f"{name}: no collision geometry, nothing to collide")
        return
    variant, experiment, judge, notes = CONTACT_EXPERIMENTS[name](obj)
    report.notes += [f"{name}: {n}" for n in notes]
    if experiment is None:
        return
    report.experiments.append(experiment)
    with tempfile.TemporaryDirectory(prefix="real2code-simulate-") as folder:
        files = write_formats(variant, folder, formats)
        for engine in [REFERENCE, *chosen]:
            path = files[engine.format]
            if not engine.contacts:
                report.runs.append(Run(name, engine.label, path.name, "skipped",
                                       "no contacts simulated here"))
                continue
            report.runs.append(_judged_run(engine, path, experiment, judge))


def _judged_run(engine: Engine, path: Path, experiment: Experiment, judge: Judge) -> Run:
    run, trajectory = _simulated(engine, path, experiment)
    if trajectory is None:
        return run
    verdict = judge(trajectory)
    run.status = "ok" if verdict.ok else "disagree"
    run.message, run.max_angle, run.max_distance = verdict.message, verdict.angle, \
        verdict.distance
    return run


def _simulated(engine: Engine, path: Path, experiment: Experiment
               ) -> tuple[Run, Trajectory | None]:
    run = Run(experiment.name, engine.label, path.name, "ok")
    start = time.perf_counter()
    try:
        trajectory = engine.simulate(path, experiment)
    except EngineUnavailable as e:
        run.status, run.message = "skipped", str(e)
        return run, None
    except (KeyError, ValueError, RuntimeError) as e:  # the engine refused the file
        run.status, run.message = "failed", str(e)
        return run, None
    run.seconds = time.perf_counter() - start
    run.notes = trajectory.notes
    return run, trajectory


def _run(engine: Engine, path: Path, experiment: Experiment, reference: Trajectory,
         tol_angle: float, tol_distance: float) -> Run:
    run, trajectory = _simulated(engine, path, experiment)
    if trajectory is None:
        return run
    try:
        run.per_joint, run.max_angle, run.max_distance = compare(experiment, reference,
                                                                 trajectory)
    except ValueError as e:
        run.status, run.message = "failed", str(e)
        return run
    tolerance = {n: tol_angle if a else tol_distance
                 for n, a in zip(experiment.joints, experiment.angular, strict=True)}
    run.worst_joint = max(run.per_joint, key=lambda n: run.per_joint[n] / tolerance[n])
    if run.per_joint[run.worst_joint] > tolerance[run.worst_joint]:
        run.status = "disagree"
    return run


def format_table(report: DynamicsReport) -> str:
    lines = [f"{report.source}: {len(report.experiments)} experiment(s), 2 s at 1 ms vs "
             f"MuJoCo (MJCF); tolerance {report.tol_angle:g} rad / {report.tol_distance:g} m"]
    if any(e.name in CONTACT_EXPERIMENTS for e in report.experiments):
        lines.append("contact experiments, each engine judged alone: max rad, a door's travel "
                     "past its closed value; max m, a box's distance from resting in its drawer")
    lines.append("")
    rows = [("experiment", "engine", "file", "max rad", "max m", "worst joint", "s", "verdict")]
    for r in report.runs:
        numbers = ("-", "-") if r.status in ("reference", "skipped", "failed") else \
            (f"{r.max_angle:.2e}", f"{r.max_distance:.2e}")
        rows.append((r.experiment, r.engine, r.file, *numbers, r.worst_joint or "-",
                     f"{r.seconds:.1f}", r.status))
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    lines += ["  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)).rstrip()
              for row in rows]
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
