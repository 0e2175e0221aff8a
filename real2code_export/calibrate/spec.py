"""The model as MuJoCo simulates it for a replay: the exported MJCF's MjSpec, with every
joint that was not measured held at its observed state.

The spec comes from the MJCF exporter (``formats.mjcf.build_spec``), so what is fitted is
what every export carries. Holding the other joints is done on the model (they become
fixed joints at their state) before the spec is built, rather than by constraints in the
simulation: no soft equality constraint can drift. Geoms are removed (only inertials
matter, and no contact between parts can interfere with the joint being calibrated).
"""

from __future__ import annotations

import copy
from collections.abc import Sequence

import numpy as np

from ..errors import ModelError
from ..model import ArticulatedObject, Dynamics, JointType


def locked(obj: ArticulatedObject, measured: Sequence[str]) -> ArticulatedObject:
    """A copy of ``obj`` where every movable joint not in ``measured`` is fixed at its
    observed state."""
    out = copy.deepcopy(obj)
    names = {j.name for j in out.movable_joints}
    missing = [m for m in measured if m not in names]
    if missing:
        raise ModelError(f"object {obj.name!r}", f"has no movable joint(s) {missing}")
    for j in out.joints:
        if j.type.movable and j.name not in measured:
            j.origin = j.transform(j.state)
            j.type = JointType.FIXED
            j.limits = None
            j.dynamics = Dynamics()
            j.state = 0.0
    return out


def replay_spec(obj: ArticulatedObject, measured: Sequence[str]):
    """The spec to replay measurements of ``measured`` joints: the MJCF exporter's spec of
    the model with the other joints held, without geoms and meshes (contacts off), in
    radians."""
    import mujoco

    from ..formats.mjcf import build_spec

    spec = build_spec(locked(obj, measured))
    for geom in list(spec.geoms):
        spec.delete(geom)
    for mesh in list(spec.meshes):
        spec.delete(mesh)
    spec.compiler.degree = False
    spec.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    return spec


def subtree_bodies(obj: ArticulatedObject, joint: str) -> list[str]:
    """Parts that move with ``joint`` (its child and everything below it)."""
    children = obj.tree().children
    out, stack = [], [obj.joint(joint).child]
    while stack:
        name = stack.pop()
        out.append(name)
        stack.extend(j.child for j in children.get(name, ()))
    return out


def gravity_loaded(obj: ArticulatedObject, joint: str, gravity=(0.0, 0.0, -9.81)) -> bool:
    """Whether gravity can exert a generalized force on ``joint`` anywhere in its range:
    a hinge whose axis is vertical, or a horizontal slide, carries no gravity load."""
    from ..model import forward_kinematics

    j = obj.joint(joint)
    g = np.asarray(gravity, float)
    world = forward_kinematics(obj, obj.observed_configuration())
    axis_world = world[j.child][:3, :3] @ j.axis
    moving_mass = sum(obj.part(p).inertial.mass for p in subtree_bodies(obj, joint)
                      if obj.part(p).inertial is not None)
    if moving_mass == 0.0:
        return False
    along = abs(float(axis_world @ g)) / np.linalg.norm(g)
    if j.type is JointType.PRISMATIC:
        return along > 1e-9
    if along > 1.0 - 1e-9:
        return False
    # a hinge: loaded unless the moving centre of mass lies on the axis
    com = sum(world[p][:3, :3] @ obj.part(p).inertial.com * obj.part(p).inertial.mass
              + world[p][:3, 3] * obj.part(p).inertial.mass
              for p in subtree_bodies(obj, joint) if obj.part(p).inertial is not None)
    com = com / moving_mass - world[j.child][:3, 3]
    return float(np.linalg.norm(np.cross(axis_world, com))) > 1e-9
