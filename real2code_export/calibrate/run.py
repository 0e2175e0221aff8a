"""``calibrate``: measured trajectories in; the named causes, the extended model, every export
and the report out (atomically: all of it or nothing)."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .. import atomic
from ..errors import FormatError
from ..model import ArticulatedObject
from . import features as ft
from .agreement import disagreement, held_out_estimate
from .alternatives import finite_or_none, symmetric_alternative
from .apply import base_parameter_halfwidths, calibrated_object
from .experiment import read_experiment
from .fit import Fit, fit_candidate
from .inertial import compared
from .inverse import _nominal_effort, effort_errors
from .prediction import initial_values, predict, predict_beside
from .problem import Problem, build_problem, calibration_spec
from .report import (
    Replay,
    build_report,
    candidates_plot,
    json_text,
    markdown,
    replay_plot,
    smoothing,
)
from .select import Selection, select
from .select_effort import (
    EFFORT_ONLY,
    effort_decides,
    replay_cannot_judge,
    select_by_effort,
    select_on_effort_only,
)
from .trajectory import MIN_SAMPLES, Trajectory, read_all
from .validate import cross_validate, cross_validate_effort
from .windows import Excluded, cut, find_pushes, segments, window

# Multiple shooting for a plant that integrates its input (no restoring force, a measured
# effort replayed open loop): its replay drifts with every error of the input, so long runs
# are fitted as pieces of about this length, each with its own initial state.
SHOOTING_SECONDS = 5.0
# ... and a free swing over many periods in pieces of this many of its periods
SHOOTING_PERIODS = 4
MIN_SHOOTING = 1.0  # s: a piece holds enough samples past its smoothing's edges to fit
# The calibrated model's replay of the fitted runs starts from the chosen fit's initial
# states, already that model's optimum but for the refinement's small step: this many
# evaluations move them the rest of the way (a closed loop barely tells an initial
# velocity, and a fit left to its end wandered a dozen replays along it for nothing)
REPLAY_NFEV = 3
ROUNDOFF = 1e-9  # relative: RMS errors closer than this are the same motion's


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


def replay(obj: ArticulatedObject, trajectories: Sequence[Trajectory],
           warm: Fit | None = None) -> Fit:
    """The model exactly as it is (its dynamics and metadata extras) replayed under each
    trajectory's conditions; only the initial states are fitted (started from ``warm``'s,
    where given, in at most REPLAY_NFEV evaluations: the fit the model was made from
    already found them)."""
    return fit_candidate(build_problem(obj, list(trajectories), inverse=False), (),
                         warm=initial_values(warm),
                         **({} if warm is None else {"max_nfev": REPLAY_NFEV}))


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
            _, dq_sim, _ = ft.derivatives(sim, tr.sample_period, sig.window)
            rest = ft.rest_position(q, dq, noise)
            rest_sim = ft.rest_position(sim, dq_sim, noise)
            env = ft.decay_envelope(tr.time, q, dq, noise, rest)
            f_meas = ft.dominant_frequency(tr.time, q)
            f_sim = ft.dominant_frequency(tr.time, sim)
            force = sig.tau[:, k] - _nominal_effort(problem, j, k, sig, set())
            missing = ft.missing_force(dq[sig.usable], sig.ddq[sig.usable, k],
                                       force[sig.usable])
            stops = sig.stops[k]
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
              out_dir: Path | None = None, formats: Sequence[str] | None = None,
              start: float | None = None, end: float | None = None,
              experiment: Path | None = None, segment: float | None = None
              ) -> CalibrationResult:
    """Fit the model's joint dynamics to measured trajectories (CSV files, docs/design.md).

    Every file is read and checked before anything runs; ``start``/``end`` (seconds, in the
    files' time) keep a window of every run (over the experiment files' own windows);
    ``experiment``: the experiment file for every CSV that has none beside it;
    ``segment`` (s): fit runs as pieces this long (multiple shooting; by default a plant
    that integrates an open-loop effort and a free swing over many periods are cut:
    :func:`shooting_length`). With
    ``out_dir`` the report (``report.json``, ``report.md`` and its plots), the calibrated
    ``object.json`` and the exports are written there atomically.
    """
    if not data:
        raise FormatError(None, "--data", "no trajectory to fit")
    if segment is not None and not segment > 0:
        raise FormatError(None, "--segment", f"{segment} s: a segment must last a while")
    if start is not None and end is not None and end <= start:
        raise FormatError(None, "--end", f"{end} is not after --start {start}")
    declared = read_experiment(experiment) if experiment is not None else None
    trajectories = [_windowed(tr, start, end) for tr in read_all(list(data), model, declared)]
    held = [_windowed(tr, start, end) for tr in read_all(list(holdout), model, declared)] \
        if holdout else []
    if held and set(held[0].joints) != set(trajectories[0].joints):
        raise FormatError(held[0].source, "header", f"measures joints {held[0].joints}, the "
                          f"fitted data measure {trajectories[0].joints}")
    return calibrate_trajectories(model, trajectories, held, out_dir, formats, segment)


def _windowed(tr: Trajectory, start: float | None, end: float | None) -> Trajectory:
    start = start if start is not None else tr.window[0]
    end = end if end is not None else tr.window[1]
    out = window(tr, start, end)
    if out.n < MIN_SAMPLES:
        raise FormatError(tr.source, "window", f"only {out.n} samples between "
                          f"{start if start is not None else 'the start'} and "
                          f"{end if end is not None else 'the end'} s: at least "
                          f"{MIN_SAMPLES} are needed to fit")
    return out


def leave_out_pushes(model: ArticulatedObject, trajectories: list[Trajectory]
                     ) -> tuple[list[Trajectory], list[Excluded]]:
    """The runs without the stretches where a passive joint is driven by an unmeasured
    force (each remaining piece its own run), and those stretches."""
    if not trajectories:
        return [], []
    joints = trajectories[0].joints
    spec = calibration_spec(model, joints, trajectories[0].gravity)
    dynamics = {j: model.joint(j).dynamics for j in joints}
    excluded = [e for tr in trajectories for e in find_pushes(tr, joints, spec, dynamics)]
    pieces, dropped = [], []
    for tr in trajectories:
        kept, short = cut(tr, excluded)
        pieces += kept
        dropped += short
    return pieces, excluded + dropped


def shooting_length(model: ArticulatedObject, trajectories: list[Trajectory]) -> float | None:
    """How long the pieces of multiple shooting are, or None (runs fitted whole):
    SHOOTING_SECONDS where a measured joint has no restoring force (no gravity load, no
    spring) and its measured effort is replayed open loop; SHOOTING_PERIODS of its swing
    where a joint moves freely (no effort measured, no law) through many swings: each
    period's small error of frequency shifts the replay's phase, until after a few seconds
    it swings against the data and the fit loses every effect in it."""
    from .spec import gravity_loaded

    free_periods = []
    for j in trajectories[0].joints:
        gravity = trajectories[0].gravity
        restoring = gravity_loaded(model, j, *([gravity] if gravity else [])) or \
            model.joint(j).dynamics.stiffness > 0
        if not restoring and any(j in tr.efforts and tr.law() is None for tr in trajectories):
            return SHOOTING_SECONDS
        for tr in trajectories:
            if j not in tr.efforts and tr.law() is None:
                period = ft.swing_period(tr.time, tr.positions[j])
                if period is not None and tr.duration > 1.5 * SHOOTING_PERIODS * period:
                    free_periods.append(period)
    if not free_periods:
        return None
    return max(SHOOTING_PERIODS * max(free_periods), MIN_SHOOTING)


def calibrate_trajectories(model: ArticulatedObject, trajectories: list[Trajectory],
                           held: list[Trajectory], out_dir: Path | None = None,
                           formats: Sequence[str] | None = None,
                           segment: float | None = None) -> CalibrationResult:
    """:func:`calibrate` on trajectories already in memory (adapters with a feedback law)."""
    trajectories = [tr.with_encoder_noise() for tr in trajectories]
    held = [tr.with_encoder_noise() for tr in held]
    whole = trajectories
    trajectories, excluded = leave_out_pushes(model, trajectories)
    held, held_excluded = leave_out_pushes(model, held)
    if not trajectories:
        raise FormatError(whole[0].source, None, "nothing left to fit: an unmeasured force "
                          "drives the joint throughout (" + "; ".join(
                              f"{e.start:.3f}-{e.end:.3f} s" for e in excluded) + ")")
    segment = segment if segment is not None else shooting_length(model, trajectories)
    if segment is not None:
        trajectories = [p for tr in trajectories for p in segments(tr, segment)]
    problem = build_problem(model, trajectories)
    selection = select_by_effort(problem) if effort_decides(problem) else select(problem)
    if selection.by == "simulation" and replay_cannot_judge(problem, selection):
        selection = select_on_effort_only(problem, selection)
    # the effort equation alone chose and fitted: every judgement is made on the effort
    effort_only = selection.by == EFFORT_ONLY
    rejected = None
    cv = cross_validate(model, trajectories, selection.chosen) \
        if selection.by == "simulation" else cross_validate_effort(problem, selection.chosen)
    if not cv.improves:
        rejected = (f"{'+'.join(selection.chosen.names)} predicts left-out data worse than "
                    f"the nominal model (cross-validation by {cv.kind}, {cv.error}: squared "
                    f"error {cv.sse_calibrated:.4g} vs {cv.sse_nominal:.4g} noise units)")
    calibrated = calibrated_object(model, selection.chosen)
    # the calibrated model replayed as it will be exported: the gain is measured on it (the
    # nominal model's replay is the selection's own nominal fit: not made twice)
    after = replay(calibrated, trajectories, selection.chosen) if selection.chosen.effects \
        else selection.nominal
    fits = _replays("fitted", trajectories, selection.nominal, after)
    if rejected is None and selection.chosen.effects and not effort_only and \
            _worse(fits):
        # (its own fit is better; the exported model's replay, initial states as the data
        # give them, is not: what it fitted lives in the fit's initial states)
        rejected = (f"{'+'.join(selection.chosen.names)} replays the fitted data worse than "
                    "the nominal model")
    held_nominal = predict(model, held) if held else None
    holdouts = []
    held_effort = held_estimate = None
    held_smoothing: list[dict] = []
    if held and rejected is None:
        held_after = held_nominal
        if selection.chosen.effects:
            held_nominal, held_after = predict_beside(model, calibrated, held, held_nominal)
        holdouts = _replays("held out", held, held_nominal, held_after)
        lost = list(range(len(held))) if effort_only else \
            [i for i, r in enumerate(holdouts) if _lost(r)]
        if selection.chosen.effects and lost and all(
                j in held[i].efforts for i in lost for j in problem.joints):
            # neither model's open-loop replay follows these runs (an unstable plant its
            # controller held up, replayed on the recorded effort), or the replay judged
            # nothing of the fit: the effort each model says the measured motion needs
            # judges them
            held_problem = build_problem(model, [held[i] for i in lost])
            held_effort = held_effort_errors(held_problem, selection.chosen)
            held_smoothing = smoothing(held_problem)
            # (and what the same structure says fitted on them: whether the runs share
            # its values)
            held_estimate = held_out_estimate(model, held_problem, selection.chosen)
            followed = [r for i, r in enumerate(holdouts) if i not in lost]
            worse = (followed and _worse(followed)) or \
                sum(e["sse_calibrated"] for e in held_effort) > \
                sum(e["sse_nominal"] for e in held_effort)
        else:
            worse = _worse(holdouts)
        if worse:
            rejected = (f"{'+'.join(selection.chosen.names)} predicts the held-out data "
                        "worse than the nominal model" + (
                            " (judged by the effort each predicts from the measured "
                            "motion on the runs no replay follows)"
                            if held_effort else "") + disagreement(held_estimate))
    proposed = None  # the structure rejected, if one was
    if rejected is not None:  # never worse than nominal: the nominal model is the result
        selection.log.append(f"rejected: {rejected}; the nominal model is kept")
        proposed = selection.chosen
        selection.chosen = selection.nominal
        calibrated = calibrated_object(model, selection.nominal)
        if held:
            holdouts = _replays("held out", held, held_nominal, held_nominal)
        fits = _replays("fitted", trajectories, selection.nominal, selection.nominal)
    report = build_report(problem, selection, fits, holdouts, _features(problem, selection.nominal),
                          [tr.source for tr in trajectories], [tr.source for tr in held],
                          model.name)
    # (of the rejected structure where one was: what the effort said, set beside the
    # nominal model that was kept)
    report["equation_error"] = _equation_error(model, problem, proposed or selection.chosen)
    if proposed is not None and report["equation_error"] is not None:
        report["equation_error"]["rejected"] = True
    report["base_parameters"] = {j: {**compared(model, calibrated, j), "halfwidth95":
                                     base_parameter_halfwidths(model, selection.chosen, j)}
                                 for j in problem.joints}
    report["excluded"] = [e.as_json() for e in excluded + held_excluded]
    report["shooting_segment"] = segment
    report["sensor"] = {tr.source: {j: {"noise": float(problem.position_noise[t][k]),
                                        "quantum": ft.quantum(tr.positions[j])}
                                    for k, j in enumerate(problem.joints)}
                        for t, tr in enumerate(problem.trajectories)}
    report["cross_validation"] = cv.as_json()
    report["holdout_effort"] = held_effort
    report["smoothing"] += held_smoothing  # the held-out runs' effort equation too
    report["holdout_estimate"] = held_estimate
    report["residual_error"] = "effort" if effort_only and rejected is None else "position"
    # (fitted by simulation as the chosen structure was: not where no replay can judge)
    report["symmetric_alternative"] = None if effort_only else \
        symmetric_alternative(problem, selection.chosen)
    report["rejected"] = rejected
    if rejected is not None:
        report["unexplained"] = True
    files: dict[str, Path] = {}
    if out_dir is not None:
        files = write_outputs(Path(out_dir), calibrated, report, fits + holdouts, problem,
                              list(formats) if formats is not None else _export_formats())
    return CalibrationResult(calibrated, report, selection, problem, fits, holdouts, files)


def _equation_error(model: ArticulatedObject, problem: Problem, chosen: Fit) -> dict | None:
    """The inverse-dynamics (equation-error) estimate of the chosen structure beside the
    simulation (output-error) one, with its 95 % intervals and the base inertial
    parameters it gives: where the effort is measured both are reported."""
    if not any(problem.contexts[j].has_effort for j in problem.joints):
        return None
    start = chosen.start
    if start is None:
        return {"parameters": {}, "note": "nominal model: nothing fitted"}
    as_fit = dataclasses.replace(chosen, values={**chosen.values, **start.values},
                                 cov=dict(start.cov))
    inverse_model = calibrated_object(model, as_fit)
    return {"parameters": dict(start.values),
            "halfwidth95": {k: finite_or_none(start.halfwidth(k)) for k in start.values},
            "base_parameters": {j: {**compared(model, inverse_model, j)["calibrated"],
                                    "halfwidth95": base_parameter_halfwidths(model, as_fit, j)}
                                for j in problem.joints},
            "rejected": False,
            "residual_rms": float(np.sqrt(start.rss / max(start.n, 1))),
            "unit": "effort / effort scale",
            "loss": "soft L1 where the effort residual has spikes, else least squares",
            "note": "measured effort regressed on Savitzky-Golay smoothed motion; the "
                    "simulation fit starts from it and decides, but where selected_by is "
                    "'effort equation only' (this is then the result)"}



def _lost(r: Replay) -> bool:
    """Neither model's replay follows the run: each is further from the measured motion
    than the run's own mean (R^2 <= 0), so the position error measures a divergence, not
    which model is nearer."""
    spread = float(np.sum((r.measured - r.measured.mean(axis=0)) ** 2))
    return all(float(np.sum((sim - r.measured) ** 2)) >= spread
               for sim in (r.nominal, r.calibrated))


def held_effort_errors(problem: Problem, chosen: Fit) -> list[dict]:
    """The chosen structure's effort equation, with the values of the fit (and with its
    inverse-dynamics estimate), against the nominal model on runs it was not fitted on
    (``problem``'s): the measured effort each predicts from the measured motion (inverse
    dynamics), per run and joint."""
    effects = tuple(problem.effects[e.joint][e.variant] for e in chosen.effects
                    if e.variant in problem.effects[e.joint])
    out = effort_errors(problem, effects, chosen.values)
    if chosen.start is not None:
        for row, eq in zip(out, effort_errors(problem, effects, chosen.start.values),
                           strict=True):
            row["rms_inverse_dynamics"] = eq["rms_calibrated"]
    return out


def _worse(replays: list[Replay]) -> bool:
    """The calibrated model's replays are further from the data than the nominal's, beyond
    the round-off two replays of the same motion differ by (a stop the runs never reach
    changes nothing but the last digits)."""
    return _total_rmse(replays, "calibrated") > _total_rmse(replays, "nominal") * (1 + ROUNDOFF)


def _total_rmse(replays: list[Replay], which: str) -> float:
    sq = [((r.nominal if which == "nominal" else r.calibrated) - r.measured) ** 2
          for r in replays]
    return float(np.sqrt(np.mean(np.concatenate([s.ravel() for s in sq]))))


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
                  out_dir: Path, start: float | None = None, end: float | None = None,
                  experiment: Path | None = None, segment: float | None = None) -> int:
    """The ``real2code calibrate`` command: 0 on success (errors raise Real2CodeError,
    which the CLI prints, exiting non-zero, with nothing written)."""
    from ..formats import load

    model = load(model_path)
    result = calibrate(model, list(data), list(holdout), Path(out_dir), start=start, end=end,
                       experiment=experiment, segment=segment)
    r = result.report
    causes = ", ".join(r["causes"]) or "none (the nominal model explains the data)"
    print(f"causes      {causes}")
    for joint, lag in r["effort_hold"].items():
        print(f"  effort on {joint} held between samples: replayed {lag * 1e3:.3g} ms late")
    for key, p in r["parameters"].items():
        hw = p["halfwidth95"]
        print(f"  {key:28s} {p['value']:.6g} ± {hw:.2g} {p['unit']}" if hw is not None
              else f"  {key:28s} {p['value']:.6g} (not identifiable) {p['unit']}")
    print(f"rmse        {r['rmse_before']:.4g} -> {r['rmse_after']:.4g} {r['rmse_unit']} (fitted)")
    if r["holdout_rmse_before"] is not None:
        print(f"            {r['holdout_rmse_before']:.4g} -> {r['holdout_rmse_after']:.4g} "
              f"{r['rmse_unit']} (held out)")
    for e in r["excluded"]:
        print(f"left out   {Path(e['file']).name} {e['start']:.3f}-{e['end']:.3f} s: "
              f"{e['reason']}")
    for e in r["holdout_effort"] or []:
        print(f"            {Path(e['file']).name}: no replay follows it; effort RMS "
              f"{e['rms_nominal']:.4g} -> {e['rms_calibrated']:.4g} (held out, inverse "
              "dynamics)")
    if r["rejected"]:
        print(f"rejected    {r['rejected']}")
    if r["unexplained"]:
        print(f"unexplained residual: {r['residual_to_noise']:.1f} x sensor noise")
    print(f"report      {Path(out_dir) / 'report.md'}")
    return 0
