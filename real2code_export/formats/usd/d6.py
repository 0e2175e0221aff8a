"""The generic UsdPhysics joint (``PhysicsJoint``, a D6): six degrees of freedom, each free
unless a ``PhysicsLimitAPI`` instance (``transX`` ... ``rotZ``) bounds it, and locked where
that limit's low is above its high (the schema's convention). MuJoCo-style bodies of several
hinges come to USD this way (Newton's humanoid: a hip of three rotations, each limited).

What it is in the model, by the degrees of freedom left free:

- none: a fixed joint; one translation: a prismatic joint; one rotation: a revolute joint
  (continuous without a limit); the three rotations, none limited: a ball;
- else a chain, as Newton's importer and simulator take a D6 (``JointType.D6``: the free
  translations along the joint frame's axes, then the free rotations in X, Y, Z order, each
  about its axis as the rotations before it turned it) and as MuJoCo applies a body's
  several joints: one joint per free axis, named ``<joint>_<axis>`` (``hip_rotX``), through
  massless intermediate parts ``<child>_<joint>_<axis>``, as the MJCF reader splits a body
  of several joints (the MJCF writer merges them back into one body).

A degree of freedom without a limit is free (the schema: "by default all degrees of freedom
are free"); Newton 1.8's importer keeps only those with a ``PhysicsLimitAPI``. A ``distance``
limit (a rope between the frames) is no joint of the model: refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ... import transforms as tf
from ...errors import FormatError
from ...model import JointType

AXES = {"X": np.array([1.0, 0.0, 0.0]), "Y": np.array([0.0, 1.0, 0.0]),
        "Z": np.array([0.0, 0.0, 1.0])}
ORDER = ("transX", "transY", "transZ", "rotX", "rotY", "rotZ")  # Newton's D6 order
# A value this small (rad or m) is the rounding of the float32 joint frames the bodies'
# poses are compared through (float32's epsilon is 1.2e-7), not a pose: it is 0. (A chain's
# later joints away from 0 keep the MJCF writer from merging it into one body.)
FLOAT32_NOISE = 1e-7


@dataclass(frozen=True)
class Dof:
    """A free degree of freedom: ``name`` (``rotX``), its axis token, whether it turns, and
    its range as authored (degrees or stage units; None: unlimited)."""

    name: str
    token: str
    angular: bool
    lower: float | None = None
    upper: float | None = None

    @property
    def kind(self) -> JointType:
        if not self.angular:
            return JointType.PRISMATIC
        return JointType.CONTINUOUS if self.lower is None else JointType.REVOLUTE


def free_dofs(desc, path, element: str) -> list[Dof]:
    """The D6's free degrees of freedom in :data:`ORDER` (``desc``: UsdPhysics' parsed joint)."""
    limits = {}
    for pair in desc.jointLimits:
        name = pair.first.name[0].lower() + pair.first.name[1:]  # RotX -> rotX
        if name == "distance":
            raise FormatError(path, element, "a generic joint with a distance limit cannot be "
                              "represented (a rope between the frames, no joint of the model)")
        limits[name] = pair.second
    out = []
    for name in ORDER:
        lim = limits.get(name)
        lower = upper = None
        if lim is not None and lim.enabled:
            if lim.lower > lim.upper:  # locked
                continue
            if math.isfinite(lim.lower) and math.isfinite(lim.upper):
                lower, upper = float(lim.lower), float(lim.upper)
        out.append(Dof(name, name[-1], name.startswith("rot"), lower, upper))
    return out


def kind(dofs: list[Dof]) -> JointType:
    """What the D6 is: fixed, prismatic, revolute, continuous, ball, or for a chain the kind
    of its first joint (:func:`is_ball`, :func:`is_chain`)."""
    if not dofs:
        return JointType.FIXED
    return JointType.BALL if is_ball(dofs) else dofs[0].kind


def is_ball(dofs: list[Dof]) -> bool:
    """The three rotations free, or all three limited to [0, 0]: a ball held at its rest
    (:func:`is_held_ball`; how the USD writer writes a ball whose cone is 0, as a spherical
    joint's cone of 0 would leave the twist free)."""
    return [d.name for d in dofs] == ["rotX", "rotY", "rotZ"] and (
        all(d.lower is None for d in dofs) or is_held_ball(dofs))


def is_held_ball(dofs: list[Dof]) -> bool:
    return [d.name for d in dofs] == ["rotX", "rotY", "rotZ"] and all(
        d.lower == 0.0 and d.upper == 0.0 for d in dofs)


def is_chain(dofs: list[Dof]) -> bool:
    return len(dofs) > 1 and not is_ball(dofs)


def motion(dofs: list[Dof], values: list[float]) -> np.ndarray:
    """The D6's motion (joint frame 1 in joint frame 0, metres) at ``values`` (rad or m):
    the free translations, then the free rotations, each about its turned axis."""
    out = np.eye(4)
    for dof, q in zip(dofs, values, strict=True):
        axis = AXES[dof.token]
        out = out @ (tf.make(rotation=tf.axis_angle_matrix(axis, q)) if dof.angular
                     else tf.make(translation=axis * q))
    return out


def values_of(dofs: list[Dof], moved: np.ndarray) -> tuple[list[float], float]:
    """The values (rad or m) that explain ``moved`` (joint frame 1 in joint frame 0, metres),
    and how far the D6 leaves it unexplained (the largest entry of the difference)."""
    from scipy.spatial.transform import Rotation

    values = [float(moved[:3, 3] @ AXES[d.token]) for d in dofs if not d.angular]
    turns = [d.token for d in dofs if d.angular]
    if len(turns) == 1:
        e = AXES[turns[0]]
        r = moved[:3, :3]
        s = 0.5 * float(e @ np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]]))
        c = 0.5 * (float(np.trace(r)) - float(e @ r @ e))
        values.append(math.atan2(s, c))
    elif turns:  # intrinsic angles (upper case), the locked axis last
        sequence = "".join(turns) + "".join(t for t in "XYZ" if t not in turns)
        values += Rotation.from_matrix(moved[:3, :3]).as_euler(sequence)[:len(turns)].tolist()
    off = float(np.abs(moved - motion(dofs, values)).max())
    return [0.0 if abs(q) <= FLOAT32_NOISE else q for q in values], off


# -- writing: a chain the reader made of a generic joint, written back as one -----------------
@dataclass(frozen=True)
class Chain:
    """Joints of the model that are one generic joint (D6) ``name``: ``joints`` in
    :data:`ORDER` through massless intermediate parts (``between``), each about ``turn``'s
    column of its axis (the joint frame turned so that its axes are the joints')."""

    name: str
    joints: tuple  # model.Joint, in order
    dofs: tuple[Dof, ...]  # their axes, ranges in degrees or metres
    turn: np.ndarray  # 3x3: joint frame -> the first joint's origin frame
    between: tuple[str, ...]  # the intermediate parts


def chains(obj) -> list[Chain]:
    """The chains the USD reader makes of a generic joint of several free axes, as they
    stand in ``obj``: joints named ``<name>_<axis>`` in :data:`ORDER` (revolute, continuous
    or prismatic, all turning or all sliding, one dynamics, no mimic, no effort or velocity
    limit), through parts ``<child>_<joint>`` holding exactly the reader's negligible mass
    and nothing else, each joint after the first at the identity, their axes those of one
    turned frame. Anything else stays joints and bodies of their own."""
    from ...repairs import negligible_inertial

    tree, out = obj.tree(), []
    names = {j.name for j in obj.joints}
    placeholder = negligible_inertial()
    for first in obj.joints:
        chain, part = [first], first.child
        while len(tree.children[part]) == 1 and _bare(tree.parts[part], placeholder):
            nxt = tree.children[part][0]
            if not np.allclose(nxt.origin, np.eye(4), rtol=0, atol=1e-12):
                break
            chain.append(nxt)
            part = nxt.child
        # the longest run that is one (a bare part may follow the generic joint's child)
        found = next((c for n in range(len(chain), 1, -1)
                      if (c := _chain(chain[:n], names)) is not None), None)
        if found is not None:
            out.append(found)
    inner = {j.name for c in out for j in c.joints[1:]}  # (a chain's tail is one too)
    return [c for c in out if c.joints[0].name not in inner]


def _bare(part, placeholder) -> bool:
    i = part.inertial
    return (part.visual is None and not part.collision and part.texture is None
            and i is not None and i.mass == placeholder.mass and not np.any(i.com)
            and np.array_equal(i.inertia, placeholder.inertia))


def _chain(chain: list, names: set[str]) -> Chain | None:
    from ...model import JointType

    if len(chain) < 2:
        return None
    name, _, _ = chain[0].name.rpartition("_")
    if not name or name in names:  # (the generic joint's prim would take a joint's name)
        return None
    axes = [j.name[len(name) + 1:] for j in chain]
    if any(j.name != f"{name}_{a}" for j, a in zip(chain, axes, strict=True)) or any(
            a not in ORDER for a in axes) or [ORDER.index(a) for a in axes] != sorted(
            {ORDER.index(a) for a in axes}):
        return None
    final = chain[-1].child
    if [j.child for j in chain[:-1]] != [f"{final}_{j.name}" for j in chain[:-1]]:
        return None
    turning = {a.startswith("rot") for a in axes}
    kinds = {JointType.REVOLUTE, JointType.CONTINUOUS} if turning == {True} else \
        {JointType.PRISMATIC} if turning == {False} else set()
    d0 = chain[0].dynamics
    if any(j.type not in kinds or j.mimic is not None or j.drive_limits is not None
           or (j.limits is not None and (j.limits.effort is not None
                                         or j.limits.velocity is not None))
           or j.dynamics != d0 for j in chain):
        return None
    turn = _turn({a[-1]: j.axis for a, j in zip(axes, chain, strict=True)})
    if turn is None:
        return None
    dofs = []
    for a, j in zip(axes, chain, strict=True):
        scale = 180.0 / math.pi if a.startswith("rot") else 1.0
        lim = j.limits
        dofs.append(Dof(a, a[-1], a.startswith("rot"), None if lim is None else lim.lower * scale,
                        None if lim is None else lim.upper * scale))
    return Chain(name, tuple(chain), tuple(dofs), turn, tuple(j.child for j in chain[:-1]))


def _turn(axes: dict[str, np.ndarray]) -> np.ndarray | None:
    """The rotation taking each token's unit axis onto ``axes[token]`` (None: no rotation
    does, to 1e-9)."""
    tokens = sorted(axes)
    if len(tokens) == 1:
        return tf.rotation_between(AXES[tokens[0]], axes[tokens[0]])
    a, b = tokens[0], tokens[1]
    c = next(t for t in "XYZ" if t not in (a, b))
    sign = float(np.cross(AXES[a], AXES[b]) @ AXES[c])
    columns = {a: axes[a], b: axes[b], c: sign * np.cross(axes[a], axes[b])}
    turn = np.stack([columns[t] for t in "XYZ"], axis=1)
    if not np.allclose(turn.T @ turn, np.eye(3), rtol=0, atol=1e-9) or np.linalg.det(turn) < 0 \
            or any(not np.allclose(turn @ AXES[t], v, rtol=0, atol=1e-9) for t, v in axes.items()):
        return None
    return turn


def write_chain(layer, path: str, chain: Chain, body0: str, body1: str):
    """``chain`` as the generic joint prim it was read from: the first joint's origin turned
    (localRot1 = the turn, as the writer turns a revolute joint's frame onto its axis),
    each free axis limited or not, the others locked, the values as our float64 copies
    (``real2code:state:<axis>``) and PhysX's joint state, the dynamics once."""
    from pxr import Gf

    from .conventions import as_float32, float_outward, snapped_quat
    from .joint import STATE, write_dynamics
    from .layer import apply, attribute, define, relationship

    first = chain.joints[0]
    prim = define(layer, path, "PhysicsJoint")
    relationship(prim, "physics:body0", body0)
    relationship(prim, "physics:body1", body1)
    pos0 = first.origin[:3, 3].astype(np.float32).astype(np.float64)
    attribute(prim, "physics:localPos0", "Point3f", Gf.Vec3f(*pos0.tolist()))
    attribute(prim, "physics:localRot0", "Quatf",
              Gf.Quatf(*snapped_quat(first.origin[:3, :3] @ chain.turn).tolist()))
    attribute(prim, "physics:localPos1", "Point3f", Gf.Vec3f(0.0, 0.0, 0.0))
    attribute(prim, "physics:localRot1", "Quatf", Gf.Quatf(*snapped_quat(chain.turn).tolist()))
    free = {d.name: d for d in chain.dofs}
    for axis in ORDER:
        dof = free.get(axis)
        if dof is not None and dof.lower is None:
            continue  # free, no limit
        apply(prim, f"PhysicsLimitAPI:{axis}")
        low, high = (1.0, -1.0) if dof is None else (float_outward(dof.lower, upward=False),
                                                     float_outward(dof.upper, upward=True))
        attribute(prim, f"limit:{axis}:physics:low", "Float", low)
        attribute(prim, f"limit:{axis}:physics:high", "Float", high)
    for dof, joint in zip(chain.dofs, chain.joints, strict=True):
        attribute(prim, f"{STATE}:{dof.name}", "Double", float(joint.state), custom=True)
        apply(prim, f"PhysicsJointStateAPI:{dof.name}")  # (Newton reads a D6's start here)
        value = math.degrees(joint.state) if dof.angular else joint.state
        attribute(prim, f"state:{dof.name}:physics:position", "Float", as_float32(value))
        attribute(prim, f"state:{dof.name}:physics:velocity", "Float", 0.0)
    write_dynamics(prim, first.dynamics, chain.dofs[0].angular)
    return prim
