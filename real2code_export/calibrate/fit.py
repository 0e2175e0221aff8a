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

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from . import features
from .effects import Effect
from .inverse import EquationFit, equation_fit
from .problem import Problem
from .simulate import MAX_TIMESTEP, AppliedLaw, BatchRunner, Rollout, compile_spec

FD_STEP = 3e-4  # forward-difference step, relative to each parameter's scale
CORRELATED = 0.995
DEGENERATE = 0.999  # parameters of two effects this correlated explain the same thing
# An effect is named only if removing it moves the simulated motion by at least this many
# noise standard deviations (RMS): smaller ones are statistically visible in long records
# but are not worth a model change.
MATERIAL = 1.0
# The replay's own numerical error (sampled input, step size, soft dry friction) is
# measured by one replay this many times finer, with the input interpolated: the
# Gauss-Newton step it asks for corrects the estimate and widens its interval.
REFINE = 4
# Multiple shooting: a gap of one noise deviation between a piece's replayed end and the
# next piece's start weighs as much as CONTINUITY**2 samples off by one deviation
CONTINUITY = 10.0


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
        it moves the simulated motion by more than the sensor noise."""
        strength, se = e.strength(self.effect_values(e), self.effect_cov(e))
        z = 1.96 if math.isfinite(se) else math.inf
        return bool(strength > z * se) and self.material.get(e.name, math.inf) >= MATERIAL


def sysid_parameters(effects: tuple[Effect, ...]):
    """The candidate's parameters as a ``mujoco.sysid.ParameterDict`` (one vector
    parameter per effect; its modifier writes the effect into an MjSpec)."""
    from mujoco import sysid

    pd = sysid.ParameterDict()
    for e in effects:
        pd.add(e.sysid_parameter())
    return pd


def laws_for(effects: tuple[Effect, ...], values: dict[str, float],
             base: dict[str, AppliedLaw] | None = None) -> dict[str, AppliedLaw]:
    """Applied-force laws per joint: the model's own, with the candidate's effects in
    place of the terms they refit."""
    out = dict(base or {})
    for e in effects:
        old = out.get(e.joint, AppliedLaw())
        law = e.law({p.name: values[p.key] for p in e.params})
        if e.name == "offset":
            out[e.joint] = AppliedLaw(law.offset, old.friction_asym, old.damping_asym)
        elif e.name == "asymmetric_friction":
            out[e.joint] = AppliedLaw(old.offset, law.friction_asym, law.damping_asym)
    return out


def build_model(problem: Problem, effects: tuple[Effect, ...], values: dict[str, float],
                refine: int = 1):
    """Compile the candidate: the nominal replay spec with each effect's sysid parameter
    modifier applied. ``refine`` > 1: the reference replay (dry friction as stiff as its
    finer step allows)."""
    from mujoco import sysid

    params = sysid_parameters(effects)
    params.update_from_vector(np.array([values[p.key] for e in effects for p in e.params]))
    spec = problem.spec.copy()
    if refine > 1:
        for name in problem.joints:
            spec.joint(name).solref_friction = [2 * MAX_TIMESTEP / refine, 1.0]
    return compile_spec(sysid.apply_param_modifiers_spec(params, spec))


NONSMOOTH = {"friction", "asymmetric_friction", "limit"}


def initial_slots(problem: Problem) -> list[tuple[int, int, int]]:
    """(trajectory, joint, 0 position / 1 velocity) of every fitted initial-state value."""
    return [(t, k, c) for t, free in enumerate(problem.initial_free)
            for k in range(len(problem.joints)) for c in (0, 1) if free[k, c]]


class _Evaluator:
    """Residuals of one candidate as a function of the scaled parameter vector."""

    def __init__(self, problem: Problem, effects: tuple[Effect, ...], scales: np.ndarray,
                 refine: int = 1):
        self.problem = problem
        self.refine = refine
        self.effects = effects
        self.scales = scales
        self.params = [p for e in effects for p in e.params]
        self.slots = initial_slots(problem)
        self.fine = problem.nonsmooth or any(e.name in NONSMOOTH for e in effects)
        self.count = 0
        self._models: dict[tuple, object] = {}
        self._lagged: dict[tuple, BatchRunner] = {}
        self.runners = [BatchRunner(tr, problem.joints) for tr in problem.trajectories]
        sizes = [tr.n * len(problem.joints) for tr in problem.trajectories]
        self.offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(int)

    def split(self, x: np.ndarray):
        theta = x * self.scales
        values = {p.key: float(theta[i]) for i, p in enumerate(self.params)}
        x0 = [v.copy() for v in self.problem.initial]
        for i, (t, k, c) in enumerate(self.slots):
            x0[t][k, c] = float(theta[len(self.params) + i])
        return values, x0

    def model(self, values: dict[str, float]):
        key = tuple(values[p.key] for p in self.params)
        if key not in self._models:
            if len(self._models) > 64:
                self._models.clear()
            self._models[key] = build_model(self.problem, self.effects, values, self.refine)
        return self._models[key]

    def _block(self, t: int, ro: Rollout) -> np.ndarray:
        pr = self.problem
        tr = pr.trajectories[t]
        # Positions only, also in closed loop: there the recorded effort is the feedback
        # law applied to the measured positions, so fitting it too would count the same
        # information twice (the simulated effort is compared in the report).
        parts = []
        for k, j in enumerate(pr.joints):
            sigma = _floor(pr.position_noise[t][k], tr.positions[j])
            parts.append((ro.positions[:, k] - tr.positions[j]) / sigma)
        return np.concatenate(parts)

    def run(self, t: int, points: list[np.ndarray], runner: BatchRunner | None = None
            ) -> list[tuple[np.ndarray, Rollout]]:
        """Residual block of trajectory ``t`` and its rollout at each point (``runner``:
        another replay of the same trajectory, e.g. with a perturbed input)."""
        if not points:
            return []
        models, initials, laws, zeros = [], [], [], []
        for x in points:
            values, x0 = self.split(x)
            models.append(self.model(values))
            # the initial state is fitted as read; the joint starts at the reading less the
            # encoder's zero error, and what the encoder reads is compared with the data
            zero = self.sensor_offsets(values)
            zeros.append(zero)
            initials.append({j: (float(x0[t][k, 0] - zero[k]), float(x0[t][k, 1]))
                             for k, j in enumerate(self.problem.joints)})
            laws.append(laws_for(self.effects, values, self.problem.base_laws))
        self.count += len(points)
        ros: list = [None] * len(points)
        groups: dict[tuple, list[int]] = {}
        for i, x in enumerate(points):  # points with one lag replay one input
            groups.setdefault(self.delays(self.split(x)[0]), []).append(i)
        for lag, idx in groups.items():
            use = self._runner(t, lag, runner)
            out = use.run([models[i] for i in idx], [initials[i] for i in idx],
                          [laws[i] for i in idx], self.fine, self.refine)
            for i, ro in zip(idx, out, strict=True):
                ros[i] = ro
        for zero, ro in zip(zeros, ros, strict=True):
            if np.any(zero):
                ro.positions = ro.positions + zero
        return [(self._block(t, ro), ro) for ro in ros]

    def delays(self, values: dict[str, float]) -> tuple[float, ...]:
        pr = self.problem
        return tuple(values.get(f"{j}.effort_delay", pr.contexts[j].effort_delay)
                     for j in pr.joints)

    def _runner(self, t: int, lag: tuple[float, ...], given: BatchRunner | None = None
                ) -> BatchRunner:
        """The replay of trajectory ``t`` (or of ``given``'s input) with each joint's effort
        felt ``lag`` seconds after it was recorded (cached: a fit tries few lags)."""
        base = given if given is not None else self.runners[t]
        if not any(lag):
            return base
        key = (t, lag)
        if given is None and key in self._lagged:
            return self._lagged[key]
        tr = base.traj
        efforts = {j: np.interp(tr.time - lag[k], tr.time, tr.efforts[j])
                   for k, j in enumerate(self.problem.joints) if j in tr.efforts}
        lagged = BatchRunner(dataclasses.replace(tr, efforts=efforts), self.problem.joints)
        if given is None:
            if len(self._lagged) > 16:
                self._lagged.clear()
            self._lagged[key] = lagged
        return lagged

    def sensor_offsets(self, values: dict[str, float]) -> np.ndarray:
        pr = self.problem
        return np.array([values.get(f"{j}.encoder_offset", pr.contexts[j].sensor_offset)
                         for j in pr.joints])

    def residual(self, x: np.ndarray) -> tuple[np.ndarray, list[Rollout]]:
        out = [self.run(t, [x])[0] for t in range(len(self.problem.trajectories))]
        ros = [ro for _, ro in out]
        links = [self._link(ros[a], x, b) for a, b in self.problem.links]
        return np.concatenate([r for r, _ in out] + links), ros

    def _link(self, ro_prev: Rollout, x: np.ndarray, nxt: int) -> np.ndarray:
        """Continuity between pieces of one run: where the previous piece's replay ends
        against where the next one's fitted start is (noise units, CONTINUITY weight)."""
        pr = self.problem
        _, x0 = self.split(x)
        out = np.empty(len(pr.joints))
        for k, j in enumerate(pr.joints):
            sigma = _floor(pr.position_noise[nxt][k], pr.trajectories[nxt].positions[j])
            out[k] = CONTINUITY * (ro_prev.positions[-1, k] - x0[nxt][k, 0]) / sigma
        return out

    def jacobian(self, x: np.ndarray, r0: np.ndarray, ub: np.ndarray) -> np.ndarray:
        """Forward differences; an initial velocity moves only its own trajectory."""
        p = len(self.params)
        steps = []
        for i in range(len(x)):
            h = FD_STEP if x[i] + FD_STEP <= ub[i] else -FD_STEP
            steps.append(h)
        jmat = np.zeros((len(r0), len(x)))
        for t in range(len(self.problem.trajectories)):
            cols = list(range(p)) + [p + i for i, slot in enumerate(self.slots) if slot[0] == t]
            points = []
            for c in cols:
                x1 = x.copy()
                x1[c] += steps[c]
                points.append(x1)
            a, b = self.offsets[t], self.offsets[t + 1]
            for c, x1, (r1, ro) in zip(cols, points, self.run(t, points), strict=True):
                jmat[a:b, c] = (r1 - r0[a:b]) / steps[c]
                for n, (prev, nxt) in enumerate(self.problem.links):
                    if prev == t:
                        rows = self._link_rows(n)
                        jmat[rows, c] = (self._link(ro, x1, nxt) - r0[rows]) / steps[c]
        # the next piece's start enters its link directly
        for n, (_, nxt) in enumerate(self.problem.links):
            rows = self._link_rows(n)
            for i, (t, k, c) in enumerate(self.slots):
                if t == nxt and c == 0:
                    j = self.problem.joints[k]
                    sigma = _floor(self.problem.position_noise[nxt][k],
                                   self.problem.trajectories[nxt].positions[j])
                    jmat[rows[k], p + i] = -CONTINUITY * self.scales[p + i] / sigma
        return jmat

    def _link_rows(self, n: int) -> np.ndarray:
        nj = len(self.problem.joints)
        return self.offsets[-1] + n * nj + np.arange(nj)


def _floor(sigma: float, x: np.ndarray) -> float:
    return max(float(sigma), 1e-6 * max(float(np.ptp(x)), 1e-3), 1e-12)


def fit_candidate(problem: Problem, effects: tuple[Effect, ...], max_nfev: int = 20,
                  refine: bool = True, warm: dict[str, float] | None = None) -> Fit:
    """Fit one candidate structure (an empty tuple: the nominal model, initial state only);
    ``refine``: also measure the replay's numerical error (:func:`refine_fit`); ``warm``:
    start values (by parameter key) from a fit already made, the inverse dynamics
    starting the rest."""
    effects = tuple(sorted(effects, key=lambda e: (e.joint, e.name)))
    start = equation_fit(problem, effects) if effects else None
    params = [p for e in effects for p in e.params]
    slots = initial_slots(problem)
    warm = warm or {}
    x0_theta, lb, ub, scales = [], [], [], []
    for p in params:
        v = warm.get(p.key, start.values[p.key] if start is not None else p.nominal)
        scale = max(abs(v), abs(p.nominal), 1e-3 * (p.upper - p.lower), 1e-12)
        x0_theta.append(min(max(v, p.lower), p.upper))
        lb.append(p.lower)
        ub.append(p.upper)
        scales.append(scale)
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
    scales_a = np.array(scales, float)
    ev = _Evaluator(problem, effects, scales_a)
    x0 = np.array(x0_theta, float) / scales_a
    x0 = _start_limit_softness(ev, params, x0, scales_a)
    lb_a = np.array(lb, float) / scales_a
    ub_a = np.array(ub, float) / scales_a
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
        return ev.jacobian(x, last["r"], ub_a)

    if len(x0):
        res = least_squares(fun, x0, jac=jac, bounds=(lb_a, ub_a), method="trf",
                            max_nfev=max_nfev, xtol=1e-5, ftol=1e-7, gtol=1e-8)
        x_star = res.x
        jmat = res.jac
        if not np.array_equal(last.get("x"), x_star):
            fun(x_star)
    else:
        x_star = x0
        fun(x_star)
        jmat = np.zeros((len(last["r"]), 0))
    sol = _Solution(problem, ev, x_star, jmat, scales_a, lb_a, ub_a, last["r"], last["ros"],
                    start)
    fit = _finish(sol, np.zeros(len(x_star)))
    return refine_fit(fit) if refine else fit


@dataclass
class _Solution:
    """What a fit needs to be finished again (after the numerical refinement)."""

    problem: Problem
    ev: _Evaluator
    x: np.ndarray
    jac: np.ndarray
    scales: np.ndarray
    lb: np.ndarray
    ub: np.ndarray
    r: np.ndarray
    ros: list
    start: EquationFit | None


def _finish(sol: _Solution, numerical: np.ndarray) -> Fit:
    problem, ev, r = sol.problem, sol.ev, sol.r
    values, x0 = ev.split(sol.x)
    n_eff = sum(features.effective_samples(r[ev.offsets[t]:ev.offsets[t + 1]])
                for t in range(len(problem.trajectories)))
    halfwidth, cov, ident, corr, material = _uncertainty(ev, r, sol.jac, sol.scales, n_eff,
                                                         values, problem, sol.x, numerical,
                                                         sol.ros)
    return Fit(ev.effects, values, halfwidth, cov, ident, corr, x0, r, float(r @ r), n_eff,
               len(ev.params), sol.ros, sol.start, ev.count, material=material,
               solution=sol, refined=not len(sol.x))


def refine_fit(fit: Fit) -> Fit:
    """Measure the replay's numerical error: one replay ``REFINE`` times finer (input
    interpolated, dry friction stiffer) at the estimate; the Gauss-Newton step it asks for
    corrects the estimate and is added to its interval. The residual (hence the BIC) stays
    the one every candidate was compared on."""
    sol = fit.solution
    if fit.refined or sol is None or not len(sol.x):
        return fit
    ref = _Evaluator(sol.problem, sol.ev.effects, sol.scales, refine=REFINE)
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
    numerical = np.sqrt((x_corr - sol.x) ** 2 + _input_noise_spread(sol) ** 2)
    refined = _finish(_Solution(sol.problem, sol.ev, x_corr, sol.jac, sol.scales, sol.lb,
                                sol.ub, sol.r, sol.ros, sol.start), numerical)
    refined.refined = True
    for e in sol.ev.effects:
        if e.name == "limit":  # how much the stop moves the motion: replay without it
            refined.material["limit"] = _without_stop(sol, e)
    return refined


INPUT_NOISE_DRAWS = 4


def _input_noise_spread(sol: _Solution) -> np.ndarray:
    """What the noise on the measured effort does to the estimate (the fit treats the
    input as exact): replays with the input perturbed by its own noise level (seeded
    draws), mapped to parameters through the Jacobian; 1.96 standard deviations."""
    problem, ev = sol.problem, sol.ev
    shifts = []
    rng = np.random.default_rng(0)
    for _ in range(INPUT_NOISE_DRAWS):
        dr = np.zeros_like(sol.r)
        for t, tr in enumerate(problem.trajectories):
            if tr.law() is not None or not tr.efforts:
                continue
            sigma = problem.effort_noise[t]
            efforts = {j: e + rng.normal(0.0, sigma[problem.joints.index(j)], len(e))
                       for j, e in tr.efforts.items()}
            noisy = dataclasses.replace(tr, efforts=efforts)
            (r1, _), = ev.run(t, [sol.x], BatchRunner(noisy, problem.joints))
            a, b = ev.offsets[t], ev.offsets[t + 1]
            dr[a:b] = r1 - sol.r[a:b]
        if np.any(dr):
            shifts.append(np.linalg.lstsq(sol.jac, dr, rcond=None)[0])
    if not shifts:
        return np.zeros(len(sol.x))
    return 1.96 * np.sqrt(np.mean(np.square(shifts), axis=0))


def _without_stop(sol: _Solution, stop: Effect) -> float:
    ev = sol.ev
    limits = stop.ctx.limits
    lo, hi = (limits.lower, limits.upper) if limits is not None else (-1e6, 1e6)
    x = sol.x.copy()
    for i, prm in enumerate(ev.params):
        if prm.effect == "limit" and prm.name in ("limit_lower", "limit_upper"):
            x[i] = (lo if prm.name == "limit_lower" else hi) / sol.scales[i]
    r, _ = ev.residual(x)
    return float(np.sqrt(np.mean((r - sol.r) ** 2)))


def _start_limit_softness(ev: _Evaluator, params, x0: np.ndarray, scales: np.ndarray
                          ) -> np.ndarray:
    """An end stop's softness has local minima: start from the best of a small grid of
    time constants and damping ratios (one rollout each, in one batch)."""
    idx_tc = [i for i, p in enumerate(params) if p.name == "limit_timeconst"]
    idx_dr = [i for i, p in enumerate(params) if p.name == "limit_dampratio"]
    if not idx_tc:
        return x0
    points = []
    for tc in (0.003, 0.01, 0.03):
        for dr in (0.3, 1.0, 2.0):
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


def _uncertainty(ev: _Evaluator, r, jmat, scales, n_eff, values, problem, x_star, numerical,
                 rollouts):
    """95 % half-widths (sysid's Jacobian intervals, widened for residual correlation),
    the covariance, which parameters the data cannot identify, strong correlations, and
    how much each effect moves the simulated motion (RMS, in noise standard deviations:
    the Jacobian times the step back to the effect's absence)."""
    from mujoco import sysid

    p = len(ev.params)
    halfwidth: dict[str, float] = {}
    cov: dict[tuple[str, str], float] = {}
    ident: dict[str, bool] = {}
    corr: dict[str, list[str]] = {}
    material: dict[str, float] = {}
    if p == 0:
        return halfwidth, cov, ident, corr, material
    inflate = math.sqrt(max(len(r) / max(n_eff, 1.0), 1.0))
    sigma_x, hw = sysid.calculate_intervals([r], jmat)
    sigma_x = np.asarray(sigma_x)[:p, :p] * inflate**2
    hw = np.asarray(hw)[:p] * inflate
    for i, a in enumerate(ev.params):
        # statistical half-width plus the replay's numerical error, added linearly
        num = float(numerical[i] * scales[i])
        halfwidth[a.key] = float(hw[i] * scales[i]) + num
        for k, b in enumerate(ev.params):
            cov[(a.key, b.key)] = float(sigma_x[i, k] * scales[i] * scales[k])
        cov[(a.key, a.key)] = (math.sqrt(max(cov[(a.key, a.key)], 0.0)) + num / 1.96) ** 2
    for i, a in enumerate(ev.params):
        h = halfwidth[a.key]
        v = values[a.key]
        if a.unit in ("rad", "m"):
            ctx = problem.contexts[a.joint]
            ref = max(ctx.q_high - ctx.q_low, 1e-9)
        else:
            ref = max(abs(v), 1e-12)
        ident[a.key] = bool(math.isfinite(h) and h < 0.5 * ref)
        others = []
        for k, b in enumerate(ev.params):
            if k == i:
                continue
            denom = math.sqrt(abs(sigma_x[i, i] * sigma_x[k, k]))
            if denom > 0 and abs(sigma_x[i, k]) / denom > CORRELATED:
                others.append(b.key)
        if others:
            corr[a.key] = others
    for e in ev.effects:
        if e.name != "limit":
            continue
        # The stop's contact law is MuJoCo's soft constraint; a stop of another law would
        # put the same motion's stop elsewhere by up to how deep the joint goes into it.
        k = problem.joints.index(e.joint)
        for prm in e.params:
            side = {"limit_upper": 1.0, "limit_lower": -1.0}.get(prm.name)
            if side is None:
                continue
            depth = max(float(np.max(side * (ro.positions[:, k] - values[prm.key])))
                        for ro in rollouts)
            halfwidth[prm.key] += max(depth, 0.0)
    index = {prm.key: i for i, prm in enumerate(ev.params)}
    for e in ev.effects:
        own = {prm.name: values[prm.key] for prm in e.params}
        null = e.null_values(own)
        if null is None:
            material[e.name] = math.inf
            continue
        dx = np.zeros(len(x_star))
        for name, v in null.items():
            i = index[f"{e.joint}.{name}"]
            dx[i] = (v - own[name]) / scales[i]
        material[e.name] = float(np.sqrt(np.mean((jmat @ dx) ** 2)))
    return halfwidth, cov, ident, corr, material
