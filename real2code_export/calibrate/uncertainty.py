"""How sure a fitted candidate is: 95 % intervals from ``mujoco.sysid``'s Jacobian
intervals (widened for the residual's correlation, plus the replay's numerical error,
what the noise on a measured input does to the estimate and what a declared loop's
reaction to its encoder's noise does to it), the covariance, which parameters the data
cannot identify or cannot tell apart, and how much each effect moves the simulated
motion.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .problem import Problem
from .residuals import noise_floor
from .simulate import BatchRunner

if TYPE_CHECKING:
    from .inverse import EquationFit
    from .residuals import Evaluator

CORRELATED = 0.995  # parameters this correlated are reported as correlated_with

INPUT_NOISE_DRAWS = 4


@dataclass
class Solution:
    """What a fit needs to be finished again (after the numerical refinement)."""

    problem: Problem
    ev: Evaluator
    x: np.ndarray
    jac: np.ndarray
    scales: np.ndarray
    lb: np.ndarray
    ub: np.ndarray
    r: np.ndarray
    ros: list
    start: EquationFit | None


def _redrawn_shifts(sol: Solution, redraw) -> np.ndarray | None:
    """The parameter shifts (scaled units, one row per seeded draw) that redrawn runs
    cause, mapped through the Jacobian against the fit's own replay; None where ``redraw``
    redraws no run. ``redraw(t, trajectory, rng)`` gives run ``t`` as it might have been
    recorded and what the recording adds to the start of its residual (an array, maybe
    empty), or None to leave it; the draws come from one generator in the same order
    every time."""
    problem, ev = sol.problem, sol.ev
    shifts = []
    rng = np.random.default_rng(0)
    for _ in range(INPUT_NOISE_DRAWS):
        dr = np.zeros_like(sol.r)
        for t, tr in enumerate(problem.trajectories):
            drawn = redraw(t, tr, rng)
            if drawn is None:
                continue
            noisy, recorded = drawn
            (r1, _), = ev.run(t, [sol.x], BatchRunner(noisy, problem.joints))
            a, b = ev.offsets[t], ev.offsets[t + 1]
            dr[a:b] = r1 - sol.r[a:b]
            dr[a:a + len(recorded)] += recorded
        if not np.any(dr):
            return None
        shifts.append(np.linalg.lstsq(sol.jac, dr, rcond=None)[0])
    return np.array(shifts)


def input_noise_spread(sol: Solution) -> np.ndarray:
    """What the noise on the measured effort does to the estimate (the fit treats the
    input as exact): replays with the input perturbed by its own noise level (seeded
    draws), mapped to parameters through the Jacobian; 1.96 standard deviations."""
    problem = sol.problem

    def redraw(t, tr, rng):
        if tr.law() is not None or not tr.efforts:
            return None
        # the sensor's noise: a loop's reaction to the encoder's noise was applied
        sigma = problem.effort_sensor_noise[t]
        efforts = {j: e + rng.normal(0.0, sigma[problem.joints.index(j)], len(e))
                   for j, e in tr.efforts.items()}
        return dataclasses.replace(tr, efforts=efforts), np.zeros(0)

    shifts = _redrawn_shifts(sol, redraw)
    if shifts is None:
        return np.zeros(len(sol.x))
    return 1.96 * np.sqrt(np.mean(np.square(shifts), axis=0))


def loop_noise_cov(sol: Solution) -> np.ndarray | None:
    """What a declared loop's reaction to its encoder's noise does to the estimate: the
    mean square of the parameter shifts it causes (scaled units; None where no run is a
    declared loop). The loop reads the position plus the noise, so the joint is driven
    by a random command the replay (the noiseless law, or its clipped mean) does not
    apply: process noise, spread over the loop's own time constants and partly
    cancelled in what the encoder records (below its bandwidth the loop holds the
    *reading* on the reference), which no count of the residual's effective samples
    describes; and where the joint sticks the jitter smooths its dry friction into
    something like damping (a bias: friction fitted low, damping high, alike both ways).
    Seeded draws make each such run as the loop would have recorded it at the estimate
    (the loop reading the simulated position plus a draw of the noise, that reading
    recorded), mapped to parameters through the Jacobian against the noiseless replay;
    their mean square holds the bias and the spread, and how they move together (a
    bias alike both ways cancels in the difference of the two directions)."""
    problem = sol.problem

    def redraw(t, tr, rng):
        if not tr.feedback or tr.controller is not None:
            return None
        feedback, columns, draws = {}, dict(tr.columns), {}
        for j, f in tr.feedback.items():
            if j not in problem.joints:  # (a law on no measured joint: not replayed)
                feedback[j] = f
                continue
            k = problem.joints.index(j)
            sigma = f.encoder_noise or float(problem.position_noise[t][k])
            name = f"{j}.encoder_noise_draw"
            columns[name] = draws[k] = rng.normal(0.0, sigma, tr.n)
            # the draw is in the reading: the law clipped as it is, not its mean
            feedback[j] = dataclasses.replace(f, reading=name, encoder_noise=0.0)
        # the recorded reading, in the run's position residuals (one block per joint)
        recorded = np.zeros((max(draws) + 1) * tr.n if draws else 0)
        for k, n in draws.items():
            recorded[k * tr.n:(k + 1) * tr.n] = n / noise_floor(
                problem.position_noise[t][k], tr.positions[problem.joints[k]])
        noisy = dataclasses.replace(tr, feedback=feedback, columns=columns)
        return noisy, recorded

    shifts = _redrawn_shifts(sol, redraw)
    if shifts is None:
        return None
    return shifts.T @ shifts / len(shifts)


def uncertainty(ev: Evaluator, r, jmat, scales, n_eff, values, problem, x_star, numerical,
                rollouts, loop_cov: np.ndarray | None = None):
    """95 % half-widths (sysid's Jacobian intervals, widened for residual correlation,
    with ``loop_cov``, :func:`loop_noise_cov`, added to their covariance), the
    covariance, which parameters the data cannot identify, strong correlations, and how
    much each effect moves the simulated motion (RMS, in noise standard deviations: the
    Jacobian times the step back to the effect's absence)."""
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
    if loop_cov is not None:
        sigma_x = sigma_x + loop_cov[:p, :p]
        hw = np.sqrt(hw**2 + 1.96**2 * np.diag(loop_cov)[:p])
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
        material[e.name] = max(float(np.sqrt(np.mean((jmat @ dx) ** 2))),
                               effort_moved(ev, problem, x_star + dx, rollouts))
    return halfwidth, cov, ident, corr, material


def effort_moved(ev: Evaluator, problem, x: np.ndarray, rollouts) -> float:
    """How far the point ``x`` moves a declared loop's effort from ``rollouts`` (the
    fit's replays) where the effort is measured: RMS in the effort sensor's noise
    (:func:`features.sensor_noise_level`). A loop holds the motion, so an effect shows
    in the effort it takes, not in the positions; 0 where no run is a measured loop."""
    total, count = 0.0, 0
    for t, tr in enumerate(problem.trajectories):
        measured = [k for k, j in enumerate(problem.joints) if j in tr.efforts]
        if tr.law() is None or not measured or t >= len(rollouts) or \
                not problem.effort_sensor_noise:
            continue
        (_, ro), = ev.run(t, [x])
        for k in measured:
            sigma = float(problem.effort_sensor_noise[t][k])
            if not sigma > 0:
                continue
            d = (ro.efforts[:, k] - rollouts[t].efforts[:, k]) / sigma
            total += float(d @ d)
            count += d.size
    return math.sqrt(total / count) if count else 0.0
