"""A declared closed loop (the experiment file's ``[joints.<name>.feedback]``): the effort
applied in the replay is the controller's, computed each sample from the *simulated*
position, held over the sample interval:

    v_k = (q_k - q_{k-taps}) / (taps * h)
    u_k = kp * (r_k - q_k) - kd * v_k + added_k,  clipped to the saturation
    effort_k = gain * u_k

A loop reads a noisy encoder: its command carries the law's reaction to that noise, and
where the command is clipped the noisy command's mean is not the noiseless law's (near
the limit the noise is clipped on one side only: the loop applies less than the law
says). The replay, noiseless, applies that mean (``encoder_noise``, the position's own
noise level, set from the data: :meth:`Trajectory.with_encoder_noise`); unclipped, the
mean is the law itself.

``reading`` names a column added to the position the law reads: a draw of the encoder's
noise, replayed to measure what the loop's reaction to it does to the estimate
(:func:`uncertainty.input_noise_spread`); the draw is in the reading, so the law is
clipped as it is, not averaged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr

# command noise deviations from the limit beyond which the clipped mean is the clip itself
CLIP_REACH = 8.0


@dataclass(frozen=True)
class Feedback:
    reference: str  # column holding the reference position
    kp: float = 0.0
    kd: float = 0.0
    velocity_taps: int = 1
    added: str | None = None  # column added to the command
    saturation: tuple[float, float] | None = None
    gain: float = 1.0
    encoder_noise: float = 0.0  # the position noise the loop reads (from the data)
    reading: str | None = None  # column of noise drawn onto the position the law reads

    def command_noise(self, period: float) -> float:
        """The standard deviation of the command's reaction to the encoder's noise n:
        -(kp + c) n_k + c n_(k-taps), c = kd / (taps * period)."""
        c = self.kd / (max(self.velocity_taps, 1) * period)
        return self.encoder_noise * math.hypot(self.kp + c, c)

    def command(self, k: int, q: np.ndarray, columns: dict[str, np.ndarray],
                period: float) -> float:
        """The command ``u`` at sample ``k`` from positions ``q[0..k]`` (simulated); the
        effort is ``gain * u``."""
        return float(self.commands(k, q[None, :], columns, period)[0])

    def commands(self, k: int, q: np.ndarray, columns: dict[str, np.ndarray],
                 period: float) -> np.ndarray:
        """:meth:`command` for several replays at once: ``q`` is (replays, samples)."""
        taps = min(self.velocity_taps, k)
        qk, qb = q[:, k], q[:, k - taps]
        if self.reading is not None:
            qk, qb = qk + columns[self.reading][k], qb + columns[self.reading][k - taps]
        v = (qk - qb) / (taps * period) if taps > 0 else 0.0
        u = self.kp * (columns[self.reference][k] - qk) - self.kd * v
        if self.added is not None:
            u = u + columns[self.added][k]
        if self.saturation is not None:
            lo, hi = self.saturation
            s = self.command_noise(period)
            # (the array's own clip: np.clip's wrapper costs more than the clipping)
            clipped = u.clip(lo, hi)
            if s > 0:
                near = (u < lo + CLIP_REACH * s) | (u > hi - CLIP_REACH * s)
                if near.any():
                    return np.where(near, clipped_mean(u, lo, hi, s), clipped)
            return clipped
        return u


def clipped_mean(u, lo: float, hi: float, s: float):
    """E[clip(u + e, lo, hi)] for e ~ N(0, s^2) (arrays or floats)."""
    a = (lo - u) / s
    b = (hi - u) / s
    pa, pb = ndtr(a), ndtr(b)
    phi = 1.0 / math.sqrt(2.0 * math.pi)
    return lo * pa + hi * (1.0 - pb) + u * (pb - pa) + \
        s * phi * (np.exp(-0.5 * a * a) - np.exp(-0.5 * b * b))


def controller(feedback: dict[str, Feedback], columns: dict[str, np.ndarray], period: float):
    """The replay's controller (``simulate.rollout``'s ``(k, history) -> efforts``)."""

    def law(k: int, history: dict[str, np.ndarray]) -> dict[str, float]:
        return {j: f.gain * f.command(k, history[j], columns, period)
                for j, f in feedback.items()}

    return law
