"""Features of the measured motion and of the replay's mismatch that point at causes:
the decay envelope (linear: dry friction; exponential: viscous damping), oscillation about a
rest position other than the model's, a sudden stop (an end stop), a frequency shift
(stiffness or inertia), a force bias that flips with the sign of the velocity (friction) or
does not (an offset). Also the sensor noise level and smoothed derivatives the fit starts
from.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import find_peaks, savgol_coeffs, savgol_filter

MIN_WINDOW = 7  # samples: the order-4 polynomial's fewest plus two


def smoothing_window(period: float, seconds: float = 0.15, minimum: int = MIN_WINDOW) -> int:
    """A window of a fixed duration (odd, at least ``minimum`` samples): for looks that
    need one span whatever the data (an impact, a push's energy); the equation error's
    own window is :func:`chosen_window`'s, from the run's data."""
    w = max(minimum, int(round(seconds / period)))
    return w + 1 if w % 2 == 0 else w


# The equation error regresses the effort on the smoothed acceleration: noise in a
# regressor biases its coefficient toward zero by its share of the regressor's variance
# (errors in variables), so the window is long enough that the acceleration's noise is at
# most this share of the acceleration's RMS (an inertia low by at most 4 %, which the
# simulation fit then removes); longer windows blur what is not linear in the motion (a
# friction's sign where the joint sticks) and bias it the other way. It is never
# shorter than smoothing_window's 0.15 s: shorter windows were tried (session 24) and
# let the effort equation explain a hand-driven run's torque (DFKI's gravity
# compensation) with invented causes.
REGRESSOR_NOISE = 0.2
MAX_WINDOW_SECONDS = 1.0  # s: no filter of the equation error averages over longer
WINDOW_GROWTH = 1.1  # the windows tried grow by this factor
POLYORDER = 4


def _gain(window: int, deriv: int, period: float) -> float:
    """The factor by which the smoothing's ``deriv``-th derivative scales white noise."""
    order = min(POLYORDER, window - 1)
    return float(np.sqrt(np.sum(savgol_coeffs(window, order, deriv=deriv, delta=period)
                                ** 2)))


def chosen_window(qs: np.ndarray, period: float, efforts: np.ndarray | None = None) -> int:
    """The smoothing window of one run's equation error, chosen from its data: the
    shortest in which every regressor the window makes keeps its noise (the signal's noise
    level through the filter) at most REGRESSOR_NOISE of its RMS: the acceleration of each
    joint that moves (its span beyond 20 noise deviations) and the rate of each measured
    effort (``efforts``, columns; what a lag between effort and position moves). One
    window per run, the effort filtered alike (parallel filtering: the filter's lag and
    shape cancel between regressors and regressand). At least :func:`smoothing_window`'s,
    at most MAX_WINDOW_SECONDS and a quarter of the run; :func:`smoothing_window`'s where
    no effort is measured (``efforts`` None or without columns): the simulation error fits
    such a run, the equation only starts it, and a coasting joint's acceleration, small
    against the noise, would ask for a window that blurs its whole motion."""
    x = np.asarray(qs, float)
    x = x[:, None] if x.ndim == 1 else x
    n = len(x)
    if efforts is None or np.size(efforts) == 0:
        return smoothing_window(period)
    cap = max(MIN_WINDOW, min(n // 4, int(round(MAX_WINDOW_SECONDS / period))))
    cap -= 1 - cap % 2
    grid = [min(smoothing_window(period), cap)]
    while grid[-1] < cap:
        w = max(int(grid[-1] * WINDOW_GROWTH), grid[-1] + 2)
        grid.append(min(w + 1 - w % 2, cap))
    signals = [(x[:, k], 2) for k in range(x.shape[1])]
    if efforts is not None:
        e = np.asarray(efforts, float)
        e = e[:, None] if e.ndim == 1 else e
        signals += [(e[:, k], 1) for k in range(e.shape[1])]
    out = grid[0]
    for y, deriv in signals:
        sigma = noise_level(y)
        if sigma <= 0 or np.ptp(y) <= 20 * sigma:
            continue
        w = cap
        for cand in grid:
            if 3 * cand > n:
                break
            d = savgol_filter(y, cand, min(POLYORDER, cand - 1), deriv=deriv,
                              delta=period, mode="interp")[cand:-cand]
            rms = float(np.sqrt(np.mean(d**2))) if d.size else 0.0
            if _gain(cand, deriv, period) * sigma <= REGRESSOR_NOISE * rms:
                w = cand
                break
        out = max(out, w)
    return out


def cutoff(window: int, period: float) -> float:
    """The frequency (Hz) where :func:`derivatives`' smoothing passes half the power (its
    -3 dB point): the low-pass cut-off the window amounts to."""
    c = savgol_coeffs(window, min(POLYORDER, window - 1))
    freqs = np.linspace(0.0, 0.5, 4096)
    k = np.arange(len(c)) - len(c) // 2
    h = np.abs(np.exp(-2j * np.pi * np.outer(freqs, k)) @ c)
    below = np.flatnonzero(h < 1.0 / math.sqrt(2.0))
    return float(freqs[below[0]] / period) if below.size else 0.5 / period


def smoothing_gain(period: float, window: int | None = None) -> float:
    """The factor by which :func:`derivatives`' smoothing (``window``; by default
    :func:`smoothing_window`'s) scales white noise (its standard deviation)."""
    return _gain(window or smoothing_window(period), 0, period)


def derivative_gain(period: float, window: int | None = None) -> float:
    """The factor by which :func:`derivatives`' smoothed first derivative scales white
    position noise (its standard deviation)."""
    return _gain(window or smoothing_window(period), 1, period)


def derivatives(x: np.ndarray, period: float, window: int | None = None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Savitzky-Golay smoothed value, first and second derivative."""
    w = min(window or smoothing_window(period), len(x) - (1 - len(x) % 2))
    w = max(w, 5)
    order = min(POLYORDER, w - 1)
    kw = {"window_length": w, "polyorder": order, "delta": period, "mode": "interp"}
    return (savgol_filter(x, deriv=0, **kw), savgol_filter(x, deriv=1, **kw),
            savgol_filter(x, deriv=2, **kw))


def despike(x: np.ndarray, width: int = 7, sigmas: float = 6.0) -> tuple[np.ndarray, int]:
    """``x`` with isolated spikes (a motor's current-derived torque) replaced by the running
    median (a Hampel filter), and how many were replaced: a spike smoothed with the rest
    would spread into a bump no robust loss could tell from the signal."""
    from scipy.signal import medfilt

    if len(x) < 3 * width:
        return x, 0
    med = medfilt(x, width)
    r = x - med
    sigma = 1.4826 * float(np.median(np.abs(r - np.median(r))))
    if sigma <= 0:
        return x, 0
    spikes = np.abs(r) > sigmas * sigma
    if not spikes.any():
        return x, 0
    out = x.copy()
    out[spikes] = med[spikes]
    return out, int(spikes.sum())


def quantum(x: np.ndarray) -> float | None:
    """The encoder's step where the readings lie on a grid (None: they do not): the
    smallest step between consecutive distinct readings, kept when every reading is a
    whole number of steps from the first. Quantisation is part of the sensor noise the
    fit weighs by, never a force."""
    steps = np.abs(np.diff(x))
    steps = steps[steps > 1e-12 * max(float(np.max(np.abs(x))), 1e-300)]
    if steps.size < 10:
        return None
    q = float(np.percentile(steps, 5))
    units = (x - x[0]) / q
    if np.max(np.abs(units - np.round(units))) > 0.02:
        return None
    return q


def noise_level(x: np.ndarray) -> float:
    """Standard deviation of the sensor noise (quantisation included), from what a short
    local cubic cannot follow; corrected for the part of the noise the fit absorbs."""
    w = 9 if len(x) >= 9 else (len(x) - 1) | 1
    if w < 5:
        return 0.0
    resid = x - savgol_filter(x, w, 3, mode="interp")
    center = savgol_coeffs(w, 3)[w // 2]
    core = resid[w:-w] if len(resid) > 3 * w else resid
    # median absolute deviation: robust to the few samples at impacts
    mad = float(np.median(np.abs(core - np.median(core)))) * 1.4826
    rms = float(np.sqrt(np.mean(core**2)))
    est = min(mad, rms) if mad > 0 else rms
    return est / math.sqrt(max(1.0 - center, 1e-6))


# samples of the position's recent past a loop's command may read (a velocity from a few
# samples' differences, a short filter): the jitter they explain is the loop's, not the sensor's
LOOP_TAPS = 8


def sensor_noise_level(x: np.ndarray, q: np.ndarray) -> float:
    """:func:`noise_level` of an effort ``x`` less the part of its jitter the position
    ``q``'s jitter explains: a loop on the measured position turns the encoder's noise into
    applied effort (real force, replayed as recorded), which is no noise of the effort's
    sensor. The jitter of both (what a short local cubic cannot follow) is regressed on the
    position's at this and the previous LOOP_TAPS samples (causal: what the effort does to
    the position shows samples later); where no loop reads the position, nothing is
    explained and this is :func:`noise_level`."""
    n = len(x)
    w = 9 if n >= 9 else (n - 1) | 1
    if w < 5 or n < 3 * w + 4 * (LOOP_TAPS + 1):
        return noise_level(x)
    ex = x - savgol_filter(x, w, 3, mode="interp")
    eq = q - savgol_filter(q, w, 3, mode="interp")
    a = np.column_stack([eq[LOOP_TAPS - i:n - i] for i in range(LOOP_TAPS + 1)])
    y = ex[LOOP_TAPS:]
    core = slice(w, len(y) - w)
    a, y = a[core], y[core]
    if not np.any(a):
        return noise_level(x)
    # robust: the few samples where the loop saturates or an impact kicks are left out
    coef = np.linalg.lstsq(a, y, rcond=None)[0]
    for _ in range(2):
        r = y - a @ coef
        scale = float(np.median(np.abs(r))) * 1.4826
        keep = np.abs(r) <= 4.0 * max(scale, 1e-300)
        if keep.sum() < a.shape[1] * 4:
            break
        coef = np.linalg.lstsq(a[keep], y[keep], rcond=None)[0]
    r = y - a @ coef
    mad = float(np.median(np.abs(r - np.median(r)))) * 1.4826
    rms = float(np.sqrt(np.mean(r**2)))
    est = min(mad, rms) if mad > 0 else rms
    center = savgol_coeffs(w, 3)[w // 2]
    return min(est / math.sqrt(max(1.0 - center, 1e-6)), noise_level(x))


def effective_samples(resid: np.ndarray) -> float:
    """Independent samples in a residual: its length over the integrated autocorrelation
    time (Sokal's automatic window). A residual with slow drifts (an unmodelled input
    error integrated by the dynamics) carries far less information than its length."""
    r = np.asarray(resid, float)
    n = r.size
    if n < 4:
        return float(max(n, 1))
    r = r - r.mean()
    f = np.fft.rfft(r, 2 * n)
    acf = np.fft.irfft(f * np.conj(f))[:n]
    if acf[0] <= 0:
        return float(n)
    rho = acf / acf[0]
    tau = 1.0
    for m in range(1, n):
        tau += 2.0 * rho[m]
        if m >= 5.0 * tau:
            break
    tau = min(max(tau, 1.0), n / 2.0)
    return float(n / tau)


# -- causes ------------------------------------------------------------------------------------
def turning_points(q: np.ndarray, dq: np.ndarray, noise: float) -> np.ndarray:
    """Indices where the velocity changes sign with a swing larger than the noise."""
    s = np.sign(dq)
    idx = np.flatnonzero((s[1:] * s[:-1]) < 0) + 1
    keep, last = [], None
    for i in idx:
        if last is None or abs(q[i] - q[last]) > 6 * noise:
            keep.append(i)
            last = i
    return np.array(keep, dtype=int)


def decay_envelope(t, q, dq, noise, rest: float | None = None) -> dict:
    """How the swing amplitude decays: 'linear' (dry friction), 'exponential' (viscous
    damping), 'none', or 'n/a' (too few swings)."""
    tp = turning_points(q, dq, noise)
    if len(tp) < 4:
        return {"kind": "n/a", "swings": int(len(tp))}
    centre = rest if rest is not None else float(np.median(q[tp]))
    amp = np.abs(q[tp] - centre)
    tt = t[tp]
    ok = amp > 4 * noise
    if ok.sum() < 4:
        return {"kind": "n/a", "swings": int(len(tp))}
    tt, amp = tt[ok], amp[ok]
    lin = np.polyfit(tt, amp, 1)
    lin_err = float(np.sqrt(np.mean((np.polyval(lin, tt) - amp) ** 2)))
    ex = np.polyfit(tt, np.log(amp), 1)
    ex_err = float(np.sqrt(np.mean((np.exp(np.polyval(ex, tt)) - amp) ** 2)))
    drop = (amp[0] - amp[-1]) / amp[0]
    if drop < 0.05:
        kind = "none"
    else:
        kind = "linear" if lin_err < 0.7 * ex_err else \
            "exponential" if ex_err < 0.7 * lin_err else "mixed"
    return {"kind": kind, "swings": int(len(tt)), "linear_rms": lin_err,
            "exponential_rms": ex_err, "amplitude_drop": float(drop),
            "linear_slope": float(-lin[0]), "exponential_rate": float(-ex[0])}


def rest_position(q, dq, noise) -> float | None:
    """Centre of the oscillation (mean of successive turning-point midpoints)."""
    tp = turning_points(q, dq, noise)
    if len(tp) < 3:
        return None
    mids = 0.5 * (q[tp[1:]] + q[tp[:-1]])
    return float(np.median(mids))


def dominant_frequency(t, q) -> float | None:
    x = q - np.polyval(np.polyfit(t, q, 1), t)
    if len(x) < 16 or np.allclose(x, 0):
        return None
    spec = np.abs(np.fft.rfft(x * np.hanning(len(x))))
    freqs = np.fft.rfftfreq(len(x), d=float(np.median(np.diff(t))))
    k = int(np.argmax(spec[1:]) + 1)
    if spec[k] < 3 * np.median(spec[1:]):
        return None
    return float(freqs[k])


def swing_period(t: np.ndarray, q: np.ndarray) -> float | None:
    """The period of a motion that swings back and forth (turning points, each far above
    the noise from the last), from the time between its first and last turning points;
    None where it turns fewer than three times."""
    if len(q) < 16:
        return None
    smooth = derivatives(q, float(np.median(np.diff(t))))[0]
    prominence = max(20.0 * noise_level(q), 1e-12)
    turns = np.sort(np.concatenate([find_peaks(smooth, prominence=prominence)[0],
                                    find_peaks(-smooth, prominence=prominence)[0]]))
    if len(turns) < 3:
        return None
    return 2.0 * float(t[turns[-1]] - t[turns[0]]) / (len(turns) - 1)


def sudden_stops(q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, noise: float,
                 margin: int = 0) -> list[str]:
    """Sides ('lower', 'upper') where the joint is stopped hard: at the extreme of the
    motion, while the joint still moves into it, the deceleration peaks far above what the
    rest of the motion shows. ``ddq``: the acceleration nothing measured drives (a measured
    push that turns the joint back at the far end of its travel is no stop); ``margin``:
    samples at each end of the record, where a smoothed derivative is an extrapolation and
    is not judged."""
    span = float(np.ptp(q))
    if span < 20 * noise:
        return []
    a = np.abs(ddq)
    edges = (("lower", q.min()), ("upper", q.max()))
    # the rest of the motion: away from both edges (a run that rests against a stop for a
    # tenth of its samples would otherwise put the impact in its own yardstick)
    away = np.ones(len(q), bool)
    for _, edge in edges:
        away &= np.abs(q - edge) >= 0.03 * span
    typical = float(np.percentile(a[away] if away.sum() > 10 else a, 90)) + 1e-12
    judged = np.ones(len(q), bool)
    if margin:
        judged[:margin] = judged[-margin:] = False
    out = []
    for side, edge in edges:
        near = np.abs(q - edge) < 0.03 * span
        if not near.any():
            continue
        # the stopping deceleration, where the joint still moves into the edge: a joint
        # that rests there and is pushed away accelerates the same way, but from rest
        into = 1.0 if side == "upper" else -1.0
        stopping = near & judged & (into * dq > 0)
        peak = float(np.max(-into * ddq[stopping])) if stopping.any() else 0.0
        # approached with speed: the velocity before reaching the edge is not small
        moving = float(np.percentile(np.abs(dq), 75))
        idx = np.flatnonzero(near)
        before = idx[0] - 1
        approach = abs(dq[max(before - 2, 0)]) if before >= 0 else 0.0
        if peak > 3.0 * typical and approach > 0.3 * moving:
            out.append(side)
    return out


def missing_force(dq: np.ndarray, ddq: np.ndarray, force_residual: np.ndarray) -> dict:
    """The force the nominal model misses, split by what it goes with: a part that flips
    with the velocity's sign at constant size (dry friction), one that grows with the speed
    (viscous damping), one that does not flip (an offset), one that follows the
    acceleration (inertia). Terms are reported when larger than three standard errors."""
    if len(dq) < 10:  # a piece held at a stop throughout has no usable samples
        return {"terms": []}
    moving = np.abs(dq) > 0.05 * np.percentile(np.abs(dq), 90)
    if moving.sum() < 10 or np.all(dq[moving] > 0) or np.all(dq[moving] < 0):
        return {"terms": []}
    v, a, f = dq[moving], ddq[moving], force_residual[moving]
    cols = np.column_stack([np.sign(v), v, np.ones_like(v), a])
    scale = np.maximum(np.abs(cols).max(axis=0), 1e-300)
    coef, *_ = np.linalg.lstsq(cols / scale, f, rcond=None)
    resid = f - (cols / scale) @ coef
    s2 = float(resid @ resid) / max(len(f) - 4, 1)
    se = np.sqrt(np.diag(np.linalg.pinv((cols / scale).T @ (cols / scale))) * s2)
    coef, se = coef / scale, se / scale
    names = ("flips with the velocity sign (dry friction)", "grows with the speed (viscous)",
             "does not flip (constant)", "follows the acceleration (inertia)")
    terms = [names[i] for i in range(4) if abs(coef[i]) > 3 * se[i]]
    return {"dry": float(coef[0]), "viscous": float(coef[1]), "constant": float(coef[2]),
            "inertial": float(coef[3]), "stderr": se.tolist(), "terms": terms}
