"""A declared closed loop (the experiment file's ``[joints.<name>.feedback]``): the effort
applied in the replay is the controller's, computed each sample from the *simulated*
position, held over the sample interval:

    v_k = (q_k - q_{k-taps}) / (taps * h)
    u_k = kp * (r_k - q_k) - kd * v_k + added_k,  clipped to the saturation
    effort_k = gain * u_k
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Feedback:
    reference: str  # column holding the reference position
    kp: float = 0.0
    kd: float = 0.0
    velocity_taps: int = 1
    added: str | None = None  # column added to the command
    saturation: tuple[float, float] | None = None
    gain: float = 1.0

    def command(self, k: int, q: np.ndarray, columns: dict[str, np.ndarray],
                period: float) -> float:
        """The command ``u`` at sample ``k`` from positions ``q[0..k]`` (simulated); the
        effort is ``gain * u``."""
        return float(self.commands(k, q[None, :], columns, period)[0])

    def commands(self, k: int, q: np.ndarray, columns: dict[str, np.ndarray],
                 period: float) -> np.ndarray:
        """:meth:`command` for several replays at once: ``q`` is (replays, samples)."""
        taps = min(self.velocity_taps, k)
        v = (q[:, k] - q[:, k - taps]) / (taps * period) if taps > 0 else 0.0
        u = self.kp * (columns[self.reference][k] - q[:, k]) - self.kd * v
        if self.added is not None:
            u = u + columns[self.added][k]
        if self.saturation is not None:  # (the array's own clip: np.clip's wrapper costs
            u = u.clip(self.saturation[0], self.saturation[1])  # more than the clipping)
        return u


def controller(feedback: dict[str, Feedback], columns: dict[str, np.ndarray], period: float):
    """The replay's controller (``simulate.rollout``'s ``(k, history) -> efforts``)."""

    def law(k: int, history: dict[str, np.ndarray]) -> dict[str, float]:
        return {j: f.gain * f.command(k, history[j], columns, period)
                for j, f in feedback.items()}

    return law
