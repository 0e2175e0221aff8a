"""``calibrate``: measured trajectories in; the named causes, the extended model, every export
and the report out (atomically: all of it or nothing)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .. import atomic
from ..errors import FormatError
from ..model import ArticulatedObject
from . import features as ft
from .apply import calibrated_object
from .fit import Fit, fit_candidate
from .inverse import _nominal_effort
from .problem import Problem, build_problem
from .report import Replay, build_report, candidates_plot, json_text, markdown, replay_plot
from .select import Selection, select
from .trajectory import Trajectory, read_all


@dataclass
class CalibrationResult:
    model: ArticulatedObject  # the calibrated model
    report: dict[str, Any]  # report.json
    selection: Selection
    problem: Problem
    fits: list[Replay]
    holdouts: list[Replay]
    files: dict[str, Path]  # what was written (empty when no out_dir)

    @property
    def causes(self) -> list[str]:
        return self.report["causes"]


def replay(obj: ArticulatedObject, trajectories: Sequence[Trajectory]) -> Fit:
    """The model exactly as it is (its dynamics and metadata extras) replayed under each
    trajectory's conditions; only the initial velocities of runs that start moving are
    fitted."""
    return fit_candidate(build_problem(obj, list(trajectories)), ())


def _replays(label: str, trajectories, nominal: Fit, calibrated: Fit) -> list[Replay]:
    out = []
    for t, tr in enumerate(trajectories):
        measured = np.column_stack([tr.positions[j] for j in tr.joints])
        out.append(Replay(label, tr.source, tr.time, measured, nominal.simulated[t].positions,
                          calibrated.simulated[t].positions, tr.joints))
    return out


def _features(problem: Problem, nominal: Fit) -> list[dict]:
    """What points at causes, per trajectory and joint (measured vs the nominal replay)."""
    out = []
    for t, (tr, sig) in enumerate(zip(problem.trajectories, problem.signals, strict=True)):
        for k, j in enumerate(problem.joints):
            noise = float(problem.position_noise[t][k])
            q, dq = sig.q[:, k], sig.dq[:, k]
            sim = nominal.simulated[t].positions[:, k]
            _, dq_sim, _ = ft.derivatives(sim, tr.sample_period)
            rest = ft.rest_position(q, dq, noise)
            rest_sim = ft.rest_position(sim, dq_sim, noise)
            env = ft.decay_envelope(tr.time, q, dq, noise, rest)
            f_meas = ft.dominant_frequency(tr.time, q)
            f_sim = ft.dominant_frequency(tr.time, sim)
            force = sig.tau[:, k] - _nominal_effort(problem, j, k, sig, set())
            missing = ft.missing_force(dq[sig.usable], sig.ddq[sig.usable, k],
                                       force[sig.usable])
            stops = ft.sudden_stops(q, dq, sig.ddq[:, k], noise)
            summary = [f"noise {noise:.3g}"]
            if env["kind"] != "n/a":
                summary.append(f"swing amplitude decays {env['kind']}ly"
                               if env["kind"] in ("linear", "exponential")
                               else f"decay envelope: {env['kind']}")
            if rest is not None:
                summary.append(f"oscillates about {rest:.4g}" + (
                    f" (nominal model: {rest_sim:.4g})" if rest_sim is not None else ""))
            if f_meas and f_sim and abs(f_meas - f_sim) > 0.05 * f_sim:
                summary.append(f"frequency {f_meas:.3g} Hz vs nominal {f_sim:.3g} Hz")
            if stops:
                summary.append("sudden stop at the " + " and ".join(stops) + " end")
            if missing["terms"]:
                summary.append("the force the nominal model misses " +
                               ", ".join(missing["terms"]))
            out.append({"file": tr.source, "joint": j, "noise": noise, "decay": env,
                        "rest_position": rest, "rest_position_nominal": rest_sim,
                        "frequency": f_meas, "frequency_nominal": f_sim, "stops": stops,
                        "missing_force": missing, "summary": summary})
    return out


def _export_formats() -> list[str]:
    from ..formats import export_formats

    return ["json", *export_formats()]


def calibrate(model: ArticulatedObject, data: Sequence[Path], holdout: Sequence[Path] = (),
              out_dir: Path | None = None, formats: Sequence[str] | None = None
              ) -> CalibrationResult:
    """Fit the model's joint dynamics to measured trajectories (CSV files, docs/design.md).

    Every file is read and checked before anything runs; with ``out_dir`` the report
    (``report.json``, ``report.md`` and its plots), the calibrated ``object.json`` and the
    exports are written there atomically.
    """
    if not data:
        raise FormatError(None, "--data", "no trajectory to fit")
    trajectories = read_all(list(data), model)
    held = read_all(list(holdout), model) if holdout else []
    if held and set(held[0].joints) != set(trajectories[0].joints):
        raise FormatError(held[0].source, "header", f"measures joints {held[0].joints}, the "
                          f"fitted data measure {trajectories[0].joints}")
    return calibrate_trajectories(model, trajectories, held, out_dir, formats)


def calibrate_trajectories(model: ArticulatedObject, trajectories: list[Trajectory],
                           held: list[Trajectory], out_dir: Path | None = None,
                           formats: Sequence[str] | None = None) -> CalibrationResult:
    """:func:`calibrate` on trajectories already in memory (adapters with a feedback law)."""
    problem = build_problem(model, trajectories)
    selection = select(problem)
    calibrated = calibrated_object(model, selection.chosen)
    # the calibrated model replayed as it will be exported: the gain is measured on it
    after = replay(calibrated, trajectories)
    fits = _replays("fitted", trajectories, selection.nominal, after)
    holdouts = []
    if held:
        holdouts = _replays("held out", held, replay(model, held), replay(calibrated, held))
    report = build_report(problem, selection, fits, holdouts, _features(problem, selection.nominal),
                          [tr.source for tr in trajectories], [tr.source for tr in held],
                          model.name)
    files: dict[str, Path] = {}
    if out_dir is not None:
        files = write_outputs(Path(out_dir), calibrated, report, fits + holdouts, problem,
                              list(formats) if formats is not None else _export_formats())
    return CalibrationResult(calibrated, report, selection, problem, fits, holdouts, files)


def write_outputs(out_dir: Path, calibrated: ArticulatedObject, report: dict[str, Any],
                  replays: list[Replay], problem: Problem, formats: list[str]) -> dict[str, Path]:
    from ..formats import export

    unit = problem.contexts[problem.joints[0]].unit("position")
    images: dict[str, str] = {}
    blobs: dict[str, bytes] = {}
    for i, r in enumerate(replays):
        name = f"plots/{'fit' if r.label == 'fitted' else 'holdout'}_{i}.png"
        blobs[name] = replay_plot(r, unit)
        images[f"{r.label}: {Path(r.source).name}"] = name
    blobs["plots/candidates.png"] = candidates_plot(report)
    images["candidates"] = "plots/candidates.png"
    files: dict[str, Path] = {}
    with atomic.staged_output(out_dir) as staging:
        for name, data in blobs.items():
            atomic.write_bytes(staging / name, data)
            files[name] = out_dir / name
        atomic.write_text(staging / "report.json", json_text(report))
        atomic.write_text(staging / "report.md", markdown(report, images))
        written = export(calibrated, staging, formats)
        for fmt, path in written.items():
            files[fmt] = out_dir / Path(path).relative_to(staging)
    files["report.json"] = out_dir / "report.json"
    files["report.md"] = out_dir / "report.md"
    return files


def run_calibrate(model_path: Path, data: Sequence[Path], holdout: Sequence[Path],
                  out_dir: Path) -> int:
    """The ``real2code calibrate`` command: 0 on success (errors raise Real2CodeError,
    which the CLI prints, exiting non-zero, with nothing written)."""
    from ..formats import load

    model = load(model_path)
    result = calibrate(model, list(data), list(holdout), Path(out_dir))
    r = result.report
    causes = ", ".join(r["causes"]) or "none (the nominal model explains the data)"
    print(f"causes      {causes}")
    for key, p in r["parameters"].items():
        hw = p["halfwidth95"]
        print(f"  {key:28s} {p['value']:.6g} ± {hw:.2g} {p['unit']}" if hw is not None
              else f"  {key:28s} {p['value']:.6g} (not identifiable) {p['unit']}")
    print(f"rmse        {r['rmse_before']:.4g} -> {r['rmse_after']:.4g} {r['rmse_unit']} (fitted)")
    if r["holdout_rmse_before"] is not None:
        print(f"            {r['holdout_rmse_before']:.4g} -> {r['holdout_rmse_after']:.4g} "
              f"{r['rmse_unit']} (held out)")
    if r["unexplained"]:
        print(f"unexplained residual: {r['residual_to_noise']:.1f} x sensor noise")
    print(f"report      {Path(out_dir) / 'report.md'}")
    return 0
