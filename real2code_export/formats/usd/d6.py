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
    return [d.name for d in dofs] == ["rotX", "rotY", "rotZ"] and all(
        d.lower is None for d in dofs)


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
