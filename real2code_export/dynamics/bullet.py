"""Bullet (``pybullet``): the URDF, base fixed, inertia from the file.

What a user must set because URDF has no place for it or Bullet defaults it otherwise (see
docs/engines.md): ``URDF_USE_INERTIA_FROM_FILE`` (else inertia comes from the collision
shapes); link damping 0 (Bullet's default is 0.04); its default velocity motors off, and a
velocity motor with target 0 and the URDF friction as its force limit in their place (Bullet
reads ``<dynamics damping>`` but not ``friction``); springs from our ``real2code:`` attributes
as a torque each step; a joint error reduction of 0.001 (its 0.2 default makes a joint
bounce off its limit). Bullet's limits are hard stops; it has no armature.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..probes._stdio import captured_c_output
from . import EngineUnavailable, Experiment, Recorder, Trajectory, urdf_laws

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
    by_name, friction = {}, {}
    for j in range(pb.getNumJoints(body, **kw)):
        info = pb.getJointInfo(body, j, **kw)
        by_name[info[1].decode()] = j
        friction[j] = float(info[7])
    missing = [n for n in experiment.joints if n not in by_name]
    if missing:
        raise KeyError(f"{path}: Bullet's model has no joint named {missing[0]!r}")
    index = [by_name[n] for n in experiment.joints]
    for link in range(-1, pb.getNumJoints(body, **kw)):
        pb.changeDynamics(body, link, linearDamping=0.0, angularDamping=0.0, **kw)
        if not experiment.contacts:
            pb.setCollisionFilterGroupMask(body, link, 0, 0, **kw)
    pb.setJointMotorControlArray(body, index, pb.VELOCITY_CONTROL, targetVelocities=[0.0] * len(index),
                                 forces=[friction[j] for j in index], **kw)
    extra = urdf_laws(path)
    springs = [(j, extra[n]["stiffness"], extra[n].get("springref", 0.0))
               for n, j in zip(experiment.joints, index, strict=True)
               if extra.get(n, {}).get("stiffness", 0.0) > 0.0]
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
        for j, k, ref in springs:
            q = pb.getJointState(body, j, **kw)[0]
            pb.setJointMotorControl2(body, j, pb.TORQUE_CONTROL, force=-k * (q - ref), **kw)
        pb.stepSimulation(**kw)
    return recorder.trajectory(notes)
