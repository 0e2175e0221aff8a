"""A model as it is predicting runs it was not fitted on (held-out runs, cross-validation's
left-out parts): each run's initial state fitted on its own opening, the whole run then
replayed once from it; and the nominal model's prediction beside the calibrated one's at
one step."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from ..model import ArticulatedObject
from .fit import Fit, fit_candidate
from .problem import CREEP_SECONDS, build_problem
from .trajectory import MIN_SAMPLES, Trajectory
from .windows import window

# A run is predicted from its opening: this share of it fits its initial state ...
PREDICT_SHARE = 0.25
PREDICT_NFEV = 8  # ... in at most this many evaluations (two values a run, started near)
ALIKE = 1e-9  # relative: replays closer than this are the same motion's


def initial_values(fit: Fit | None) -> dict[str, float]:
    """``fit``'s initial states as start values for a fit of the same runs."""
    return {} if fit is None else {
        f"initial:{t}:{k}:{c}": float(x[k, c]) for t, x in enumerate(fit.initial)
        for k in range(x.shape[0]) for c in (0, 1)}


def predict(obj: ArticulatedObject, trajectories: Sequence[Trajectory],
            warm: Fit | None = None) -> Fit:
    """The model as a prediction of runs it was not fitted on: each run's initial state
    fitted on its opening only (PREDICT_SHARE of it, at least CREEP_SECONDS: the look that
    tells a start from rest; at most PREDICT_NFEV evaluations, started from ``warm``'s
    initial states where given), then the whole run replayed once from it. Fitted on a
    whole run, the initial state would take up what the model gets wrong (and on a replay
    that diverges, cost every evaluation on the whole run)."""
    trajectories = list(trajectories)
    opened = fit_candidate(build_problem(obj, [opening(tr) for tr in trajectories],
                                         inverse=False),
                           (), max_nfev=PREDICT_NFEV, warm=initial_values(warm))
    whole = replay_from(obj, trajectories, opened.initial)
    return dataclasses.replace(whole, rollouts=opened.rollouts + whole.rollouts)


def predict_beside(nominal_obj: ArticulatedObject, calibrated_obj: ArticulatedObject,
                   trajectories: Sequence[Trajectory], nominal: Fit) -> tuple[Fit, Fit]:
    """The calibrated model's prediction of runs (started from ``nominal``, the nominal
    model's :func:`predict` of them) and the nominal prediction to compare it with: both
    replayed at one step, so that what the model changes is compared, not two steps'
    errors (a stop the runs come near but never reach makes the calibrated replay step
    finely and changes nothing else). A run whose opening the two models replay alike from
    the nominal initial state keeps that state: the same opening fits the same state, and a
    refit from it would move it by the optimiser's tolerance and judge that, not the model
    (a stop reached only later, or never)."""
    trajectories = list(trajectories)
    same = replay_from(calibrated_obj, trajectories, nominal.initial)
    if same.solution.ev.fine and not nominal.solution.ev.fine:
        again = replay_from(nominal_obj, trajectories, nominal.initial, fine=True)
        nominal = dataclasses.replace(again, rollouts=nominal.rollouts + again.rollouts)
    alike = [_alike(opening_samples(tr), a.positions, b.positions) for tr, a, b in
             zip(trajectories, nominal.simulated, same.simulated, strict=True)]
    if all(alike):
        return nominal, same
    calibrated = predict(calibrated_obj, trajectories, nominal)
    if any(alike):
        initial = [x0 if keep else x for keep, x0, x in
                   zip(alike, nominal.initial, calibrated.initial, strict=True)]
        again = replay_from(calibrated_obj, trajectories, initial)
        calibrated = dataclasses.replace(again, rollouts=calibrated.rollouts + again.rollouts)
    return nominal, dataclasses.replace(calibrated,
                                        rollouts=calibrated.rollouts + same.rollouts)


def _alike(n: int, a: np.ndarray, b: np.ndarray) -> bool:
    """Two replays' first ``n`` samples the same motion, to round-off."""
    a, b = a[:n], b[:n]
    scale = max(float(np.max(np.abs(a))), 1.0)
    return bool(np.max(np.abs(a - b)) <= ALIKE * scale)


def replay_from(obj: ArticulatedObject, trajectories: list[Trajectory],
                initial: list[np.ndarray], fine: bool = False) -> Fit:
    """One replay of each run from the given initial states (no value left free);
    ``fine``: stepped as non-smooth dynamics are, whatever the model has."""
    problem = build_problem(obj, trajectories, inverse=False)
    problem.initial = [x.copy() for x in initial]
    problem.initial_free = [np.zeros_like(free) for free in problem.initial_free]
    problem.nonsmooth |= fine
    return fit_candidate(problem, ())


def opening(tr: Trajectory) -> Trajectory:
    """The start of ``tr`` its initial state is fitted on (the whole of a short run, or of
    one a coded law drives: that law indexes the whole run's samples)."""
    end = tr.time[0] + max(PREDICT_SHARE * tr.duration, CREEP_SECONDS)
    if tr.controller is not None or np.searchsorted(tr.time, end) < 2 * MIN_SAMPLES:
        return tr
    return window(tr, None, end)


def opening_samples(tr: Trajectory) -> int:
    """How many of ``tr``'s first samples :func:`opening` keeps."""
    end = tr.time[0] + max(PREDICT_SHARE * tr.duration, CREEP_SECONDS)
    if tr.controller is not None or np.searchsorted(tr.time, end) < 2 * MIN_SAMPLES:
        return tr.n
    return int(np.count_nonzero(tr.time <= end + 1e-12))
