"""Bullet (``pybullet``): the URDF, base fixed, inertia from the file.

What a user must set because URDF has no place for it or Bullet defaults it otherwise (see
docs/engines.md): ``URDF_USE_INERTIA_FROM_FILE`` (else inertia comes from the collision
shapes); link damping 0 (Bullet's default is 0.04); its default velocity motors off, and a
velocity motor with target 0 and the URDF friction as its force limit in their place (Bullet
reads ``<dynamics damping>`` but not ``friction``); springs from our ``real2code:`` attributes
as a torque each step; a joint error reduction of 0.001 (its 0.2 default makes a joint
bounce off its limit); the URDF damping applied at the step's end velocity, as MuJoCo's
implicit damping (Bullet applies it at the start; ``_end_velocity``). Bullet's limits are
hard stops; it has no armature.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..probes._stdio import captured_c_output
from . import EngineUnavailable, Experiment, Recorder, Trajectory, urdf_laws
from .impulses import constrain

JOINT_ERP = 0.001


def simulate(path: Path, experiment: Experiment) -> Trajectory:
    try:
        with captured_c_output():  # its build time, printed on import
            import pybullet as pb
    except ImportError as e:
        raise EngineUnavailable("Bullet is not installed (pip install 'real2code-export[engines]')"
                                ) from e
    client = pb.connect(pb.DIRECT)
    try:
        return _run(pb, client, path, experiment)
    finally:
        pb.disconnect(client)


def _run(pb, client, path: Path, experiment: Experiment) -> Trajectory:
    kw = {"physicsClientId": client}
    pb.setGravity(*experiment.gravity, **kw)
    pb.setTimeStep(experiment.dt, **kw)
    # Bullet pushes a joint back out of its limit by erp * penetration / dt each step (0.2 by
    # default): a door thrown into its stop bounces off it. A small erp makes the stop
    # inelastic, as in MuJoCo (our MJCF's solreflimit) and PhysX.
    pb.setPhysicsEngineParameter(erp=JOINT_ERP, **kw)
    with captured_c_output():  # its notes on links without an inertial (a fixed root's)
        body = pb.loadURDF(str(path), useFixedBase=True, flags=pb.URDF_USE_INERTIA_FROM_FILE,
                           **kw)
    by_name, dofs, damping, friction = {}, [], [], []  # dofs: Bullet's movable joints
    for j in range(pb.getNumJoints(body, **kw)):
        info = pb.getJointInfo(body, j, **kw)
        by_name[info[1].decode()] = j
        if info[2] != pb.JOINT_FIXED:
            dofs.append(j)
            damping.append(float(info[6]))
            friction.append(float(info[7]))
    damping, friction = np.array(damping), np.array(friction)
    missing = [n for n in experiment.joints if n not in by_name]
    if missing:
        raise KeyError(f"{path}: Bullet's model has no joint named {missing[0]!r}")
    index = [by_name[n] for n in experiment.joints]
    for link in range(-1, pb.getNumJoints(body, **kw)):
        # jointDamping 0: the damping is applied below, from the step's end velocity
        pb.changeDynamics(body, link, linearDamping=0.0, angularDamping=0.0, jointDamping=0.0,
                          **kw)
        if not experiment.contacts:
            pb.setCollisionFilterGroupMask(body, link, 0, 0, **kw)
    pb.setJointMotorControlArray(body, dofs, pb.VELOCITY_CONTROL, targetVelocities=[0.0] * len(dofs),
                                 forces=list(friction), **kw)
    extra = urdf_laws(path)
    springs = [(dofs.index(by_name[n]), extra[n]["stiffness"], extra[n].get("springref", 0.0))
               for n in experiment.joints if extra.get(n, {}).get("stiffness", 0.0) > 0.0]
    notes = []
    if any(extra.get(n, {}).get("armature", 0.0) for n in experiment.joints):
        notes.append("Bullet has no joint armature: the URDF's real2code:armature is ignored")
    for j, q, v in zip(index, experiment.q0, experiment.v0, strict=True):
        pb.resetJointState(body, j, q, v, **kw)
    recorder = Recorder(experiment)
    for step in range(experiment.steps + 1):
        if recorder.due(step):
            states = pb.getJointStates(body, index, **kw)
            recorder.add(step, np.array([s[0] for s in states]))
        if step == experiment.steps:
            break
        states = pb.getJointStates(body, dofs, **kw)
        q, v = np.array([s[0] for s in states]), np.array([s[1] for s in states])
        torque = np.zeros(len(dofs))
        for k, stiffness, ref in springs:
            torque[k] = -stiffness * (q[k] - ref)
        if damping.any():
            torque -= damping * _end_velocity(pb, body, q, v, torque, damping, friction,
                                              experiment.dt, kw)
        for j, t in zip(dofs, torque, strict=True):
            if t:
                pb.setJointMotorControl2(body, j, pb.TORQUE_CONTROL, force=float(t), **kw)
        pb.stepSimulation(**kw)
    return recorder.trajectory(notes)


def _end_velocity(pb, body, q, v, torque, damping, friction, dt, kw) -> np.ndarray:
    """The velocities of Bullet's degrees of freedom at the end of this step, the damping
    applied at them, MuJoCo's way: (M + dt D) v' = M v + dt (torque - bias - D v), then dry
    friction (impulses.py). Bullet applies a joint's damping at the step's start velocity
    (explicitly); for a light part (b dt / I of 1.6 %) thrown through a fall the two part
    by 2e-2 rad in 0.7 s. Limits are left out: the torque it gives against a joint's motion
    into its stop is taken up by Bullet's stop."""
    mass = np.array(pb.calculateMassMatrix(body, list(q), **kw))
    bias = np.array(pb.calculateInverseDynamics(body, list(q), list(v), [0.0] * len(q), **kw))
    inverse = np.linalg.inv(mass + dt * np.diag(damping))
    v_free = v + dt * inverse @ (torque - bias - damping * v)
    unlimited = np.full(len(q), np.inf)
    return constrain(v_free, inverse, q, dt, friction, -unlimited, unlimited)
