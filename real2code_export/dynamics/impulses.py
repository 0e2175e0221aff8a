"""Joint-space impulses for engines whose loop we write: dry friction (an impulse bounded by
friction * dt per joint) and hard limits (an impulse that only pushes), solved by projected
Gauss-Seidel on the joint-space inverse inertia. Pinocchio's loop steps with them; Bullet's
runner predicts its step's end velocity with them (bullet.py). numpy only."""

from __future__ import annotations

import numpy as np

PGS_ITERATIONS = 60
PGS_TOLERANCE = 1e-12  # N m s (or N s): an impulse change below this ends the passes


def constrain(v_free, inverse, theta, dt, friction, lower, upper) -> np.ndarray:
    """Velocity after dry friction (an impulse bounded by friction * dt per joint) and hard
    limits (an impulse that only pushes, so that the next position stays in range)."""
    n = len(v_free)
    rows = [i for i in range(n) if friction[i] > 0]
    at_lower = [i for i in range(n) if theta[i] + dt * v_free[i] < lower[i]]
    at_upper = [i for i in range(n) if theta[i] + dt * v_free[i] > upper[i]]
    if not rows and not at_lower and not at_upper:
        return v_free
    impulse_f = np.zeros(n)
    impulse_l = np.zeros(n)
    v = v_free.copy()
    for _ in range(PGS_ITERATIONS):
        change = 0.0
        for i in rows:  # friction: drive v_i to 0 within the bound
            old = impulse_f[i]
            impulse_f[i] = np.clip(old - v[i] / inverse[i, i], -friction[i] * dt, friction[i] * dt)
            v += inverse[:, i] * (impulse_f[i] - old)
            change = max(change, abs(impulse_f[i] - old))
        for i in at_lower:  # v_i >= (lower - theta_i) / dt, push only
            old = impulse_l[i]
            target = (lower[i] - theta[i]) / dt
            impulse_l[i] = max(0.0, old + (target - v[i]) / inverse[i, i])
            v += inverse[:, i] * (impulse_l[i] - old)
            change = max(change, abs(impulse_l[i] - old))
        for i in at_upper:
            old = impulse_l[i]
            target = (upper[i] - theta[i]) / dt
            impulse_l[i] = min(0.0, old + (target - v[i]) / inverse[i, i])
            v += inverse[:, i] * (impulse_l[i] - old)
            change = max(change, abs(impulse_l[i] - old))
        if change <= PGS_TOLERANCE:  # converged: a further pass would change nothing
            break
    return v
