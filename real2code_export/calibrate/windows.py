"""Which parts of a record to fit: the user's window (``--start``/``--end``), and the
stretches where a joint is driven by something the data do not hold (a hand on a pendulum,
a push on a door), found by the energy it puts in and left out.

A push is what no candidate effect explains: the effort equation (measured effort against
the nominal rigid-body dynamics) is fitted with every linear candidate term at once
(damping and Coulomb friction, which only take energy out; a spring; the inertia where the
effort is measured, else gravity's load scaled against the inertia, where gravity loads the
joint (a first moment off: a free swing's frequency); a constant force as the residual's
median) under a redescending
(Cauchy) loss, so the effects the calibration may still name are absorbed and a short
foreign force is left as an outlier. A stretch of outliers (one that reaches the
smoothing's edge runs on to the record's end: a hand that lets go at the start of the
record acts from its first sample) counts as a push when the work it does on the joint is
large against the joint's kinetic energy where it moves, put in or taken out (a hand that
brakes a moving lid): an unmodelled effect of the state (inertia, a spring) only moves
energy back and forth, friction's share is in the regression, and a stretch at a stop (its
impact takes energy out, its rebound gives it back) is not counted. The run is cut there;
each piece keeps its own initial state (multiple shooting across the push).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares, lsq_linear

from . import features
from .effects import MAX_DELAY
from .trajectory import MIN_SAMPLES, Trajectory

# outliers: this many robust standard deviations of the equation residual
OUTLIER_SIGMAS = 5.0
# a push's work, against the joint's typical kinetic energy (1/2 I v95^2)
PUSH_ENERGY = 0.1
MIN_PUSH = 0.02  # s: shorter outlier runs are impacts or spikes
MERGE_GAP = 0.1  # s: outlier runs this close are one push
# s: left out on each side of a push: its force rises and falls over about a smoothing
# window (features.smoothing_window, 0.15 s) beyond where it stands out of the noise, and
# its tails left in would bias every estimate
GUARD = 0.15
MIN_PIECE = 0.25  # s: a piece shorter than this is dropped with the push
INERTIA_RANGE = (0.25, 4.0)  # the inertia's scale the push search allows, x nominal
ACTING = 0.2  # the measured effort acts where above this share of its 95th percentile
MOVING_SIGMAS = 5.0  # the joint moves where its speed is this many noise deviations


@dataclass(frozen=True)
class Excluded:
    """A stretch of one run that the fit leaves out, and why."""

    source: str
    joint: str
    start: float  # s, in the run's time
    end: float
    work: float  # J: energy put into the joint over the stretch
    reason: str

    def as_json(self) -> dict:
        return {"file": self.source, "joint": self.joint, "start": self.start,
                "end": self.end, "work": self.work, "reason": self.reason}


def window(tr: Trajectory, start: float | None, end: float | None) -> Trajectory:
    """The part of ``tr`` between ``start`` and ``end`` (its own time, seconds)."""
    if start is None and end is None:
        return tr
    keep = np.ones(tr.n, bool)
    if start is not None:
        keep &= tr.time >= start - 1e-12
    if end is not None:
        keep &= tr.time <= end + 1e-12
    return _piece(tr, keep, tr.source)


def _piece(tr: Trajectory, keep: np.ndarray, source: str) -> Trajectory:
    if tr.controller is not None:  # a coded law indexes the whole run's samples
        raise ValueError(f"{tr.source}: a run with a coded controller cannot be cut")
    return dataclasses.replace(
        tr, source=source, continues=False, time=tr.time[keep].copy(),
        positions={j: q[keep].copy() for j, q in tr.positions.items()},
        efforts={j: u[keep].copy() for j, u in tr.efforts.items()},
        columns={c: x[keep].copy() for c, x in tr.columns.items()})


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) index ranges where ``mask`` holds."""
    edges = np.diff(np.concatenate([[0], mask.astype(int), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True))


def find_pushes(tr: Trajectory, joints: list[str], spec, dynamics: dict) -> list[Excluded]:
    """Stretches of ``tr`` where a joint gains energy no candidate effect explains.
    ``spec``: the nominal replay spec; ``dynamics``: joint -> its model ``Dynamics``."""
    from .problem import rigid_effort, stops_seen

    if tr.law() is not None:
        return []  # a closed loop drives the joint by design
    period = tr.sample_period
    qs = np.column_stack([tr.positions[j] for j in joints])
    smooth = [features.derivatives(qs[:, k], period) for k in range(len(joints))]
    q = np.column_stack([s[0] for s in smooth])
    dq = np.column_stack([s[1] for s in smooth])
    ddq = np.column_stack([s[2] for s in smooth])
    tau_rb = rigid_effort(spec, joints, q, dq, ddq)
    # the joint-space inertia at each sample: the effort a unit acceleration needs at rest
    zero = np.zeros_like(q)
    weight = rigid_effort(spec, joints, q, zero, zero)  # gravity's load at each sample
    mass = rigid_effort(spec, joints, q, zero, zero + 1.0) - weight
    seen = stops_seen(spec, joints, tr, {j: dynamics[j].armature for j in joints})
    found = []
    edge = features.smoothing_window(period) // 2 + 1
    window = features.smoothing_window(period)
    gain = features.derivative_gain(period)  # white position noise -> the speed's noise
    for k, j in enumerate(joints):
        d = dynamics[j]
        # the joint's speed where it moves (its smoothed speed stands MOVING_SIGMAS noise
        # deviations out): the energy scale a push is judged against and the width of
        # friction's sign. Over a whole record a drawer that slides for a fifth of a second
        # and rests for three has a 95th-percentile speed of nearly nothing, and its whole
        # slide passed for a push. (The regression keeps every sample: at rest the joint
        # shows which force is no push, and a door that coasts at one speed cannot tell
        # damping from a constant force.)
        speed = np.abs(dq[:, k])
        moving = speed > MOVING_SIGMAS * features.noise_level(qs[:, k]) * gain
        if moving.sum() < MIN_SAMPLES:  # too few to say: the whole record
            moving[:] = True
        v95 = float(np.percentile(speed[moving], 95))
        if v95 <= 0:
            continue
        # friction's direction is the velocity's where the joint moves; where it rests,
        # static friction holds whatever else acts, so its column is zero there, not the
        # sign of the speed's noise (which kept friction out of the fit: a random force
        # of its full size on every resting sample)
        sgn = np.where(moving, np.tanh(dq[:, k] / max(0.05 * v95, 1e-12)), 0.0)
        required = (tau_rb[:, k] + d.armature * ddq[:, k] + d.damping * dq[:, k]
                    + d.friction * sgn + d.stiffness * (q[:, k] - d.spring_ref))
        # minus the unmeasured force, less what candidate effects explain (a constant force
        # is the residual's median, kept out of the regression where, with damping, it
        # would pass for a push from rest)
        cols = [dq[:, k], sgn, q[:, k] - q[:, k].mean()]
        if j in tr.efforts:  # smoothed as the motion is; the effort fixes the inertia's scale
            measured, rate, _ = features.derivatives(features.despike(tr.efforts[j])[0],
                                                     period, window)
            y = measured - required
            # and a lag between the effort's clock and the position's (u(t - d) ~ u - d u')
            cols += [ddq[:, k], rate]
        else:  # without an effort the inertia's scale is not observable: it stays nominal,
            y = -required  # but gravity's load against it (a free swing's frequency) is not
            if np.ptp(weight[:, k]) > 0:
                cols.append(weight[:, k])
        x = np.column_stack(cols)
        use = np.zeros(tr.n, bool)
        use[edge:-edge] = True
        if use.sum() < MIN_SAMPLES:
            continue
        scale = np.maximum(np.linalg.norm(x[use], axis=0), 1e-12)
        ys = max(float(np.std(y[use])), 1e-12)
        # damping and friction only take energy out: a push cannot hide in them
        lower = np.array([0.0, 0.0] + [-np.inf] * (x.shape[1] - 2))
        upper = np.full(x.shape[1], np.inf)
        if j in tr.efforts:
            # nor in a vanishing mass: with the inertia scaled to nothing, every sample the
            # measured effort is zero at (free motion, and the push itself) fits exactly,
            # and only the measured pushes are left as outliers. The scale stays within
            # INERTIA_RANGE of the nominal inertia.
            nominal = float(np.median(mass[:, k])) + d.armature
            lower[3], upper[3] = ((s - 1.0) * nominal * scale[3] / ys for s in INERTIA_RANGE)
            lower[4], upper[4] = (s * MAX_DELAY * scale[4] / ys for s in (-1.0, 1.0))
        a_use, y_use = x[use] / scale, y[use] / ys

        def resid(b, a=a_use, yy=y_use):
            r = a @ b - yy
            return r - np.median(r)

        # a push is a minority of samples with a large force: a redescending (Cauchy) loss
        # whose scale follows the residual's own spread leaves it out of the fit
        coef = np.array([1e-6, 1e-6] + [0.0] * (x.shape[1] - 2))
        f_scale = 0.1
        at_stop = _at_stops(qs[:, k], seen[k])
        if j in tr.efforts:
            # the inertia is what the measured effort says: fitted (least squares) where
            # the effort acts, then held. A robust loss left free would find a minimum for
            # every inertia that the zero-effort samples allow, the push among them, and
            # could as well call the measured pushes the outliers.
            # (not where the joint is at a stop: the stop's force would pass for inertia,
            # and every push elsewhere then for a force against the motion)
            acting = use & ~at_stop & (np.abs(measured) > ACTING * np.percentile(
                np.abs(measured[use]), 95))
            if acting.sum() >= MIN_SAMPLES:
                a_act = x[acting] / scale
                # bounded as the robust fit is: over a push or two the smooth columns are
                # nearly collinear, and a negative damping would buy any inertia
                b = lsq_linear(a_act - a_act.mean(axis=0), y[acting] / ys
                               - np.mean(y[acting] / ys), bounds=(lower, upper)).x
                held = float(b[3])
                coef[3] = held
                lower[3], upper[3] = held - 1e-9 * max(abs(held), 1.0), \
                    held + 1e-9 * max(abs(held), 1.0)
        for _ in range(4):
            coef = least_squares(resid, coef, bounds=(lower, upper), loss="cauchy",
                                 f_scale=f_scale).x
            rr = resid(coef)
            f_scale = max(2.0 * 1.4826 * float(np.median(np.abs(rr))), 1e-9)
        r = y - (x / scale) @ coef * ys
        r -= np.median(r[use])
        core = r[use]
        sigma = 1.4826 * float(np.median(np.abs(core - np.median(core))))
        if sigma <= 0:
            continue
        out = np.abs(r) > OUTLIER_SIGMAS * sigma
        out &= use
        # close runs merge into one push
        gap = max(1, int(round(MERGE_GAP / period)))
        runs = _runs(out)
        merged: list[list[int]] = []
        for a, b in runs:
            if merged and a - merged[-1][1] <= gap:
                merged[-1][1] = b
            else:
                merged.append([a, b])
        inertia = float(np.median(mass[:, k])) + d.armature
        energy_scale = 0.5 * inertia * v95**2
        for a, b in merged:
            if (b - a) * period < MIN_PUSH or at_stop[a:b].any():
                continue  # too short, or a stop's rebound (it gives back what it took)
            # the outlier test cannot see the smoothing's edges: a stretch that reaches one
            # runs on to the record's end (a hand that lets go acts from the first sample)
            wa = 0 if a <= edge else a
            wb = tr.n if b >= tr.n - edge else b
            # the unmeasured force is -r: its work on the joint
            work = float(np.sum(-r[wa:wb] * dq[wa:wb, k]) * period)
            if abs(work) > PUSH_ENERGY * energy_scale:
                # grow the stretch to where the force starts and ends (half the threshold)
                lo, hi = a, b
                while lo > 0 and abs(r[lo - 1]) > 0.5 * OUTLIER_SIGMAS * sigma:
                    lo -= 1
                while hi < tr.n and abs(r[hi]) > 0.5 * OUTLIER_SIGMAS * sigma:
                    hi += 1
                found.append(Excluded(tr.source, j, float(tr.time[lo]),
                                      float(tr.time[hi - 1]), work,
                                      f"energy {'rises' if work > 0 else 'falls'} by "
                                      f"{abs(work):.3g} J ({abs(work) / energy_scale:.2g} x "
                                      "the joint's kinetic energy) in a way no candidate "
                                      "effect and no measured effort explains: an unmeasured "
                                      "push"))
    return found


def _at_stops(q: np.ndarray, sides: list[str]) -> np.ndarray:
    """Samples near an end of the motion where the joint is stopped hard (``sides``: where
    :func:`problem.stops_seen` sees it; a stop's rebound returns the energy its compression
    took: positive work, but no push)."""
    span = float(np.ptp(q))
    near = np.zeros(len(q), bool)
    if "upper" in sides:
        near |= q > q.max() - 0.05 * span
    if "lower" in sides:
        near |= q < q.min() + 0.05 * span
    return near


def cut(tr: Trajectory, excluded: list[Excluded]
        ) -> tuple[list[Trajectory], list[Excluded]]:
    """``tr`` without the excluded stretches (a guard on each side): the pieces long enough
    to fit, each its own run with its own initial state, and the pieces too short to fit
    (left out too, and said so)."""
    mine = [e for e in excluded if e.source == tr.source]
    if not mine:
        return [tr], []
    keep = np.ones(tr.n, bool)
    for e in mine:
        keep &= ~((tr.time >= e.start - GUARD) & (tr.time <= e.end + GUARD))
    pieces, dropped = [], []
    for a, b in _runs(keep):
        t0, t1 = float(tr.time[a]), float(tr.time[b - 1])
        if t1 - t0 < MIN_PIECE or b - a < MIN_SAMPLES:
            dropped.append(Excluded(tr.source, mine[0].joint, t0, t1, 0.0,
                                    f"shorter than {MIN_PIECE} s between pushes: too short "
                                    "to fit its own initial state"))
            continue
        mask = np.zeros(tr.n, bool)
        mask[a:b] = True
        pieces.append(_piece(tr, mask, f"{tr.source} [{t0:.3f}-{t1:.3f} s]"))
    return pieces, dropped


def segments(tr: Trajectory, seconds: float) -> list[Trajectory]:
    """``tr`` as consecutive pieces of about ``seconds`` each (sharing their boundary
    sample), each its own run with its own initial state: multiple shooting, so that an
    open-loop replay cannot drift away over a long record and take the fit with it (the
    fit weighs each piece's end against the next one's start: ``continues``)."""
    if tr.controller is not None or tr.duration <= 1.5 * seconds:
        return [tr]
    count = max(1, int(round(tr.duration / seconds)))
    edges = np.searchsorted(tr.time, tr.time[0] + np.arange(1, count) * tr.duration / count)
    bounds = [0, *edges.tolist(), tr.n - 1]
    pieces = []
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        mask = np.zeros(tr.n, bool)
        mask[a:b + 1] = True
        piece = _piece(tr, mask, f"{tr.source} [{tr.time[a]:.3f}-{tr.time[b]:.3f} s]")
        pieces.append(dataclasses.replace(piece, continues=bool(pieces)))
    return pieces
