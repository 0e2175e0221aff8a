"""No false causes: a chosen structure is kept only if it also predicts data it was not
fitted on better than the nominal model does.

Cross-validation across the fit runs (leave one run out; a run fitted in pieces, each
piece); with a single run, across its two halves. Each fold refits the chosen structure on
the rest (started from the full fit's values: a parameter the rest cannot inform stays
where the full fit put it, and one the rest does not identify is reset there) and
predicts the left-out piece as a held-out run is predicted: its initial state fitted on
the piece's own opening, then the whole piece replayed from it (fitted on the whole
piece, the initial state would take up what the model gets wrong there). The nominal
model predicts it alike. The sums of squared position errors, in noise units, decide.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .fit import Fit, fit_candidate
from .inverse import design, fold_errors
from .prediction import predict, predict_beside
from .problem import Problem, build_problem
from .trajectory import MIN_SAMPLES, Trajectory
from .windows import window

MIN_HALF = 0.5  # s: a single run shorter than twice this is not split
FOLD_NFEV = 8  # a fold starts at the full fit: a few steps move it to its own optimum


@dataclass
class CrossValidation:
    folds: int
    sse_nominal: float  # squared errors (noise units) of the left-out pieces, nominal model
    sse_calibrated: float  # the same, the chosen structure refitted without them
    kind: str  # "runs" | "halves" | "none"
    error: str = "position"  # what the left-out part is predicted in: position | effort

    @property
    def improves(self) -> bool:
        return self.folds == 0 or self.sse_calibrated < self.sse_nominal

    def as_json(self) -> dict:
        return {"folds": self.folds, "by": self.kind, "sse_nominal": self.sse_nominal,
                "sse_calibrated": self.sse_calibrated, "improves": self.improves,
                "error": self.error}


def _folds(trajectories: list[Trajectory]) -> tuple[str, list[tuple[list, Trajectory]]]:
    if len(trajectories) >= 2:
        return "runs", [(_without(trajectories, i), left)
                        for i, left in enumerate(trajectories)]
    tr = trajectories[0]
    if tr.duration < 2 * MIN_HALF or tr.n < 4 * MIN_SAMPLES or tr.controller is not None:
        return "none", []  # too short to halve, or a coded law indexed by the whole run
    mid = float(tr.time[0] + 0.5 * tr.duration)
    first = window(tr, None, mid)
    second = window(tr, mid, None)
    first.source, second.source = f"{tr.source} [first half]", f"{tr.source} [second half]"
    return "halves", [([first], second), ([second], first)]


def _without(trajectories: list[Trajectory], i: int) -> list[Trajectory]:
    """The runs but the ``i``-th; the piece after it no longer continues the one before it
    (multiple shooting's continuity holds only between pieces that meet)."""
    return [dataclasses.replace(tr, continues=False) if n == i + 1 and tr.continues else tr
            for n, tr in enumerate(trajectories) if n != i]


def _sse(fit: Fit) -> float:
    return float(fit.residual @ fit.residual)


def cross_validate(obj, trajectories: list[Trajectory], chosen: Fit) -> CrossValidation:
    """Leave-out prediction error of ``chosen``'s structure against the nominal model."""
    if not chosen.effects:
        return CrossValidation(0, 0.0, 0.0, "none")
    from .apply import calibrated_object

    kind, folds = _folds(trajectories)
    sse_nom = sse_cal = 0.0
    for rest, left in folds:
        # the chosen effects as they are (a stop only one run reaches keeps its place),
        # refitted from the full fit's values
        fold = fit_candidate(build_problem(obj, rest), chosen.effects, refine=False,
                             warm=dict(chosen.values), max_nfev=FOLD_NFEV)
        # what the fold's data cannot identify (a half without pushes says nothing of the
        # inertia) stays at the full fit's value rather than wherever the fold drifted
        fold = dataclasses.replace(fold, values={
            k: v if fold.identifiable.get(k, False) else chosen.values[k]
            for k, v in fold.values.items()})
        # the fold's model as it would be exported and the nominal one, each predicting
        # the left-out piece from its opening
        nominal, predicted = predict_beside(obj, calibrated_object(obj, fold), [left],
                                            predict(obj, [left]))
        sse_nom += _sse(nominal)
        sse_cal += _sse(predicted)
    return CrossValidation(len(folds), sse_nom, sse_cal, kind)


def cross_validate_effort(problem: Problem, chosen: Fit) -> CrossValidation:
    """The same test on the effort equation, where it chose the structure (a closed loop
    with its effort measured): refitted without each run (one run: without each half),
    the structure predicts the left-out effort better than the nominal model or is not
    kept."""
    if not chosen.effects:
        return CrossValidation(0, 0.0, 0.0, "none", "effort")
    rows = design(problem, chosen.effects).rows
    sizes = [len(idx) for _, _, idx in rows]
    starts = np.concatenate([[0], np.cumsum(sizes)])
    n = int(starts[-1])
    folds = []
    if len(problem.trajectories) >= 2:
        kind = "runs"
        for t in range(len(problem.trajectories)):
            left = np.zeros(n, bool)
            for b, (tb, _, _) in enumerate(rows):
                if tb == t:
                    left[starts[b]:starts[b + 1]] = True
            folds.append((~left, left))
    else:
        kind = "halves"
        first = np.zeros(n, bool)
        for b, (_, _, idx) in enumerate(rows):
            first[starts[b]:starts[b + 1]] = idx < np.median(idx)
        folds = [(~first, first), (first, ~first)]
    sse_nom, sse_cal = fold_errors(problem, chosen.effects, folds)
    return CrossValidation(len(folds), sse_nom, sse_cal, kind, "effort")
