"""Inverse-dynamics (equation-error) fit: the measured effort regressed on smoothed motion,
linear in the candidate's parameters (the IDIM least squares of robotics). Cheap, so every
candidate is scored this way first; its values start the simulation fit, which is the one
that decides (equation error is biased by the smoothing and the noise in the regressors).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares, lsq_linear

from . import features
from .effects import Effect
from .problem import Problem


@dataclass
class EquationFit:
    values: dict[str, float]  # param key -> value (clipped into bounds)
    rss: float
    n: int
    n_eff: float
    k: int
    effects: tuple[Effect, ...] = ()
    # parameter covariance (keys as ``values``), widened for the residual's correlation
    cov: dict[tuple[str, str], float] = field(default_factory=dict)
    # per effect name: how much it changes the effort (RMS, in effort-noise deviations)
    material: dict[str, float] = field(default_factory=dict)

    def bic(self, n_ref: float) -> float:
        if self.n == 0:
            return math.inf
        return n_ref * math.log(max(self.rss / self.n, 1e-300)) + self.k * math.log(
            max(n_ref, 2.0))

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(sorted(e.name for e in self.effects))

    def halfwidth(self, key: str) -> float:
        return 1.96 * math.sqrt(max(self.cov.get((key, key), math.inf), 0.0))

    def present(self, e: Effect, material: float) -> bool:
        """The effect is there: its departure from absence exceeds its 95 % interval and
        it changes the effort by at least ``material`` noise deviations (RMS)."""
        own = {p.name: self.values[p.key] for p in e.params}
        cov = {(a.name, b.name): self.cov.get((a.key, b.key), math.inf)
               for a in e.params for b in e.params}
        strength, se = e.strength(own, cov)
        return bool(strength > 1.96 * se) and self.material.get(e.name, 0.0) >= material

    def degenerate(self, limit: float) -> bool:
        """Parameters of two effects correlated beyond ``limit``: they explain the same
        thing."""
        owner = {p.key: e.name for e in self.effects for p in e.params}
        for a in owner:
            for b in owner:
                if owner[a] == owner[b]:
                    continue
                va, vb = self.cov.get((a, a), 0.0), self.cov.get((b, b), 0.0)
                if va > 0 and vb > 0 and math.isfinite(va * vb) and \
                        abs(self.cov.get((a, b), 0.0)) / math.sqrt(va * vb) > limit:
                    return True
        return False


def _smooth_sign(dq: np.ndarray, noise: float) -> np.ndarray:
    return np.tanh(dq / max(3.0 * noise, 1e-12))


def _nominal_effort(problem: Problem, joint: str, k: int, sig, names: set[str]) -> np.ndarray:
    """The model's own forces for the parts of the dynamics the candidate does not refit."""
    ctx = problem.contexts[joint]
    d = ctx.dynamics
    q, dq, ddq = sig.q[:, k], sig.dq[:, k], sig.ddq[:, k]
    sgn = _smooth_sign(dq, sig.dq_noise[k])
    out = np.zeros_like(q)
    if "inertia" not in names or not ctx.has_effort:
        out += sig.tau_rb[:, k]
    if "armature" not in names and not ("inertia" in names and not ctx.gravity_loaded):
        out += d.armature * ddq
    if not names & {"damping", "asymmetric_friction"}:
        out += d.damping * dq
    if not names & {"friction", "asymmetric_friction"}:
        out += d.friction * sgn
    if "spring" not in names:
        out += d.stiffness * (q - d.spring_ref)
    law = ctx.law
    if "offset" not in names:
        out -= law.offset
    if "asymmetric_friction" not in names:
        out += law.friction_asym + law.damping_asym * np.abs(dq)
    return out


SPIKE_SIGMAS = 3.0  # residuals beyond this many robust deviations weigh less (soft L1)


def _robust(x: np.ndarray, y: np.ndarray, coef: np.ndarray, colscale: np.ndarray,
            lb: np.ndarray, ub: np.ndarray) -> np.ndarray:
    """Refit with a soft-L1 loss when the residual has spikes (a motor's current-derived
    torque; samples at impacts): scale from the residual's median absolute deviation, so
    Gaussian noise is fitted as by least squares and spikes pull linearly, not
    quadratically."""
    r = y - x @ coef
    sigma = 1.4826 * float(np.median(np.abs(r - np.median(r))))
    if sigma <= 0 or not np.any(np.abs(r) > 2 * SPIKE_SIGMAS * sigma):
        return coef
    a = x / colscale
    start = np.clip(coef * colscale, lb, ub)
    res = least_squares(lambda c: a @ c - y, start, bounds=(lb, ub), loss="soft_l1",
                        f_scale=SPIKE_SIGMAS * sigma)
    return res.x / colscale


@dataclass
class Design:
    """The effort equation of one candidate, stacked over trajectories and joints (rows
    scaled by each joint's effort scale): y = x @ coef."""

    x: np.ndarray
    y: np.ndarray
    rows: list[tuple[int, int, np.ndarray]]  # (trajectory, joint, sample indices) per block
    noise: np.ndarray  # per row: the measured effort's noise, in the rows' scale
    columns: list[tuple[Effect, str]]
    lower: np.ndarray
    upper: np.ndarray


def design(problem: Problem, effects: tuple[Effect, ...]) -> Design:
    names_by_joint: dict[str, set[str]] = {j: set() for j in problem.joints}
    for e in effects:
        names_by_joint[e.joint].add(e.name)
    rows_y, rows_x, rows, noise = [], [], [], []
    col_index: list[tuple[Effect, str]] = []
    for e in effects:
        col_index.extend((e, name) for name in e.coefficient_names)
    for t, sig in enumerate(problem.signals):
        use = sig.usable
        for k, joint in enumerate(problem.joints):
            sgn = _smooth_sign(sig.dq[:, k], sig.dq_noise[k])
            y = sig.tau[:, k] - _nominal_effort(problem, joint, k, sig, names_by_joint[joint])
            x = np.zeros((len(y), len(col_index)))
            c = 0
            for e in effects:
                cols = e.columns(sig.q[:, k], sig.dq[:, k], sig.ddq[:, k], sig.tau_rb[:, k],
                                 sgn, sig.tau_rot[:, k], sig.tau_dq[:, k],
                                 sig.tau_dt[:, k]) \
                    if e.joint == joint else None
                width = len(e.coefficient_names)
                if cols is not None:
                    x[:, c:c + width] = cols[0]
                c += width
            scale = max(problem.contexts[joint].effort_scale, 1e-12)
            rows_y.append(y[use] / scale)
            rows_x.append(x[use] / scale)
            rows.append((t, k, np.flatnonzero(use)))
            # the rows hold the smoothed effort: its noise is the sensor's, smoothed
            sigma = float(problem.effort_noise[t][k]) * features.smoothing_gain(
                problem.trajectories[t].sample_period, sig.window) \
                if problem.effort_noise else 0.0
            noise.append(np.full(int(use.sum()), max(sigma, 1e-9 * scale) / scale))
    lower, upper = [], []
    for e, name in col_index:
        p = next((p for p in e.params if p.name == name), None)
        lower.append(p.lower if p is not None else -np.inf)
        upper.append(p.upper if p is not None else np.inf)
    return Design(np.concatenate(rows_x) if rows_x else np.zeros((0, len(col_index))),
                  np.concatenate(rows_y) if rows_y else np.zeros(0), rows,
                  np.concatenate(noise) if noise else np.zeros(0), col_index,
                  np.array(lower, float), np.array(upper, float))


def solve(x: np.ndarray, y: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Bounded least squares of y = x @ coef, refitted robustly where spikes remain."""
    coef = np.zeros(x.shape[1])
    if x.shape[1] and len(y):
        colscale = np.maximum(np.linalg.norm(x, axis=0), 1e-12)
        lb, ub = lower * colscale, upper * colscale
        res = lsq_linear(x / colscale, y, bounds=(lb, ub))
        coef = res.x / colscale
        coef = _robust(x, y, coef, colscale, lb, ub)
    return coef


def coefficients(e: Effect, v: dict[str, float]) -> dict[str, float]:
    """The regressor coefficients of ``e`` at parameter values ``v`` (the inverse of
    ``Effect.from_coefficients``)."""
    names = e.coefficient_names
    if e.name == "spring":
        return {"stiffness": v["stiffness"], "stiffness_x_ref": v["stiffness"] * v["spring_ref"]}
    if e.name == "inertia" and "scale_x_rotational" in names:
        return {"inertia_scale": v["inertia_scale"],
                "scale_x_rotational": v["inertia_scale"] * v["rotational_scale"]}
    if e.name == "inertia" and "rotational_excess" in names:
        return {"rotational_excess": v["rotational_scale"] - 1.0}
    return {name: v[name] for name in names}


def _values(effects: tuple[Effect, ...], coef: np.ndarray) -> dict[str, float]:
    values: dict[str, float] = {}
    c = 0
    for e in effects:
        names = e.coefficient_names
        if not names:
            for p in e.params:
                values[p.key] = p.nominal
            continue
        coefs = {name: float(coef[c + i]) for i, name in enumerate(names)}
        c += len(names)
        for p in e.params:
            v = e.from_coefficients(coefs)[p.name]
            values[p.key] = float(np.clip(v, p.lower, p.upper))
    return values


def _parameter_cov(effects, coef: np.ndarray, cov_c: np.ndarray) -> dict:
    """The coefficients' covariance carried to the parameters (the Jacobian of
    ``from_coefficients``, by differences)."""
    keys, jac_rows = [], []
    c = 0
    for e in effects:
        names = e.coefficient_names
        base = {name: float(coef[c + i]) for i, name in enumerate(names)}
        out0 = e.from_coefficients(base) if names else {}
        for p in e.params:
            row = np.zeros(len(coef))
            for i, name in enumerate(names):
                h = 1e-6 * max(abs(base[name]), 1e-6)
                moved = dict(base)
                moved[name] += h
                row[c + i] = (e.from_coefficients(moved)[p.name] - out0[p.name]) / h
            keys.append(p.key)
            jac_rows.append(row)
        c += len(names)
    if not keys:
        return {}
    jac = np.array(jac_rows)
    cov_p = jac @ cov_c @ jac.T
    return {(a, b): float(cov_p[i, k]) for i, a in enumerate(keys) for k, b in enumerate(keys)}


def _material(d: Design, effects, values: dict[str, float]) -> dict[str, float]:
    """How much each effect changes the effort from its absence (RMS over the rows, in
    effort-noise deviations)."""
    out: dict[str, float] = {}
    c = 0
    for e in effects:
        names = e.coefficient_names
        width = len(names)
        if not width:
            out[e.name] = math.inf
            continue
        own = {p.name: values[p.key] for p in e.params}
        null = e.null_values(own)
        if null is None:
            out[e.name] = math.inf
        else:
            now, absent = coefficients(e, own), coefficients(e, {**own, **null})
            delta = np.array([now[n] - absent[n] for n in names])
            change = d.x[:, c:c + width] @ delta / d.noise
            out[e.name] = float(np.sqrt(np.mean(change**2))) if len(change) else 0.0
        c += width
    return out


def equation_fit(problem: Problem, effects: tuple[Effect, ...]) -> EquationFit:
    """Least squares of the effort equation for one candidate structure, with the
    parameters' covariance (widened for the residual's correlation)."""
    d = design(problem, effects)
    coef = solve(d.x, d.y, d.lower, d.upper)
    resid = d.y - d.x @ coef if len(d.y) else d.y
    values = _values(effects, coef)
    n = len(resid)
    blocks = [len(idx) for _, _, idx in d.rows]
    n_eff = sum(features.effective_samples(r) for r in np.split(resid, np.cumsum(blocks)[:-1]))
    k = sum(len(e.params) for e in effects)
    cov: dict = {}
    material: dict = {}
    if len(coef) and n > len(coef):
        sigma2 = float(resid @ resid) / (n - len(coef))
        inflate = max(n / max(n_eff, 1.0), 1.0)
        cov_c = np.linalg.pinv(d.x.T @ d.x) * sigma2 * inflate
        cov = _parameter_cov(effects, coef, cov_c)
        material = _material(d, effects, values)
    return EquationFit(values, float(resid @ resid), n, n_eff, k, tuple(effects), cov,
                       material)


def fold_errors(problem: Problem, effects: tuple[Effect, ...],
                folds: list[tuple[np.ndarray, np.ndarray]]) -> tuple[float, float]:
    """Cross-validation of the effort equation: for each (fit rows, left-out rows) mask
    pair of the stacked design, the structure refitted on the fit rows predicts the
    left-out rows; the nominal model (no coefficient) predicts them too. The summed
    squared left-out errors (nominal, structure), in effort-noise units."""
    d = design(problem, effects)
    nominal = np.array([coefficients(e, {p.name: p.nominal for p in e.params})[name]
                        for e, name in d.columns])
    sse_nom = sse_cal = 0.0
    for fit_rows, left in folds:
        coef = solve(d.x[fit_rows], d.y[fit_rows], d.lower, d.upper)
        w = d.noise[left]
        sse_nom += float(np.sum(((d.y[left] - d.x[left] @ nominal) / w) ** 2))
        sse_cal += float(np.sum(((d.y[left] - d.x[left] @ coef) / w) ** 2))
    return sse_nom, sse_cal


def effort_errors(problem: Problem, effects: tuple[Effect, ...], values: dict[str, float]
                  ) -> list[dict]:
    """How well the effort equation with ``values`` (parameter key -> value; the nominal
    where absent) and the nominal model each predict the measured effort of every run and
    joint of ``problem``, runs they were not fitted on: per block the RMS error (effort
    units) and the squared error in effort-noise units."""
    d = design(problem, effects)
    nominal = np.array([coefficients(e, {p.name: p.nominal for p in e.params})[name]
                        for e, name in d.columns])
    fitted = np.array([coefficients(e, {p.name: values.get(p.key, p.nominal)
                                        for p in e.params})[name] for e, name in d.columns])
    out, start = [], 0
    for t, k, idx in d.rows:
        rows = slice(start, start + len(idx))
        start += len(idx)
        scale = max(problem.contexts[problem.joints[k]].effort_scale, 1e-12)
        errors = {}
        for label, coef in (("nominal", nominal), ("calibrated", fitted)):
            r = d.y[rows] - d.x[rows] @ coef if len(coef) else d.y[rows]
            errors[label] = (float(np.sqrt(np.mean(r**2))) * scale if len(r) else 0.0,
                             float(np.sum((r / d.noise[rows]) ** 2)))
        out.append({"file": problem.trajectories[t].source, "joint": problem.joints[k],
                    "rms_nominal": errors["nominal"][0], "rms_calibrated":
                    errors["calibrated"][0], "sse_nominal": errors["nominal"][1],
                    "sse_calibrated": errors["calibrated"][1]})
    return out
