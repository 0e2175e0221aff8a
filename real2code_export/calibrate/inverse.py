"""Inverse-dynamics (equation-error) fit: the measured effort regressed on smoothed motion,
linear in the candidate's parameters (the IDIM least squares of robotics). Cheap, so every
candidate is scored this way first; its values start the simulation fit, which is the one
that decides (equation error is biased by the smoothing and the noise in the regressors).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

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

    def bic(self, n_ref: float) -> float:
        if self.n == 0:
            return math.inf
        return n_ref * math.log(max(self.rss / self.n, 1e-300)) + self.k * math.log(
            max(n_ref, 2.0))


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


def equation_fit(problem: Problem, effects: tuple[Effect, ...]) -> EquationFit:
    """Least squares of the effort equation for one candidate structure."""
    names_by_joint: dict[str, set[str]] = {j: set() for j in problem.joints}
    for e in effects:
        names_by_joint[e.joint].add(e.name)
    rows_y, rows_x, blocks = [], [], []
    col_index: list[tuple[Effect, str]] = []
    for e in effects:
        col_index.extend((e, name) for name in e.coefficient_names)
    for sig in problem.signals:
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
            blocks.append(int(use.sum()))
    y = np.concatenate(rows_y) if rows_y else np.zeros(0)
    x = np.concatenate(rows_x) if rows_x else np.zeros((0, len(col_index)))
    coef = np.zeros(len(col_index))
    if len(col_index) and len(y):
        lower, upper = [], []
        for e, name in col_index:
            p = next((p for p in e.params if p.name == name), None)
            lower.append(p.lower if p is not None else -np.inf)
            upper.append(p.upper if p is not None else np.inf)
        colscale = np.maximum(np.linalg.norm(x, axis=0), 1e-12)
        lb, ub = np.array(lower) * colscale, np.array(upper) * colscale
        res = lsq_linear(x / colscale, y, bounds=(lb, ub))
        coef = res.x / colscale
        coef = _robust(x, y, coef, colscale, lb, ub)
    resid = y - x @ coef if len(y) else y
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
    n = len(resid)
    n_eff = sum(features.effective_samples(r) for r in np.split(resid, np.cumsum(blocks)[:-1]))
    k = sum(len(e.params) for e in effects)
    return EquationFit(values, float(resid @ resid), n, n_eff, k)
