"""MuJoCo's actuators <-> the model's joint drives (:class:`~real2code_export.model.Drive`):
what the MJCF reader and the USD reader (MuJoCo's ``MjcActuator`` prims) share.

An actuator MuJoCo compiles to a force ``gain * ctrl + b0 + b1 * length + b2 * velocity``
on a joint transmission (``length = gear * q``, the joint's generalized force ``gear`` times
the actuator's) is a drive when that force is one of the model's three laws, whatever the
file's element (``<position>``, ``<velocity>``, ``<motor>``, a ``<general>`` of those
forms), the gear folded in:

- position (gain kp > 0, b0 = 0, b1 = -kp, b2 = -kv <= 0): stiffness gear^2 kp, damping
  gear^2 kv, target ctrl / gear;
- velocity (gain kv > 0, b0 = b1 = 0, b2 = -kv): damping gear^2 kv, target ctrl / gear;
- effort (no bias): force gear * gain * ctrl, the drive's target (the gain folded into the
  gear, so ctrl = gear * target is kept).

``ctrlrange`` is the target's range (divided by the gear) and a symmetric ``forcerange``
the force limit (times the gear). Anything else (a tendon, site or slider-crank
transmission, activation dynamics, a muscle, gain or bias of other forms, an asymmetric
force range, a second actuator on a joint, an actuator group or gravity compensation)
is no drive.

:func:`kinematic_spec` is the model's tree as MuJoCo needs it to compile an actuator's spec
values (a ``dampratio``'s damping from the joint's inertia, ``inheritrange`` from its range):
bodies with their mass properties, joints with their axes, ranges and armature, no geometry.
"""

from __future__ import annotations

import numpy as np

from . import transforms as tf
from .model import ArticulatedObject, Drive, DriveKind, JointType

_RTOL = 1e-12  # compiled parameters compared to the forms they must have (float64 exact)


def drive_of(m, i: int) -> tuple[Drive | None, str]:
    """The drive actuator ``i`` of the compiled model ``m`` is, or (None, why it is not)."""
    import mujoco

    if int(m.actuator_trntype[i]) != mujoco.mjtTrn.mjTRN_JOINT:
        return None, "not a joint transmission"
    joint = int(m.actuator_trnid[i, 0])
    if int(m.jnt_type[joint]) not in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
        return None, "on a ball or free joint"
    if int(m.actuator_dyntype[i]) != mujoco.mjtDyn.mjDYN_NONE:
        return None, "activation dynamics"
    if int(m.actuator_gaintype[i]) != mujoco.mjtGain.mjGAIN_FIXED:
        return None, "a gain that is not fixed"
    if int(m.actuator_plugin[i]) >= 0 or int(m.actuator_group[i]) != 0:
        return None, "a plugin or a group"
    if float(m.actuator_armature[i]) or float(m.actuator_damping[i]) or \
            np.any(m.actuator_dampingpoly[i]) or float(m.actuator_delay[i]) or \
            int(m.actuator_ctrlnum[i]) != 1 or np.any(m.actuator_history[i]):
        return None, "its own armature, damping, delay or history"
    gear = np.asarray(m.actuator_gear[i], dtype=np.float64)
    gain = np.asarray(m.actuator_gainprm[i], dtype=np.float64)
    bias = np.asarray(m.actuator_biasprm[i], dtype=np.float64)
    if int(m.actuator_biastype[i]) == mujoco.mjtBias.mjBIAS_NONE:
        bias = np.zeros_like(bias)
    elif int(m.actuator_biastype[i]) != mujoco.mjtBias.mjBIAS_AFFINE:
        return None, "a bias that is not affine"
    g, a = float(gear[0]), float(gain[0])
    if g == 0 or np.any(gear[1:]) or np.any(gain[1:]) or np.any(bias[3:]) or a == 0:
        return None, "a gain or bias of another form"
    b0, b1, b2 = (float(v) for v in bias[:3])
    ctrl = _range(m.actuator_ctrllimited[i], m.actuator_ctrlrange[i])
    force = _range(m.actuator_forcelimited[i], m.actuator_forcerange[i])
    if force is not None and force[0] != -force[1]:
        return None, "an asymmetric forcerange"
    if not any((b0, b1, b2)):  # a motor: the force is gear * a * ctrl
        kind, stiffness, damping, scale = DriveKind.EFFORT, 0.0, 0.0, g * a
    elif a > 0 and b0 == 0 and _close(b1, -a) and b2 <= 0:
        kind, stiffness, damping, scale = DriveKind.POSITION, g * g * a, 0.0 - g * g * b2, g
    elif a > 0 and b0 == 0 and b1 == 0 and _close(b2, -a):
        kind, stiffness, damping, scale = DriveKind.VELOCITY, 0.0, g * g * a, g
    else:
        return None, "a gain or bias of another form"
    target_range = None if ctrl is None else tuple(sorted((ctrl[0] / scale, ctrl[1] / scale)))
    force_limit = None if force is None else abs(g) * force[1]
    if force_limit is not None and force_limit <= 0:
        return None, "a forcerange of 0"
    return Drive(kind, stiffness, damping, force_limit=force_limit, target_range=target_range,
                 name=m.actuator(i).name or None, gear=scale), ""


def _range(limited, values) -> tuple[float, float] | None:
    return (float(values[0]), float(values[1])) if bool(limited) else None


def _close(x: float, y: float) -> bool:
    return abs(x - y) <= _RTOL * max(abs(x), abs(y))



def kinematic_spec(obj: ArticulatedObject):
    """The model as an MjSpec of bodies (mass properties; none where a part has none),
    joints (axis, range, armature) and no geometry: enough for MuJoCo to compile what
    depends on the tree's inertia at q = 0 (the model's reference pose)."""
    import mujoco

    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    spec.compiler.autolimits = True
    spec.compiler.balanceinertia = True
    bodies = {obj.root.name: spec.worldbody}
    kinds = {JointType.REVOLUTE: mujoco.mjtJoint.mjJNT_HINGE,
             JointType.CONTINUOUS: mujoco.mjtJoint.mjJNT_HINGE,
             JointType.PRISMATIC: mujoco.mjtJoint.mjJNT_SLIDE,
             JointType.BALL: mujoco.mjtJoint.mjJNT_BALL}
    for joint in obj.joints_in_tree_order():
        part = obj.part(joint.child)
        body = bodies[joint.parent].add_body(
            name=joint.child, pos=joint.origin[:3, 3].tolist(),
            quat=tf.matrix_to_quat(joint.origin[:3, :3]).tolist())
        if part.inertial is not None:
            body.explicitinertial = True
            body.mass = part.inertial.mass
            body.ipos = part.inertial.com.tolist()
            i = part.inertial.inertia
            body.fullinertia = [i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2], i[1, 2]]
        if joint.type is JointType.FLOATING:
            body.add_freejoint(name=joint.name)
        elif joint.type in kinds:
            j = body.add_joint(name=joint.name, type=kinds[joint.type],
                               axis=np.asarray(joint.axis, float).tolist(),
                               armature=joint.dynamics.armature)
            if joint.limits is not None and joint.type is not JointType.BALL:
                j.limited = mujoco.mjtLimited.mjLIMITED_TRUE
                j.range = [joint.limits.lower, joint.limits.upper]
        bodies[joint.child] = body
    return spec
