"""Joints: PhysicsRevoluteJoint (continuous = revolute without limits), PhysicsPrismaticJoint,
PhysicsSphericalJoint (ball; its cone limit as both cone angles) and PhysicsFixedJoint with body0 = parent, body1 =
child. A floating joint is no joint prim: UsdPhysics' free body is a rigid body no joint
holds (convert.py).

Frames. The model's child frame is the joint frame, so localPos1 = 0; localPos0/localRot0
place the joint frame in the parent. UsdPhysics axes are tokens (X, Y, Z): for any other
direction the joint frame is turned by R_a (the shortest rotation taking X onto the model
axis) on both sides, localRot0 = R_origin R_a and localRot1 = R_a, and the token is "X".
At joint value q the child sits at T0 M_X(q) T1^-1 = origin * motion(q), as in the model.

Units (checked against the schemas' own documentation):
- UsdPhysics limits: revolute in degrees, prismatic in metres.
- NewtonJointAPI (newton-usd-schemas generatedSchema.usda): ``newton:damping`` is
  effort*s/degree for angular DOFs, so N m s/rad * pi/180; ``newton:friction`` is an effort
  (N m or N, no angle: unconverted); ``newton:armature`` is mass*distance^2 for angular DOFs
  (kg m^2, no angle: unconverted); ``newton:velocityLimit`` is degrees/s. Newton's own
  mujoco-usd-converter converts exactly these (damping scaled, friction/armature copied).
- MjcJointAPI (MuJoCo's mjcPhysics schema): no pip package registers it, so its attributes are
  authored with the exact names and types MuJoCo's USD importer reads (usd_to_mjspec.cc
  ParseMjcPhysicsJointAPI) and "MjcJointAPI" is listed in apiSchemas, which that importer
  checks. Gains are per radian as in MJCF (``mjc:damping``, ``mjc:stiffness``,
  ``mjc:frictionloss``, ``mjc:armature``); positions are in the importer's MjSpec default
  unit, degrees for hinges (``mjc:springref``, ``mjc:ref``). ``mjc:ref`` = the observed
  state, because bodies are written at q = state and MuJoCo takes the written pose as q = ref
  (the schema: "the joint value corresponding to the initial model configuration"). Newton's
  opt-in SchemaResolverMjc instead reads ref as the value where the joint frames coincide
  (true of MuJoCo-exported files) and shifts the limits by it; its default resolvers ignore
  ``mjc:*`` and read these files correctly (checked with newton 1.8.0).
- PhysX's PhysicsJointStateAPI (angular/linear instance): ``state:angular:physics:position``
  = the observed state in degrees (metres for prismatic), the initial joint position that
  Isaac Sim and Newton (PhysX resolver) start from; the bodies are written at that state.
- Ours: ``real2code:state`` (rad or m, float64), ``real2code:effort`` (N m or N),
  ``real2code:velocity`` (rad/s or m/s).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ... import transforms as tf
from ...engine_settings import FRICTION_SOLREF, LIMIT_MARGIN, LIMIT_SOLIMP, LIMIT_SOLREF
from ...errors import warn
from ...model import DriveLimits, Dynamics, Joint, JointType, Limits, Mimic
from .conventions import NAMESPACE, as_float32, float_outward, snapped_quat
from .layer import apply, attribute, define, relationship

TOKENS = {"X": np.array([1.0, 0.0, 0.0]), "Y": np.array([0.0, 1.0, 0.0]),
          "Z": np.array([0.0, 0.0, 1.0])}
STATE, EFFORT, VELOCITY = (f"{NAMESPACE}:state", f"{NAMESPACE}:effort", f"{NAMESPACE}:velocity")
MJC_ATTRS = ("mjc:damping", "mjc:frictionloss", "mjc:armature", "mjc:stiffness",
             "mjc:springref", "mjc:ref")


@dataclass(frozen=True)
class JointFrames:
    """What the joint prim stores, as float32 values (held in float64)."""

    pos0: np.ndarray
    rot0: np.ndarray  # (w, x, y, z)
    rot1: np.ndarray
    token: str


def joint_frames(joint: Joint) -> JointFrames:
    axis = joint.axis / np.linalg.norm(joint.axis) if joint.type.movable else TOKENS["X"]
    token = next((t for t, e in TOKENS.items() if np.array_equal(axis, e)), None)
    turn = np.eye(3) if token else tf.rotation_between(TOKENS["X"], axis)
    return JointFrames(
        pos0=joint.origin[:3, 3].astype(np.float32).astype(np.float64),
        rot0=snapped_quat(joint.origin[:3, :3] @ turn).astype(np.float64),
        rot1=snapped_quat(turn).astype(np.float64),
        token=token or "X",
    )


def rest_origin(pos0, rot0, rot1) -> np.ndarray:
    """Pose of the body1 frame in the body0 frame at q = 0 when localPos1 = 0: T0 R1^-1."""
    return tf.make(tf.quat_to_matrix(rot0), pos0) @ tf.make(tf.quat_to_matrix(rot1).T)


def axis_in_body1(rot1, token: str) -> np.ndarray:
    a = tf.quat_to_matrix(rot1) @ TOKENS[token]
    return a / np.linalg.norm(a)


def as_written(joint: Joint, frames: JointFrames | None = None) -> Joint:
    """The joint as the file states it (float32 frames): bodies are placed with these, so the
    file is self-consistent and an imported file re-exports to the same bytes. ``frames``:
    the joint's :func:`joint_frames`, where the caller has them."""
    f = frames or joint_frames(joint)
    return dataclasses.replace(
        joint, origin=rest_origin(f.pos0, f.rot0, f.rot1),
        axis=axis_in_body1(f.rot1, f.token) if joint.type.movable else joint.axis)


# -- writing ---------------------------------------------------------------------------------
CONE_ATTRS = ("physics:coneAngle0Limit", "physics:coneAngle1Limit")  # degrees
_JOINT_TYPES = {JointType.FIXED: "PhysicsFixedJoint", JointType.BALL: "PhysicsSphericalJoint",
                JointType.PRISMATIC: "PhysicsPrismaticJoint"}  # else PhysicsRevoluteJoint


def write_joint(layer, path: str, joint: Joint, body0: str | None, body1: str,
                frames: JointFrames | None = None):
    """The joint's prim (``frames``: its :func:`joint_frames`, where the caller has them)."""
    from pxr import Gf

    kind = joint.type
    held = kind is JointType.BALL and joint.cone_limit == 0.0
    # a ball held at rest: a generic joint, every axis locked but the rotations, limited to
    # [0, 0] (a spherical joint's cone of 0 bounds the swing, not the twist); read back a ball
    prim = define(layer, path, "PhysicsJoint" if held else
                  _JOINT_TYPES.get(kind, "PhysicsRevoluteJoint"))
    if body0 is not None:
        relationship(prim, "physics:body0", body0)
    relationship(prim, "physics:body1", body1)
    f = frames or joint_frames(joint)
    attribute(prim, "physics:localPos0", "Point3f", Gf.Vec3f(*f.pos0.tolist()))
    attribute(prim, "physics:localRot0", "Quatf", Gf.Quatf(*f.rot0.tolist()))
    attribute(prim, "physics:localPos1", "Point3f", Gf.Vec3f(0.0, 0.0, 0.0))
    attribute(prim, "physics:localRot1", "Quatf", Gf.Quatf(*f.rot1.tolist()))
    if held:
        write_dynamics(prim, joint.dynamics, angular=True)
        for axis in ("transX", "transY", "transZ", "rotX", "rotY", "rotZ"):
            apply(prim, f"PhysicsLimitAPI:{axis}")
            low, high = (1.0, -1.0) if axis.startswith("trans") else (0.0, 0.0)  # locked
            attribute(prim, f"limit:{axis}:physics:low", "Float", low)
            attribute(prim, f"limit:{axis}:physics:high", "Float", high)
    elif kind is JointType.BALL:
        write_dynamics(prim, joint.dynamics, angular=True)
        if joint.cone_limit is not None:  # about X, as mujoco-usd-converter writes a range
            warn(f"USD: joint {joint.name!r}: the ball's cone limit is written as both cone "
                 "angles about X, which bound X's swing, not the twist about it that the "
                 "limit (MuJoCo's range: the whole rotation) bounds too")
            cone = float_outward(math.degrees(joint.cone_limit), upward=True)
            for name in CONE_ATTRS:
                attribute(prim, name, "Float", cone)
    if not kind.movable:
        return prim
    angular = kind.angular
    attribute(prim, "physics:axis", "Token", f.token, uniform=True)
    to_file = math.degrees if angular else float  # positions: degrees or metres
    if joint.limits is not None:
        attribute(prim, "physics:lowerLimit", "Float",
                  float_outward(to_file(joint.limits.lower), upward=False))
        attribute(prim, "physics:upperLimit", "Float",
                  float_outward(to_file(joint.limits.upper), upward=True))

    def custom(name: str, value: float) -> None:
        attribute(prim, name, "Double", float(value), custom=True)

    custom(STATE, joint.state)
    # PhysX's PhysicsJointStateAPI (not registered here either): the initial joint position,
    # read by Isaac Sim and by Newton's PhysX resolver, so simulation starts at q = state.
    instance = "angular" if angular else "linear"
    apply(prim, f"PhysicsJointStateAPI:{instance}")
    for name, value in (("position", to_file(joint.state)), ("velocity", 0.0)):
        attribute(prim, f"state:{instance}:physics:{name}", "Float", as_float32(value))
    if joint.effort_limit is not None:  # with a range or without (drive_limits)
        custom(EFFORT, joint.effort_limit)
    if joint.velocity_limit is not None:
        custom(VELOCITY, joint.velocity_limit)

    write_dynamics(prim, joint.dynamics, angular, ref=to_file(joint.state))
    if joint.velocity_limit is not None:
        attribute(prim, "newton:velocityLimit", "Float", as_float32(to_file(joint.velocity_limit)))
    return prim


# A free body has no joint prim to hold its floating joint's dynamics (MuJoCo's free joint
# applies each value to its six DOFs): kept on the body, in SI, where not zero.
FREE_DYNAMICS = {f: f"real2code:floatingJoint:{f}"
                 for f in ("damping", "friction", "stiffness", "spring_ref", "armature")}


def write_free_dynamics(body_prim, d: Dynamics) -> None:
    for field_name, attr in FREE_DYNAMICS.items():
        value = getattr(d, field_name)
        if value != 0.0:
            attribute(body_prim, attr, "Double", value, custom=True)


def read_free_dynamics(body_prim) -> Dynamics:
    return Dynamics(**{f: authored_value(body_prim, a) or 0.0 for f, a in FREE_DYNAMICS.items()})


def write_dynamics(prim, d: Dynamics, angular: bool, ref: float | None = None) -> None:
    """NewtonJointAPI's and MjcJointAPI's damping, friction, armature (and stiffness, spring
    reference, ``mjc:ref`` for a joint with one value). Newton's attributes are floats, as
    its schema declares them (newton-usd-schemas generatedSchema.usda)."""
    apply(prim, "NewtonJointAPI")
    per_degree = math.pi / 180.0 if angular else 1.0
    attribute(prim, "newton:damping", "Float", as_float32(d.damping * per_degree))
    attribute(prim, "newton:friction", "Float", as_float32(d.friction))
    attribute(prim, "newton:armature", "Float", as_float32(d.armature))

    apply(prim, "MjcJointAPI")  # not registered here: see the module docstring
    to_file = math.degrees if angular else float
    values = (d.damping, d.friction, d.armature, d.stiffness, to_file(d.spring_ref), ref)
    for name, value in zip(MJC_ATTRS, values, strict=True):
        if value is None:
            continue
        attribute(prim, name, "Double", float(value), uniform=True)
    # The constraint softness our MJCF authors (MjcJointAPI: solreflimit, solimplimit,
    # solreffriction), for importers that build a MuJoCo model from the USD.
    for name, value in (("mjc:solreflimit", LIMIT_SOLREF), ("mjc:solimplimit", LIMIT_SOLIMP),
                        ("mjc:solreffriction", FRICTION_SOLREF)):
        attribute(prim, name, "DoubleArray", [float(v) for v in value], uniform=True)
    # the limit acting at contact, as the MJCF's margin (Newton reads it as is: not converted
    # from degrees as mjc:ref is; a millionth either way)
    attribute(prim, "mjc:margin", "Double", LIMIT_MARGIN, uniform=True)


def write_mimic(prim, mimic: Mimic, leader_path: str, angular: bool) -> None:
    """NewtonMimicAPI (newton-usd-schemas): q = coef0 + coef1 * q_leader on the follower,
    coef0 in degrees for an angular joint."""
    apply(prim, "NewtonMimicAPI")
    relationship(prim, "newton:mimicJoint", leader_path)
    attribute(prim, "newton:mimicCoef0", "Float",
              as_float32(math.degrees(mimic.offset) if angular else mimic.offset))
    attribute(prim, "newton:mimicCoef1", "Float", as_float32(mimic.multiplier))
    attribute(prim, "newton:mimicEnabled", "Bool", True)


# -- reading ---------------------------------------------------------------------------------
def read_mimic(prim, angular: bool, mpu: float) -> Mimic | None:
    """The mimic of an enabled NewtonMimicAPI, naming the leader by its prim path (the
    reader renames it to the leader's joint)."""
    # (the composed list as authored: GetAppliedSchemas() leaves out a schema registered
    # after the process's first stage, as newton-usd-schemas is when imported late)
    if "NewtonMimicAPI" not in prim.GetPrimTypeInfo().GetAppliedAPISchemas():
        return None
    enabled = prim.GetAttribute("newton:mimicEnabled")
    targets = prim.GetRelationship("newton:mimicJoint").GetTargets()
    if (enabled and enabled.Get() is False) or len(targets) != 1:
        return None
    coef0 = authored_value(prim, "newton:mimicCoef0") or 0.0
    coef1 = authored_value(prim, "newton:mimicCoef1")
    offset = math.radians(coef0) if angular else coef0 * mpu
    return Mimic(str(targets[0]), 1.0 if coef1 is None else coef1, offset)


def authored_value(prim, name: str) -> float | None:
    attr = prim.GetAttribute(name)
    if not attr or not attr.HasAuthoredValue():
        return None
    value = attr.Get()
    return None if value is None else float(value)


def _pick(where: str, what: str, exact: float | None, schema: float | None,
          tol: float = 1e-6) -> float | None:
    """The schema value (what simulators read) unless our float64 copy agrees with it to
    float precision, in which case the exact copy; a disagreement is warned about."""
    if schema is None or not math.isfinite(schema):
        return exact
    if exact is None or abs(exact - schema) <= tol * max(1.0, abs(exact)):
        return schema if exact is None else exact
    warn(f"{where}: {what}: the schema value {schema} and {exact} disagree; using {schema}")
    return schema


def read_dynamics(prim, angular: bool, mpu: float, kpu: float, where: str) -> Dynamics:
    """Damping, friction, armature from NewtonJointAPI or MjcJointAPI (per radian, SI),
    stiffness and spring reference from MjcJointAPI."""
    # stage units -> SI: kg m^2/s, kg m^2/s^2, kg m^2, kg m^2/s^2 (angular) or
    # kg/s, kg m/s^2, kg, kg/s^2 (linear)
    if angular:
        scale = dict.fromkeys(("damping", "friction", "armature", "stiffness"), kpu * mpu * mpu)
    else:
        scale = {"damping": kpu, "friction": kpu * mpu, "armature": kpu, "stiffness": kpu}
    per_degree = math.pi / 180.0 if angular else 1.0
    newton = {k: authored_value(prim, f"newton:{k}") for k in ("damping", "friction", "armature")}
    if newton["damping"] is not None:
        newton["damping"] /= per_degree
    mjc = {"damping": authored_value(prim, "mjc:damping"),
           "friction": authored_value(prim, "mjc:frictionloss"),
           "armature": authored_value(prim, "mjc:armature")}
    values = {k: _pick(where, f"newton:{k} vs mjc", mjc[k], newton[k]) for k in newton}
    values["stiffness"] = authored_value(prim, "mjc:stiffness")
    out = {k: (v or 0.0) * scale[k] for k, v in values.items()}
    spring_ref = authored_value(prim, "mjc:springref") or 0.0
    spring_ref = math.radians(spring_ref) if angular else spring_ref * mpu
    return Dynamics(spring_ref=spring_ref, **out)


def read_cone_limit(desc, where: str) -> float | None:
    """A spherical joint's cone (rad) from its parsed limit (cone angles 0 and 1 in
    degrees; off or negative: free); two different angles, an elliptic cone, are warned
    and the smaller kept (the model's ball has one angle)."""
    lim = desc.limit
    angles = (float(lim.lower), float(lim.upper))
    if not lim.enabled or not all(math.isfinite(a) and a > 0.0 for a in angles):
        return None
    if angles[0] != angles[1]:
        warn(f"{where}: an elliptic cone ({CONE_ATTRS[0]} {angles[0]}, {CONE_ATTRS[1]} "
             f"{angles[1]} degrees): the smaller kept as the ball's cone limit")
    return math.radians(min(angles))


def read_limits(desc, kind: JointType, prim, mpu: float, kpu: float,
                where: str) -> tuple[Limits | None, DriveLimits | None]:
    """(the range from the parsed joint (degrees -> rad, units -> m) with effort and velocity,
    or None; effort and velocity of a joint without a range, or None), effort and velocity
    from our attributes or NewtonJointAPI's velocityLimit."""
    if kind not in (JointType.REVOLUTE, JointType.PRISMATIC, JointType.CONTINUOUS):
        return None, None
    angular = kind.angular
    to_model = math.radians if angular else (lambda v: v * mpu)
    effort = authored_value(prim, EFFORT)
    newton_velocity = authored_value(prim, "newton:velocityLimit")
    velocity = _pick(where, "velocity limit", authored_value(prim, VELOCITY),
                     None if newton_velocity is None else to_model(newton_velocity))
    if effort is not None:
        effort *= kpu * (mpu * mpu if angular else mpu)
    lim = desc.limit
    if kind is JointType.CONTINUOUS or not (lim.enabled and math.isfinite(lim.lower)
                                            and math.isfinite(lim.upper)):
        # a continuous joint, a slide without limits
        drive = None if effort is None and velocity is None else DriveLimits(effort, velocity)
        return None, drive
    return Limits(to_model(float(desc.limit.lower)), to_model(float(desc.limit.upper)),
                  effort=effort, velocity=velocity), None


def state_from_motion(motion: np.ndarray, kind: JointType, token: str,
                      where: str) -> float:
    """The joint value that explains ``motion`` (joint frame 1 in joint frame 0, metres), with
    a warning when the bodies are not where the joint allows."""
    e = TOKENS[token]
    if kind is JointType.PRISMATIC:
        q = float(motion[:3, 3] @ e)
        expected = tf.make(translation=e * q)
    elif kind.angular:
        r = motion[:3, :3]
        s = 0.5 * float(e @ np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]]))
        c = 0.5 * (float(np.trace(r)) - float(e @ r @ e))  # trace = 1 + 2cos, e'Re = 1
        q = math.atan2(s, c)
        expected = tf.make(rotation=tf.axis_angle_matrix(e, q))
    else:
        q, expected = 0.0, np.eye(4)
    off = np.abs(motion - expected).max()
    if off > 1e-5:
        warn(f"{where}: the bodies violate the joint by {off:.3g} at their written poses")
    return q
