"""KHR_physics_rigid_bodies: the model's bodies and joints as the extension describes them,
and back.

Written (following the extension's current draft and its reference Blender exporter):
- every non-root part that is its own rigid body carries ``motion`` (mass, centre of mass,
  principal inertia and its orientation; a moving part with no mass of its own, the summed
  mass properties of the parts welded below it, which are then no bodies of their own:
  :func:`bodies`); the root part is static (fixed to the world);
- each collision piece is a ``collider`` node under its part. A piece that is a box is a
  ``KHR_implicit_shapes`` box, the collider node's transform placing it; any other piece's
  ``geometry`` names a mesh-only node outside the scene (``convexHull``: the pieces are
  convex), so no viewer renders it (Blender's importer shows such nodes in an "Orphan
  Nodes" collection: boxes keep that empty for box-built objects such as reconstructions);
- each joint is a ``joint`` on an attachment node in the parent body whose ``connectedNode``
  is an attachment node in the child body. Both attachment frames have their X axis along
  the joint axis, so the joint is a 1-D angular or linear limit about/along X with every
  other degree of freedom locked (the extension's own hinged-door recipe); a ball's cone
  limit is a 2-D angular limit on Y and Z (the extension's cone about X). Limits are in
  radians / metres; the joint value is the twist of the child frame relative to the parent
  frame, as in the extension's joint-limit metrics.
- the model's spring and damping become a ``force`` drive (stiffness toward spring_ref,
  damping toward zero velocity): the drive equation is exactly that passive spring-damper;
  a ball joint's damping is one such drive on each of its three rotations (its stiffness,
  toward a rotation, is in our extras only). Friction, armature and effort/velocity limits have no place in the extension and live
  in our extras only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ... import transforms as tf
from ...errors import warn
from ...model import Dynamics, Inertial, Joint, JointType, Mesh, Tree
from .conventions import quat_xyzw

LOCK = 1e-9  # a limit with |min|, |max| below this locks its axes

# A unit box as trimesh.creation.box lays it out (the corners in this order, these
# triangles): the project's box pieces are made by it, so a piece with this layout is a box
# written as an implicit shape and read back vertex for vertex. Written out rather than
# imported: the glTF writer does not import trimesh (its import costs more than an export).
BOX_CORNERS = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
BOX_FACES = np.array([[1, 3, 0], [4, 1, 0], [0, 3, 2], [2, 4, 0], [1, 7, 3], [5, 1, 4],
                      [5, 7, 1], [3, 7, 2], [6, 4, 2], [2, 7, 6], [6, 5, 4], [7, 5, 6]])
BOX_TOLERANCE = 1e-6  # m per metre of the box's place: float32 vertices are this close


def box_mesh(size, pose: np.ndarray) -> Mesh:
    """The box of edge lengths ``size`` at ``pose`` (4x4), in the layout above."""
    corners = BOX_CORNERS * np.asarray(size, dtype=float)
    return Mesh(corners @ pose[:3, :3].T + pose[:3, 3], BOX_FACES.copy())


def as_box(piece: Mesh) -> tuple[list[float], np.ndarray] | None:
    """(size, pose) when ``piece`` is a box in the layout above, within float32 rounding;
    None otherwise. Computed from the float32 vertices a file stores, so the piece read back
    gives the same numbers again."""
    if piece.vertices.shape != (8, 3) or not np.array_equal(piece.faces, BOX_FACES):
        return None
    v = piece.vertices.astype(np.float32).astype(np.float64)
    edges = np.stack([v[4] - v[0], v[2] - v[0], v[1] - v[0]], axis=1)
    size = np.linalg.norm(edges, axis=0)
    if (size <= 0).any():
        return None
    pose = np.eye(4)
    pose[:3, :3] = edges / size
    pose[:3, 3] = v.mean(axis=0)
    r = pose[:3, :3]
    tol = BOX_TOLERANCE * (1.0 + float(np.abs(v).max()))
    if not np.allclose(r.T @ r, np.eye(3), atol=1e-6) or np.linalg.det(r) < 0 \
            or not np.allclose(box_mesh(size, pose).vertices, v, atol=tol, rtol=0):
        return None
    pose[:3, :3] = tf.orthonormalize(r)
    return [float(x) for x in size], pose


def bodies(tree: Tree) -> dict[str, Inertial | None]:
    """The parts that are rigid bodies of their own, each with the mass properties its
    ``motion`` states (in the part frame). A non-root part is its own body when it moves or
    has mass; a massless part on a fixed joint simply belongs to its parent's body (the
    extension's node-tree rule). A moving part with no mass of its own carries the parts
    fixed below it (:func:`inertia.carrier`): the extension can state no zero mass (zero
    means infinite, none "compute it from the colliders"), so that group is one body with
    the parts' summed mass properties."""
    from ...inertia import carrier, combine_inertials, welded_below

    out: dict[str, Inertial | None] = {}
    for name, joint in tree.parent.items():
        inertial = tree.parts[name].inertial
        if joint.type is JointType.FIXED:
            if inertial is not None and carrier(tree, name) is None:
                out[name] = inertial
            continue
        welded = [(tree.parts[part].inertial, pose) for part, pose in welded_below(tree, name)
                  if tree.parts[part].inertial is not None] if inertial is None else []
        out[name] = combine_inertials(welded) if welded else inertial
    return out


def motion(inertial: Inertial | None) -> dict:
    out: dict = {}
    if inertial is not None:
        moments, axes = inertial.principal()
        out = {
            "mass": inertial.mass,
            "centerOfMass": [float(v) for v in inertial.com],
            "inertiaDiagonal": [float(v) for v in moments],
            "inertiaOrientation": quat_xyzw(axes),
        }
    return out


def attachment_rotation(joint: Joint) -> np.ndarray:
    """Rotation of both attachment frames in their joint frame: X along the joint axis."""
    if not joint.type.movable:
        return np.eye(3)
    return tf.rotation_between([1.0, 0.0, 0.0], joint.axis)


def joint_description(joint: Joint) -> dict:
    """The ``physicsJoints`` entry: limits on the attachment frames and the passive drive."""
    lock = {"min": 0.0, "max": 0.0}
    t = joint.type
    # (a ball of cone 0 is held at its rest: every axis locked, its extras say it is a ball)
    if t is JointType.FIXED or (t is JointType.BALL and joint.cone_limit == 0.0):
        limits = [{"linearAxes": [0, 1, 2], **lock}, {"angularAxes": [0, 1, 2], **lock}]
    elif t is JointType.BALL:  # every rotation free, or the X axis within a cone
        limits = [{"linearAxes": [0, 1, 2], **lock}]
        if joint.cone_limit is not None:  # the extension's 2-D angular limit: a cone about X
            warn(f"glTF: joint {joint.name!r}: the ball's cone limit is written as "
                 "KHR_physics_rigid_bodies' cone about X, which bounds X's swing, not the "
                 "twist about it that the limit (MuJoCo's range: the whole rotation) bounds "
                 "too; exact in our extras")
            limits.append({"angularAxes": [1, 2], "min": 0.0, "max": joint.cone_limit})
    elif t.angular:
        limits = [{"linearAxes": [0, 1, 2], **lock}, {"angularAxes": [1, 2], **lock}]
    else:
        limits = [{"linearAxes": [1, 2], **lock}, {"angularAxes": [0, 1, 2], **lock}]
    if joint.limits is not None:
        key = "angularAxes" if t.angular else "linearAxes"
        limits.append({key: [0], "min": joint.limits.lower, "max": joint.limits.upper})
    out: dict = {"name": joint.name, "limits": limits}
    d = joint.dynamics
    if t.movable and (d.stiffness > 0 or d.damping > 0):
        drive: dict = {"type": "angular" if t.angular else "linear", "mode": "force", "axis": 0}
        if d.stiffness > 0:
            drive.update(positionTarget=d.spring_ref, stiffness=d.stiffness)
        if d.damping > 0:
            drive.update(velocityTarget=0.0, damping=d.damping)
        out["drives"] = [drive]
    elif t is JointType.BALL and d.damping > 0:  # MuJoCo's ball damps each of its rotations
        out["drives"] = [{"type": "angular", "mode": "force", "axis": k, "velocityTarget": 0.0,
                          "damping": d.damping} for k in range(3)]
    return out


# -- reading ---------------------------------------------------------------------------------
@dataclass
class FreeAxis:
    """The single degree of freedom a physics joint leaves free (in the attachment frame)."""

    kind: str  # "angular", "linear" or "fixed"
    axis: int = 0
    lower: float | None = None  # None: unbounded
    upper: float | None = None


def free_axis(description: dict) -> FreeAxis | None:
    """Classify a ``physicsJoints`` entry: fixed, or exactly one angular or linear degree of
    freedom (optionally limited). None when the joint leaves more than one free."""
    locked: set[tuple[str, int]] = set()
    bounded: dict[tuple[str, int], tuple[float, float]] = {}
    for limit in description.get("limits", []) or []:
        kind = "angular" if "angularAxes" in limit else "linear"
        axes = limit.get("angularAxes" if kind == "angular" else "linearAxes") or []
        lo = float(limit.get("min", -np.inf))
        hi = float(limit.get("max", np.inf))
        if abs(lo) <= LOCK and abs(hi) <= LOCK:
            locked.update((kind, int(a)) for a in axes)
        elif len(axes) == 1:
            key = (kind, int(axes[0]))
            old = bounded.get(key, (-np.inf, np.inf))
            bounded[key] = (max(old[0], lo), min(old[1], hi))
    dofs = [(k, a) for k in ("angular", "linear") for a in range(3) if (k, a) not in locked]
    if not dofs:
        return FreeAxis("fixed")
    if len(dofs) != 1:
        return None
    kind, axis = dofs[0]
    lo, hi = bounded.get((kind, axis), (-np.inf, np.inf))
    return FreeAxis(kind, axis, None if np.isinf(lo) else lo, None if np.isinf(hi) else hi)


def drive_dynamics(description: dict, axis: FreeAxis, sign: float) -> tuple[Dynamics, list[str]]:
    """The model's spring-damper from a force drive on the free axis (``sign`` -1 when the
    joint is read from the child side). Returns the dynamics and what could not be mapped."""
    dyn = Dynamics()
    skipped = []
    for drive in description.get("drives", []) or []:
        if drive.get("type") != axis.kind or int(drive.get("axis", -1)) != axis.axis:
            skipped.append("a drive on a locked axis")
            continue
        if drive.get("mode", "force") != "force":
            skipped.append(f"a drive in {drive.get('mode')!r} mode")
            continue
        if float(drive.get("velocityTarget", 0.0)) != 0.0:
            skipped.append("a non-zero velocity target")
        dyn.stiffness = float(drive.get("stiffness", 0.0))
        dyn.damping = float(drive.get("damping", 0.0))
        dyn.spring_ref = sign * float(drive.get("positionTarget", 0.0))
    return dyn, skipped
