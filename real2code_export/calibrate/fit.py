"""Output-error fit of one candidate: simulate the extended model in MuJoCo under the measured
conditions and adjust its parameters (and the unknown initial velocities) until the
simulated motion matches the measured one.

Parameters follow ``mujoco.sysid``'s design (``sysid.Parameter``: nominal, bounds and a
modifier writing the value into an MjSpec), and the 95 % intervals come from
``sysid.calculate_intervals`` (Jacobian at the optimum, Student t, infinite where the data
do not constrain a parameter). The optimiser is scipy's bounded ``least_squares`` called
here rather than through ``sysid.optimize``: that wrapper forces iteration printing in its
backends, and its rollout (a precomputed control sequence) cannot carry a feedback law or
a velocity-dependent force; our Jacobian also rolls out only the trajectory an initial
velocity belongs to.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from . import features
from .effects import Effect
from .inverse import EquationFit, equation_fit
from .problem import Problem
from .residuals import Evaluator, initial_slots, noise_floor
from .simulate import Rollout
from .uncertainty import Solution, input_noise_spread, loop_noise_cov, uncertainty

DEGENERATE = 0.999  # parameters of two effects this correlated explain the same thing
# An effect is named only if removing it moves the simulated motion by at least this many
# noise standard deviations (RMS): smaller ones are statistically visible in long records
# but are not worth a model change.
MATERIAL = 1.0
# The replay's own numerical error (sampled input, step size, soft dry friction) is
# measured by one replay this many times finer, with the input interpolated: the
# Gauss-Newton step it asks for corrects the estimate and widens its interval.
REFINE = 4
# A fit stops when an iteration lowers the squared residual by less than this share of
# one sample's part of it (rss / n): what the BIC and the 95 % intervals resolve is
# several such parts (an interval's edge is 3.84), so the rest would move no decision.
STOP_SHARE = 0.01
# A stop's softness (MuJoCo's solreflimit) has local minima: it starts from the best of
# this grid (time constants a factor of two to two and a half apart, and the time
# constant's upper bound: a soft stop with its edge inward is a valley of its own).
SOFTNESS_TIMECONSTS = (0.002, 0.004, 0.008, 0.016, 0.04)
SOFTNESS_DAMPRATIOS = (0.25, 0.6, 1.2, 2.5)
# A stop's fit leaving this many noise variances per sample gets a second start from the
# approach before the first impact (fitted on at least MIN_APPROACH samples).
SECOND_START = 1.5
MIN_APPROACH = 50


@dataclass
class Fit:
    effects: tuple[Effect, ...]
    values: dict[str, float]
    halfwidth: dict[str, float]
    cov: dict[tuple[str, str], float]
    identifiable: dict[str, bool]
    correlated: dict[str, list[str]]
    initial: list[np.ndarray]  # per trajectory (joints, 2): fitted initial position, velocity
    residual: np.ndarray  # normalised by the noise levels
    rss: float
    n_eff: float
    k: int
    simulated: list[Rollout]
    start: EquationFit | None = None
    rollouts: int = 0
    material: dict[str, float] = field(default_factory=dict)
    solution: object = field(default=None, repr=False)
    refined: bool = False

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(sorted(e.name for e in self.effects))

    @property
    def n(self) -> int:
        return int(self.residual.size)

    def bic(self, n_ref: float) -> float:
        """Bayesian information criterion counting ``n_ref`` effective samples (a correlated
        residual carries less evidence than its length; every candidate compared is
        scored with the same count)."""
        return n_ref * math.log(max(self.rss / self.n, 1e-300)) + self.k * math.log(
            max(n_ref, 2.0))

    def effect_values(self, e: Effect) -> dict[str, float]:
        return {p.name: self.values[p.key] for p in e.params}

    def effect_cov(self, e: Effect) -> dict[tuple[str, str], float]:
        out = {}
        for a in e.params:
            for b in e.params:
                out[(a.name, b.name)] = self.cov.get((a.key, b.key), math.inf)
        return out

    def degenerate(self) -> bool:
        """Two of its effects explain the same thing (a parameter of one moves with a
        parameter of another): naming both would force a cause."""
        keys = [p.key for e in self.effects for p in e.params]
        owner = {p.key: e.name for e in self.effects for p in e.params}
        for a in keys:
            for b in keys:
                if owner[a] == owner[b]:
                    continue
                va, vb = self.cov.get((a, a), 0.0), self.cov.get((b, b), 0.0)
                finite = va > 0 and vb > 0 and math.isfinite(va) and math.isfinite(vb)
                if finite and abs(self.cov.get((a, b), 0.0)) / math.sqrt(va * vb) > DEGENERATE:
                    return True
        return False

    def present(self, e: Effect) -> bool:
        """The effect is there: its departure from absence exceeds the 95 % interval, and
        it moves the simulated motion by more than the sensor noise (and direction-dependent
        friction dissipates both ways: :meth:`Effect.one_way`)."""
        strength, se = e.strength(self.effect_values(e), self.effect_cov(e))
        z = 1.96 if math.isfinite(se) else math.inf
        return bool(strength > z * se) and self.material.get(e.name, math.inf) >= MATERIAL \
            and not e.one_way(self.effect_values(e),
                              {p.name: self.halfwidth.get(p.key, math.inf) for p in e.params})


def fit_candidate(problem: Problem, effects: tuple[Effect, ...], max_nfev: int = 20,
                  refine: bool = True, warm: dict[str, float] | None = None,
                  second_start: bool = True) -> Fit:
    """Fit one candidate structure (an empty tuple: the nominal model, initial state only);
    ``refine``: also measure the replay's numerical error (:func:`refine_fit`); ``warm``:
    start values (by parameter key) from a fit already made, the inverse dynamics
    starting the rest; ``second_start``: a stop's fit that leaves more than the noise is
    started again from its approach (:func:`_second_start`)."""
    effects = tuple(sorted(effects, key=lambda e: (e.joint, e.name)))
    start = equation_fit(problem, effects) if effects else None
    params = [p for e in effects for p in e.params]
    slots = initial_slots(problem)
    warm = warm or {}
    x0_theta, lb, ub, scales, origin = [], [], [], [], []
    for p in params:
        v = warm.get(p.key, start.values[p.key] if start is not None else p.nominal)
        scale = max(abs(v), abs(p.nominal), 1e-3 * (p.upper - p.lower), 1e-12)
        x0_theta.append(min(max(v, p.lower), p.upper))
        lb.append(p.lower)
        ub.append(p.upper)
        scales.append(scale)
        origin.append(0.0)
    for t, k, c in slots:
        v = float(warm.get(f"initial:{t}:{k}:{c}", problem.initial[t][k, c]))
        se = float(problem.initial_stderr[t][k, c])
        # the data say where the run starts: a poor candidate must not buy its fit by
        # moving the start (on a long oscillation it could, to another phase)
        slack = max(50 * se, 10 * float(problem.position_noise[t][k])) if c == 0 else \
            max(50 * se, 0.2 * abs(v))
        x0_theta.append(v)
        lb.append(v - slack)
        ub.append(v + slack)
        scales.append(max(abs(v) if c == 1 else 0.0, 10 * se, 1e-9))
        origin.append(v)
    scales_a, origin_a = np.array(scales, float), np.array(origin, float)
    ev = Evaluator(problem, effects, scales_a, origin=origin_a)
    x0 = (np.array(x0_theta, float) - origin_a) / scales_a
    x0 = _start_limit_softness(ev, params, x0, scales_a)
    lb_a = (np.array(lb, float) - origin_a) / scales_a
    ub_a = (np.array(ub, float) - origin_a) / scales_a
    # a start on a bound stalls the trust region: nudge inside
    width = np.where(np.isfinite(ub_a - lb_a), ub_a - lb_a, 1.0)
    x0 = np.clip(x0, lb_a + 1e-6 * width, ub_a - 1e-6 * width)

    last: dict[str, object] = {}

    def fun(x):
        r, ros = ev.residual(x)
        last["x"], last["r"], last["ros"] = x.copy(), r, ros
        return r

    def jac(x):
        if last.get("x") is None or not np.array_equal(last["x"], x):
            fun(x)
        return ev.jacobian(x, last["r"], ub_a, last["ros"])

    if len(x0):
        n = int(ev.offsets[-1]) + len(problem.links) * len(problem.joints)
        res = _solve(fun, jac, x0, lb_a, ub_a, max_nfev, n)
        if second_start and 2 * res.cost / n > SECOND_START:
            res = _second_start(ev, params, res, fun, jac, lb_a, ub_a, max_nfev, n)
        x_star = res.x
        jmat = res.jac
        if not np.array_equal(last.get("x"), x_star):
            fun(x_star)
    else:
        x_star = x0
        fun(x_star)
        jmat = np.zeros((len(last["r"]), 0))
    sol = Solution(problem, ev, x_star, jmat, scales_a, lb_a, ub_a, last["r"], last["ros"],
                    start)
    fit = _finish(sol, np.zeros(len(x_star)))
    return refine_fit(fit) if refine else fit


def _finish(sol: Solution, numerical: np.ndarray, loop_cov: np.ndarray | None = None
            ) -> Fit:
    problem, ev, r = sol.problem, sol.ev, sol.r
    values, x0 = ev.split(sol.x)
    n_eff = sum(features.effective_samples(r[ev.offsets[t]:ev.offsets[t + 1]])
                for t in range(len(problem.trajectories)))
    halfwidth, cov, ident, corr, material = uncertainty(ev, r, sol.jac, sol.scales, n_eff,
                                                         values, problem, sol.x, numerical,
                                                         sol.ros, loop_cov)
    return Fit(ev.effects, values, halfwidth, cov, ident, corr, x0, r, float(r @ r), n_eff,
               len(ev.params), sol.ros, sol.start, ev.count, material=material,
               solution=sol, refined=not len(sol.x))


def refine_fit(fit: Fit) -> Fit:
    """Measure the replay's numerical error: one replay ``REFINE`` times finer (input
    interpolated, dry friction stiffer) at the estimate; the Gauss-Newton step it asks for
    corrects the estimate and is added to its interval. The residual (hence the BIC) stays
    the one every candidate was compared on."""
    sol = fit.solution
    if fit.refined or sol is None or not sol.ev.params:
        return fit  # no effect parameters (a replay): only initial states, nothing to refine
    ref = Evaluator(sol.problem, sol.ev.effects, sol.scales, refine=REFINE,
                    origin=sol.ev.origin)
    r_ref, _ = ref.residual(sol.x)
    sol.ev.count += REFINE * len(sol.problem.trajectories)
    step = -np.linalg.lstsq(sol.jac, r_ref, rcond=1e-8)[0]
    # Along directions the data barely constrain the Gauss-Newton step can be huge: take
    # it only as far as it lowers the fine replay's residual.
    cost = float(r_ref @ r_ref)
    x_corr = sol.x
    for _ in range(4):
        trial = np.clip(sol.x + step, sol.lb, sol.ub)
        r_trial, _ = ref.residual(trial)
        sol.ev.count += REFINE * len(sol.problem.trajectories)
        if float(r_trial @ r_trial) <= cost:
            x_corr = trial
            break
        step = step / 4
    numerical = np.sqrt((x_corr - sol.x) ** 2 + input_noise_spread(sol) ** 2)
    refined = _finish(Solution(sol.problem, sol.ev, x_corr, sol.jac, sol.scales, sol.lb,
                                sol.ub, sol.r, sol.ros, sol.start), numerical,
                      loop_noise_cov(sol))
    refined.refined = True
    for e in sol.ev.effects:
        if e.name == "limit":  # how much the stop moves the motion: replay without it
            refined.material["limit"] = _without_stop(sol, e)
    return refined


def _without_stop(sol: Solution, stop: Effect) -> float:
    ev = sol.ev
    limits = stop.ctx.limits
    lo, hi = (limits.lower, limits.upper) if limits is not None else (-1e6, 1e6)
    x = sol.x.copy()
    for i, prm in enumerate(ev.params):
        if prm.effect == "limit" and prm.name in ("limit_lower", "limit_upper"):
            x[i] = (lo if prm.name == "limit_lower" else hi) / sol.scales[i]
    r, _ = ev.residual(x)
    return float(np.sqrt(np.mean((r - sol.r) ** 2)))


def _solve(fun, jac, x0, lb, ub, max_nfev, n):
    # (the variables are in units of their scales and start near zero, so scipy's
    # relative step tolerance is left tight and its Jacobian scaling evens them out)
    return least_squares(fun, x0, jac=jac, bounds=(lb, ub), method="trf",
                         max_nfev=max_nfev, xtol=1e-5, ftol=max(STOP_SHARE / n, 1e-12),
                         gtol=1e-8, x_scale="jac")


def _second_start(ev: Evaluator, params, first, fun, jac, lb, ub, max_nfev, n):
    """A stop whose fit leaves more than the noise may sit in another minimum of its
    softness: fit the approach before the first impact alone (the stop plays no part
    there, so the initial state and the other effects come from the free motion), start
    the softness from the grid at that point, fit the whole again, keep the better."""
    mask = _before_impact(ev, params, first.x)
    if mask is None:
        return first
    approach = _solve(lambda x: fun(x) * mask, lambda x: jac(x) * mask[:, None], first.x,
                      lb, ub, max_nfev, n)
    x1 = _start_limit_softness(ev, params, approach.x, ev.scales)
    width = np.where(np.isfinite(ub - lb), ub - lb, 1.0)
    x1 = np.clip(x1, lb + 1e-6 * width, ub - 1e-6 * width)
    second = _solve(fun, jac, x1, lb, ub, max_nfev, n)
    return second if second.cost < first.cost else first


def _before_impact(ev: Evaluator, params, x: np.ndarray) -> np.ndarray | None:
    """Residual rows of the samples before a run first reaches a fitted stop (within
    three noise deviations of its edge); None where there is no stop or no approach
    long enough to fit."""
    values, _ = ev.split(x)
    pr = ev.problem
    edges = [(p.joint, p.name, values[p.key]) for p in params
             if p.name in ("limit_lower", "limit_upper")]
    if not edges:
        return None
    nj = len(pr.joints)
    mask = np.zeros(int(ev.offsets[-1]) + len(pr.links) * nj)
    kept = 0
    for t, tr in enumerate(pr.trajectories):
        cut = tr.n
        for j, side, edge in edges:
            k = pr.joints.index(j)
            q = tr.positions[j]
            band = 3 * noise_floor(pr.position_noise[t][k], q)
            hit = q >= edge - band if side == "limit_upper" else q <= edge + band
            if hit.any():
                cut = min(cut, int(np.argmax(hit)))
        for k in range(nj):
            a = int(ev.offsets[t]) + k * tr.n
            mask[a:a + cut] = 1.0
        kept += cut
    return mask if kept >= max(MIN_APPROACH, 4 * len(x)) else None


def _start_limit_softness(ev: Evaluator, params, x0: np.ndarray, scales: np.ndarray
                          ) -> np.ndarray:
    """An end stop's softness has local minima: start from the best of a small grid of
    time constants and damping ratios and the given start (a fit continued from its own
    values must not lose them; one rollout each, in one batch)."""
    idx_tc = [i for i, p in enumerate(params) if p.name == "limit_timeconst"]
    idx_dr = [i for i, p in enumerate(params) if p.name == "limit_dampratio"]
    if not idx_tc:
        return x0
    points = [x0.copy()]
    for tc in (*SOFTNESS_TIMECONSTS, math.inf):  # (inf: each one's upper bound)
        for dr in SOFTNESS_DAMPRATIOS:
            x = x0.copy()
            for i in idx_tc:
                x[i] = min(max(tc, params[i].lower), params[i].upper) / scales[i]
            for i in idx_dr:
                x[i] = min(max(dr, params[i].lower), params[i].upper) / scales[i]
            points.append(x)
    costs = np.zeros(len(points))
    for t in range(len(ev.problem.trajectories)):
        for n, (r, _) in enumerate(ev.run(t, points)):
            costs[n] += float(r @ r)
    return points[int(np.argmin(costs))]


