"""A rig in Blender back into the model, with whatever the artist edited.

Read from the rig as it stands (see ``to_blender`` for its layout):

- names: an object's name (less Blender's ``.001``) when the artist renamed it, else the
  model name it was imported with; names are sanitised once, as every importer does;
- joint range, effort, velocity, dynamics and observed state: the joint Empty's custom
  properties; the joint type must stay the one the rig was built for (its motion channel);
- joint frame: the Empty's parent inverse plus its own location (move a hinge by moving its
  Empty; the locks guard against doing it by accident) for revolute and continuous joints;
  the axis is the Empty's Z arrow;
- parts: the mesh as the viewport shows it (modifiers applied), a part's own transform
  baked into its mesh; collision pieces are the mesh objects parented to the part in the
  rig's collision collection; colour from the part's first material;
- mass, centre of mass and inertia: the part's custom properties.

Values the rig still shows up to float32 rounding (``SNAP_TOLERANCE``) are replaced by the
exact float64 values imported, so an unedited rig exports exactly the model it was made from.
"""

from __future__ import annotations

import json

import bpy
import numpy as np

from real2code_export import transforms as tf
from real2code_export.errors import ModelError
from real2code_export.model import (
    DEFAULT_COLOR,
    ArticulatedObject,
    Dynamics,
    Inertial,
    Joint,
    JointType,
    Limits,
    Part,
    sanitize_name,
)

from . import mesh_data
from . import rig_props as rp


def find_rig(obj: bpy.types.Object | None) -> bpy.types.Object | None:
    """The object Empty of the rig ``obj`` belongs to (``obj`` itself or an ancestor)."""
    while obj is not None:
        if rp.role(obj) == rp.ROLE_OBJECT:
            return obj
        obj = obj.parent
    return None


def rig_joints(root: bpy.types.Object) -> list[bpy.types.Object]:
    """The joint Empties of a rig, in tree order."""
    out = []
    stack = [c for c in reversed(_children(root, rp.ROLE_PART))]
    while stack:
        ob = stack.pop()
        if rp.role(ob) == rp.ROLE_JOINT:
            out.append(ob)
        kids = _children(ob, rp.ROLE_JOINT) + _children(ob, rp.ROLE_PART)
        stack.extend(reversed(kids))
    return out


def read_rig(root: bpy.types.Object, depsgraph=None) -> ArticulatedObject:
    """The model a rig shows now; raises ModelError naming the object when it cannot be one."""
    roots = _children(root, rp.ROLE_PART)
    if len(roots) != 1:
        raise ModelError(f"rig {root.name!r}", f"needs exactly one root part under its object "
                         f"Empty, found {len(roots)}")
    parts: list[Part] = []
    joints: list[Joint] = []
    part_names: set[str] = set()
    joint_names: set[str] = set()

    objects: dict[str, bpy.types.Object] = {}  # model name -> part object
    joint_objects: dict[str, bpy.types.Object] = {}

    def visit(ob, to_frame: np.ndarray) -> str:
        """Read part ``ob`` and its subtree; ``to_frame`` maps the object's local coordinates
        into its part frame."""
        name = _model_name(ob, part_names)
        objects[name] = ob
        parts.append(_read_part(ob, name, to_frame, depsgraph))
        for je in _children(ob, rp.ROLE_JOINT):
            child = _only_child_part(je)
            joint = _read_joint(je, name, child, to_frame, joint_names)
            joints.append(joint)
            joint_objects[joint.name] = je
            joint.child = visit(child, _matrix(child.matrix_basis))
        return name

    first = roots[0]
    visit(first, _matrix(first.matrix_parent_inverse) @ _matrix(first.matrix_basis))
    # the model's own order (the rig is walked as a tree); renamed objects keep their place
    parts.sort(key=lambda p: rp.model_order(objects[p.name]))
    joints.sort(key=lambda j: rp.model_order(joint_objects[j.name]))
    try:
        metadata = json.loads(root.get(rp.METADATA) or "{}")
    except json.JSONDecodeError as e:
        raise ModelError(f"rig {root.name!r}", f"custom property {rp.METADATA} is not JSON: "
                         f"{e}") from e
    return ArticulatedObject(_model_name(root, set()), parts, joints, metadata)


def _children(ob, role: str) -> list[bpy.types.Object]:
    return sorted((c for c in ob.children if rp.role(c) == role), key=lambda c: c.name)


def _only_child_part(je) -> bpy.types.Object:
    kids = _children(je, rp.ROLE_PART)
    if len(kids) != 1:
        raise ModelError(f"joint Empty {je.name!r}", f"needs exactly one part as its child, "
                         f"found {len(kids)}")
    return kids[0]


def _model_name(ob, taken: set[str]) -> str:
    stored = ob.get(rp.NAME)
    base = rp.base_name(ob)
    raw = stored if stored is not None and base == stored else base
    return sanitize_name(raw, taken)


def _matrix(m) -> np.ndarray:
    return np.array(m, dtype=np.float64)


def _snap(value, exact_value, tol: float = rp.SNAP_TOLERANCE) -> np.ndarray:
    value = np.asarray(value, dtype=np.float64)
    if exact_value is None:
        return value
    exact_value = np.asarray(exact_value, dtype=np.float64).reshape(value.shape)
    return exact_value if np.allclose(value, exact_value, atol=tol, rtol=0) else value


def _read_part(ob, name: str, to_frame: np.ndarray, depsgraph) -> Part:
    bake = None if np.allclose(to_frame, np.eye(4), atol=1e-12) else to_frame
    visual = mesh_data.object_mesh(ob, depsgraph, bake) if ob.type == "MESH" else None
    pieces = sorted(_children(ob, rp.ROLE_COLLISION), key=rp.model_order)
    collision = []
    for piece in pieces:
        local = to_frame @ _matrix(piece.matrix_parent_inverse) @ _matrix(piece.matrix_basis)
        bake_piece = None if np.allclose(local, np.eye(4), atol=1e-12) else local
        collision.append(mesh_data.from_blender(piece.data, bake_piece))
    exact = rp.exact(ob)
    color = DEFAULT_COLOR
    material = ob.active_material if ob.type == "MESH" else None
    if material is not None:
        color = tuple(_snap(list(material.diffuse_color), exact.get("color"), 1e-6))
    elif "color" in exact:
        color = tuple(exact["color"])
    inertial = None
    if rp.MASS in ob:
        el = f"part {name!r} (object {ob.name!r})"
        try:
            inertial = Inertial(float(ob[rp.MASS]), np.array(ob.get(rp.COM, [0.0] * 3)),
                                np.array(ob.get(rp.INERTIA, list(np.eye(3).ravel())))
                                .reshape(3, 3))
        except (TypeError, ValueError) as e:
            raise ModelError(el, f"custom properties {rp.MASS}/{rp.COM}/{rp.INERTIA}: {e}") from e
    return Part(name, visual, collision, inertial, tuple(float(c) for c in color))


def _read_joint(je, parent: str, child_ob, parent_to_frame: np.ndarray,
                names: set[str]) -> Joint:
    """The joint between part ``parent`` and ``child_ob`` (its ``child`` is set by the caller,
    once the child part has its name)."""
    name = _model_name(je, names)
    el = f"joint {name!r} (object {je.name!r})"
    exact = rp.exact(je)
    built = exact.get("type", je.get(rp.TYPE))
    jtype = _joint_type(je, el, built)
    rest = parent_to_frame @ _matrix(je.matrix_parent_inverse)
    if JointType(built).angular:
        rest = rest @ tf.make(translation=np.array(je.location, dtype=np.float64))
    elif not JointType(built).movable:
        rest = rest @ _matrix(je.matrix_basis)
    unalign = _matrix(child_ob.matrix_parent_inverse)
    origin = rest @ unalign
    origin[:3, :3] = tf.orthonormalize(origin[:3, :3])
    origin = _snap(origin, exact.get("origin"))
    axis = unalign[:3, :3].T @ np.array([0.0, 0.0, 1.0])
    axis = _snap(axis / np.linalg.norm(axis), exact.get("axis"))
    limits = None
    if rp.LOWER in je or rp.UPPER in je:
        limits = Limits(_number(je, rp.LOWER, el), _number(je, rp.UPPER, el),
                        _optional(je, rp.EFFORT, el), _optional(je, rp.VELOCITY, el))
    if jtype is JointType.CONTINUOUS:
        limits = None
    dynamics = Dynamics(**{k: _number(je, rp.dynamics_key(k), el, 0.0) for k in rp.DYNAMICS})
    state = _number(je, rp.STATE, el, 0.0) if jtype.movable else 0.0
    return Joint(name, jtype, parent, child_ob.name, origin,
                 axis if jtype.movable else np.array([0.0, 0.0, 1.0]), limits, dynamics, state)


def _joint_type(je, el: str, built: str | None) -> JointType:
    text = je.get(rp.TYPE, built)
    try:
        jtype = JointType(text)
    except ValueError as e:
        raise ModelError(el, f"custom property {rp.TYPE} is {text!r}; expected one of "
                         f"{[t.value for t in JointType]}") from e
    if built is not None:
        was = JointType(built)
        same_motion = (jtype.angular and was.angular) or jtype is was
        if not same_motion:
            raise ModelError(el, f"type changed from {was.value} to {jtype.value}: the rig moves "
                             f"this joint as {was.value}; re-import the file to change its kind")
    return jtype


def _number(ob, key: str, el: str, default: float | None = None) -> float:
    if key not in ob:
        if default is None:
            raise ModelError(el, f"custom property {key} is missing")
        return default
    value = ob[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ModelError(el, f"custom property {key} must be a number, got {value!r}")
    return float(value)


def _optional(ob, key: str, el: str) -> float | None:
    return _number(ob, key, el) if key in ob else None
