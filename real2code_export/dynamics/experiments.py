"""The experiments of the dynamic check, each an object variant plus an :class:`Experiment`.

- ``swing``: every movable joint released from its observed state with a velocity under
  gravity, limits widened out of reach and the joint laws off: rigid-body dynamics alone.
- ``laws``: the same with the object's damping, dry friction, springs and armature.
- ``limit``: every joint thrown toward its nearer limit (the object's laws on), so that it
  reaches it within the first half second and stays there or rebounds as the engine's limit
  model says.

The variants are written by our own exporters, so every engine reads the file it reads
natively; what each engine then does with it is what is compared. None of these has
contacts: the variants carry no collision geometry.
"""

from __future__ import annotations

import copy

from ..model import ArticulatedObject, Dynamics, JointType, Limits
from . import Experiment

SWING_SPEED = {True: 0.5, False: 0.05}  # rad/s for angular joints, m/s for slides
WIDE = 100.0  # rad or m either side of the state: a range no 2 s swing reaches
LIMIT_REACH_TIME = 0.25  # s: a limit run reaches its limit about this soon
LIMIT_MIN_SPEED = {True: 1.0, False: 0.2}


def _start(joint) -> float:
    """The observed state, inside the limits."""
    if joint.limits is None:
        return joint.state
    return min(max(joint.state, joint.limits.lower), joint.limits.upper)


def _experiment(name: str, obj: ArticulatedObject, v0: list[float], **kw) -> Experiment:
    joints = obj.movable_joints
    return Experiment(name, tuple(j.name for j in joints), tuple(j.type.angular for j in joints),
                      tuple(_start(j) for j in joints), tuple(v0), **kw)


def _without_limits(obj: ArticulatedObject) -> ArticulatedObject:
    out = copy.deepcopy(obj)
    for j in out.movable_joints:
        if j.type is not JointType.CONTINUOUS:
            s = _start(j)
            j.limits = Limits(s - WIDE, s + WIDE, j.effort_limit, j.velocity_limit)
            j.drive_limits = None  # (a slide without a range had them there)
    return out


def _without_laws(obj: ArticulatedObject) -> ArticulatedObject:
    out = copy.deepcopy(obj)
    for j in out.movable_joints:
        j.dynamics = Dynamics(armature=j.dynamics.armature)
    return out


def without_velocity_limits(obj: ArticulatedObject) -> ArticulatedObject:
    """PhysX clamps a joint's speed at its velocity limit; MuJoCo, Bullet and Pinocchio do
    not: the experiments compare motion, so no run has one (docs/engines.md)."""
    out = copy.deepcopy(obj)
    for j in out.movable_joints:
        for held in (j.limits, j.drive_limits):
            if held is not None:
                held.velocity = None
    return out


def _without_collision(obj: ArticulatedObject) -> ArticulatedObject:
    """No contacts in any engine: the collision geometry left out (inertials are explicit).
    Parts overlapping at some joint value would otherwise push each other apart, wherever
    a format does not exclude the pair."""
    out = without_velocity_limits(obj)
    for part in out.parts:
        part.collision = []
    return out


def swing(obj: ArticulatedObject) -> tuple[ArticulatedObject, Experiment]:
    variant = _without_collision(_without_laws(_without_limits(obj)))
    v0 = [SWING_SPEED[j.type.angular] for j in obj.movable_joints]
    return variant, _experiment("swing", variant, v0)


def laws(obj: ArticulatedObject) -> tuple[ArticulatedObject, Experiment]:
    variant = _without_collision(_without_limits(obj))
    v0 = [SWING_SPEED[j.type.angular] for j in obj.movable_joints]
    return variant, _experiment("laws", variant, v0)


def limit(obj: ArticulatedObject) -> tuple[ArticulatedObject, Experiment]:
    """Toward the nearer limit (continuous joints swing freely)."""
    v0 = []
    for j in obj.movable_joints:
        if j.limits is None:
            v0.append(SWING_SPEED[j.type.angular])
            continue
        s = _start(j)
        up, down = j.limits.upper - s, s - j.limits.lower
        distance, sign = (up, 1.0) if up <= down else (down, -1.0)
        v0.append(sign * max(LIMIT_MIN_SPEED[j.type.angular], distance / LIMIT_REACH_TIME))
    variant = _without_collision(obj)
    return variant, _experiment("limit", variant, v0, stops=True)


EXPERIMENTS = {"swing": swing, "laws": laws, "limit": limit}
