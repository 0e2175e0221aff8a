"""Pinocchio: the URDF's rigid-body dynamics (``crba``, ``rnea``) plus the joint laws,
integrated the way MuJoCo integrates (semi-implicit Euler, damping implicit).

Pinocchio has no time stepper; its users write this loop. The laws: damping and dry
friction as Pinocchio reads them from ``<dynamics>``, springs and armature from our
``real2code:`` attributes (URDF has no place for them), and joint limits as hard stops
(an inelastic impulse), the constraints solved by projected Gauss-Seidel on the joint-space
inverse inertia.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import EngineUnavailable, Experiment, Recorder, Trajectory, urdf_laws

PGS_ITERATIONS = 60
PGS_TOLERANCE = 1e-12  # N m s (or N s): an impulse change below this ends the passes


def simulate(path: Path, experiment: Experiment) -> Trajectory:
    try:
        import pinocchio as pin
    except ImportError as e:
        raise EngineUnavailable("Pinocchio is not installed (pip install 'real2code-export[sim]')"
                                ) from e
    model = pin.buildModelFromUrdf(str(path))
    model.gravity.linear = np.array(experiment.gravity)
    data = model.createData()
    nv = model.nv
    # One generalised coordinate per movable joint (a continuous joint's angle kept unwrapped).
    idx_v, cont = [], []
    for name in experiment.joints:
        if not model.existJointName(name):
            raise KeyError(f"{path}: Pinocchio's model has no joint named {name!r}")
        joint = model.joints[model.getJointId(name)]
        if joint.nv != 1:
            raise ValueError(f"{path}: joint {name!r} has {joint.nv} degrees of freedom")
        idx_v.append(joint.idx_v)
        cont.append(joint.nq == 2)
    idx_v = np.array(idx_v)
    damping = np.asarray(model.damping, dtype=float).copy()
    friction = np.asarray(model.friction, dtype=float).copy()
    lower = np.full(nv, -np.inf)
    upper = np.full(nv, np.inf)
    stiffness, springref, armature = np.zeros(nv), np.zeros(nv), np.zeros(nv)
    extra = urdf_laws(path)
    for jid in range(1, model.njoints):
        joint, name = model.joints[jid], model.names[jid]
        if joint.nv != 1:
            continue
        laws = extra.get(name, {})
        stiffness[joint.idx_v] = laws.get("stiffness", 0.0)
        springref[joint.idx_v] = laws.get("springref", 0.0)
        armature[joint.idx_v] = laws.get("armature", 0.0)
        if joint.nq == 1:
            lower[joint.idx_v] = model.lowerPositionLimit[joint.idx_q]
            upper[joint.idx_v] = model.upperPositionLimit[joint.idx_q]

    # theta: one scalar per degree of freedom; q is built from it.
    theta = np.zeros(nv)
    theta[idx_v] = experiment.q0
    v = np.zeros(nv)
    v[idx_v] = experiment.v0
    q_of = _configuration(pin, model)
    dt = experiment.dt
    recorder = Recorder(experiment)
    for step in range(experiment.steps + 1):
        if recorder.due(step):
            recorder.add(step, theta[idx_v])
        if step == experiment.steps:
            break
        q = q_of(theta)
        mass = pin.crba(model, data, q)
        mass = np.triu(mass) + np.triu(mass, 1).T + np.diag(armature)
        bias = pin.rnea(model, data, q, v, np.zeros(nv))
        force = -bias - damping * v - stiffness * (theta - springref)
        m_hat = mass + dt * np.diag(damping)  # MuJoCo's implicit damping
        inverse = np.linalg.inv(m_hat)
        v_free = v + dt * inverse @ force
        v = _constrain(v_free, inverse, theta, dt, friction, lower, upper)
        theta = theta + dt * v
    return recorder.trajectory()


def _configuration(pin, model):
    """theta (one value per degree of freedom) -> Pinocchio's q (cos/sin for continuous)."""
    scalar_q, scalar_v, cont_q, cont_v = [], [], [], []
    for jid in range(1, model.njoints):
        joint = model.joints[jid]
        if joint.nv != 1:
            continue
        (cont_q if joint.nq == 2 else scalar_q).append(joint.idx_q)
        (cont_v if joint.nq == 2 else scalar_v).append(joint.idx_v)
    neutral = pin.neutral(model)

    def q_of(theta: np.ndarray) -> np.ndarray:
        q = neutral.copy()
        q[scalar_q] = theta[scalar_v]
        q[cont_q] = np.cos(theta[cont_v])
        q[np.array(cont_q, dtype=int) + 1] = np.sin(theta[cont_v])
        return q

    return q_of


def _constrain(v_free, inverse, theta, dt, friction, lower, upper) -> np.ndarray:
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
