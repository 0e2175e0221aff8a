"""A rig in Blender back into the model: what the viewport shows, with whatever the artist edited.

Read from the rig as it stands (see ``to_blender`` for its layout), in the rig's frame (the
object Empty's location and rotation; its scale is the object's):

- names: an object's name (less Blender's ``.001``) when the artist renamed it, else the
  model name it was imported with; names are sanitised once, as every importer does;
- joint range, effort, velocity, dynamics and observed state: the joint Empty's custom
  properties; the joint type must stay the one the rig was built for (its motion channel);
- geometry from the world matrices Blender shows (constraints applied): a part's frame is the
  rigid part of its world matrix, and whatever else the matrix holds (a scale on the rig, on
  a part or on a joint Empty; a part moved off its joint) is baked into its mesh, collision
  pieces and centre of mass and inertia (mass is kept: a scaled object is the same object
  drawn bigger, not a denser one; a warning says so). The joint frame is the joint Empty's
  with its own motion taken out, the axis its Z arrow, the joint value its motion channel
  (a prismatic one in metres as shown, its range too). A scale that a rigid joint cannot
  express (a hinge whose frame is stretched across its axis: turning it would shear the
  part) is refused, naming the joint;
- parts: the mesh as the viewport shows it (modifiers applied), with every mesh-like object
  the artist parented to the part (a handle, a knob) merged in; other objects parented to a
  part (a light, a camera) are named in a warning; collision pieces are the mesh objects
  parented to the part in the rig's collision collection; colour from the part's first
  material;
- mass, centre of mass and inertia: the part's custom properties.

Values the rig still shows up to float32 rounding (``SNAP_TOLERANCE``) are replaced by the
exact float64 values imported, so an unedited rig exports exactly the model it was made from.
``viewport_mismatches`` then poses the rig and the model together and says where they part.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import bpy
import numpy as np

from real2code_export import transforms as tf
from real2code_export.errors import ModelError, warn
from real2code_export.model import (
    DEFAULT_COLOR,
    ArticulatedObject,
    DriveLimits,
    Dynamics,
    Inertial,
    Joint,
    JointType,
    Limits,
    Mesh,
    Part,
    Texture,
    forward_kinematics,
    sanitize_name,
)

from . import mesh_data
from . import rig_props as rp

# object types Blender can turn into a mesh (Object.to_mesh): parented to a part, they are
# part of its visual
MESH_LIKE = frozenset({"MESH", "CURVE", "SURFACE", "FONT", "META"})
# how far (m) the exported model may put a part's mesh from where Blender shows it
VIEWPORT_TOLERANCE = 1e-4
# vertices per part compared with the viewport (spread over the mesh)
VIEWPORT_SAMPLES = 64


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


@dataclass
class RigReading:
    """The model a rig shows, and which Blender objects each of its parts and joints is."""

    model: ArticulatedObject
    part_objects: dict[str, bpy.types.Object] = field(default_factory=dict)
    joint_objects: dict[str, bpy.types.Object] = field(default_factory=dict)
    own_vertices: dict[str, int] = field(default_factory=dict)  # the part object's own mesh


def read_rig(root: bpy.types.Object, depsgraph=None) -> ArticulatedObject:
    """The model a rig shows now; raises ModelError naming the object when it cannot be one."""
    return read_rig_objects(root, depsgraph).model


def read_rig_objects(root: bpy.types.Object, depsgraph=None) -> RigReading:
    roots = _children(root, rp.ROLE_PART)
    if len(roots) != 1:
        raise ModelError(f"rig {root.name!r}", f"needs exactly one root part under its object "
                         f"Empty, found {len(roots)}")
    world = _Frames(root, depsgraph)
    parts: list[Part] = []
    joints: list[Joint] = []
    part_names: set[str] = set()
    joint_names: set[str] = set()
    reading = RigReading(None)

    def visit(ob, frame: np.ndarray) -> str:
        """Read part ``ob`` (its model frame ``frame`` in rig coordinates) and its subtree."""
        name = _model_name(ob, part_names)
        reading.part_objects[name] = ob
        part, own = _read_part(ob, name, frame, world, depsgraph)
        parts.append(part)
        reading.own_vertices[name] = own
        for je in _children(ob, rp.ROLE_JOINT):
            child = _only_child_part(je)
            joint, child_frame = _read_joint(je, name, frame, child, world, joint_names)
            joints.append(joint)
            reading.joint_objects[joint.name] = je
            joint.child = visit(child, child_frame)
        return name

    visit(roots[0], np.eye(4))  # the root part's frame is the rig's: its own transform is baked
    # the model's own order (the rig is walked as a tree); renamed objects keep their place
    parts.sort(key=lambda p: rp.model_order(reading.part_objects[p.name]))
    joints.sort(key=lambda j: rp.model_order(reading.joint_objects[j.name]))
    try:
        metadata = json.loads(root.get(rp.METADATA) or "{}")
    except json.JSONDecodeError as e:
        raise ModelError(f"rig {root.name!r}", f"custom property {rp.METADATA} is not JSON: "
                         f"{e}") from e
    reading.model = ArticulatedObject(_model_name(root, set()), parts, joints, metadata)
    return reading


def rig_configuration(reading: RigReading, depsgraph=None) -> dict[str, float]:
    """Each movable joint's value as the rig shows it now, in the model's units."""
    world = _Frames(find_rig(next(iter(reading.part_objects.values()))), depsgraph)
    out = {}
    for name, je in reading.joint_objects.items():
        joint = reading.model.joint(name)
        if joint.type.movable:
            out[name] = _joint_motion(je, joint.type, world).value
    return out


def viewport_mismatches(reading: RigReading, depsgraph) -> list[str]:
    """Where the model puts each part's mesh against where Blender shows it, at the rig's
    current pose: a line per part further apart than ``VIEWPORT_TOLERANCE``."""
    model = reading.model
    world = _Frames(find_rig(next(iter(reading.part_objects.values()))), depsgraph)
    poses = forward_kinematics(model, rig_configuration(reading, depsgraph))
    out = []
    for part in model.parts:
        ob = reading.part_objects[part.name]
        own = reading.own_vertices[part.name]
        if part.visual is None or own == 0 or ob.type != "MESH":
            continue
        shown = mesh_data.object_mesh(ob, depsgraph, world.matrix(ob))
        if len(shown.vertices) != own:
            out.append(f"part {part.name!r}: the viewport's mesh changed while posing")
            continue
        pick = np.linspace(0, own - 1, min(own, VIEWPORT_SAMPLES)).astype(int)
        placed = part.visual.vertices[pick] @ poses[part.name][:3, :3].T + \
            poses[part.name][:3, 3]
        gap = float(np.linalg.norm(placed - shown.vertices[pick], axis=1).max())
        if gap > VIEWPORT_TOLERANCE:
            out.append(f"part {part.name!r} (object {ob.name!r}): the model puts it {gap:.4g} m "
                       f"from where Blender shows it")
    return out


def compare_with_viewport(reading: RigReading, view_layer) -> list[str]:
    """``viewport_mismatches`` at the rig's pose and at a second one (every movable joint moved
    by a third of its range), so that a rig which moves otherwise than the model (a part that
    would shear, a joint turning about another axis) is caught; the pose is restored."""
    out = viewport_mismatches(reading, view_layer.depsgraph)
    posed = {je: rp.joint_value(je) for je in reading.joint_objects.values()
             if rp.motion_channel(je) is not None}
    if not posed:
        return out
    try:
        for je, value in posed.items():
            rp.set_joint_value(je, _another_value(je, value))
        view_layer.update()
        out += [f"{line} (second pose)" for line in
                viewport_mismatches(reading, view_layer.depsgraph)]
    finally:
        for je, value in posed.items():
            getattr(je, rp.motion_channel(je)[0])[rp.motion_channel(je)[1]] = value
        view_layer.update()
    return out


def _another_value(je, value: float) -> float:
    if rp.joint_kind(je) == "continuous" or rp.LOWER not in je or rp.UPPER not in je:
        return value + 0.5
    lower, upper = float(je[rp.LOWER]), float(je[rp.UPPER])
    step = (upper - lower) / 3.0
    return value + step if value + step <= upper else value - step


class _Frames:
    """World matrices in the rig's frame: the object Empty's location and rotation taken out,
    its scale kept (scaling the rig scales the object)."""

    def __init__(self, root, depsgraph) -> None:
        self.depsgraph = depsgraph
        self.to_rig = tf.inverse(_rigid(self._world(root)))

    def _world(self, ob) -> np.ndarray:
        shown = ob.evaluated_get(self.depsgraph) if self.depsgraph is not None else ob
        return _matrix(shown.matrix_world)

    def matrix(self, ob) -> np.ndarray:
        return self.to_rig @ self._world(ob)

    def child_matrix(self, ob) -> np.ndarray:
        """An object parented to a part, from its parent's matrix: collision pieces live in a
        hidden collection, which Blender does not evaluate."""
        return self.matrix(ob.parent) @ _matrix(ob.matrix_parent_inverse) @ \
            _matrix(ob.matrix_basis)


def _rigid(m: np.ndarray) -> np.ndarray:
    """The rotation and translation of an affine matrix (its polar decomposition's rotation);
    refused where the matrix mirrors (a negative scale), which no rigid frame expresses."""
    if np.linalg.det(m[:3, :3]) <= 0:
        raise ModelError("rig", "a negative or zero scale (a mirrored object) cannot be a "
                         "simulated part: apply it to the mesh or make the scale positive")
    return tf.make(rotation=tf.orthonormalize(m[:3, :3]), translation=m[:3, 3])


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


def _bake(frame: np.ndarray, shown: np.ndarray) -> np.ndarray | None:
    """What maps an object's local coordinates into its part frame; None where that is the
    identity up to float32 rounding (an unedited rig keeps its exact vertices)."""
    local = tf.inverse(frame) @ shown
    return None if np.allclose(local, np.eye(4), atol=rp.SNAP_TOLERANCE, rtol=0) else local


def _read_part(ob, name: str, frame: np.ndarray, world: _Frames, depsgraph) -> tuple[Part, int]:
    """The part ``ob`` in its model frame ``frame``; also how many of its visual's vertices
    are the part object's own mesh (the rest are meshes parented to it)."""
    el = f"part {name!r} (object {ob.name!r})"
    bake = _bake(frame, world.matrix(ob))
    meshes = [mesh_data.object_mesh(ob, depsgraph, bake)] if ob.type == "MESH" else []
    own = len(meshes[0].vertices) if meshes else 0
    for extra in _attached(ob, el):
        meshes.append(mesh_data.object_mesh(extra, depsgraph,
                                            tf.inverse(frame) @ world.child_matrix(extra)))
    visual = Mesh.concatenate(meshes) if meshes else None
    pieces = sorted(_children(ob, rp.ROLE_COLLISION), key=rp.model_order)
    collision = [mesh_data.from_blender(piece.data, _bake(frame, world.child_matrix(piece)))
                 for piece in pieces]
    exact = rp.exact(ob)
    color = DEFAULT_COLOR
    material = ob.active_material if ob.type == "MESH" else None
    images = _material_images(material, el) if material is not None else {}
    if images and (visual is None or visual.uv is None):
        warn(f"{el}: its material has images ({', '.join(images)}) but the mesh no UV map; "
             "they are not exported")
        images = {}
    texture = images.pop("texture", None)
    if material is not None:
        color = tuple(_snap(list(material.diffuse_color), exact.get("color"), 1e-6))
    elif "color" in exact:
        color = tuple(exact["color"])
    inertial = None
    if rp.MASS in ob:
        try:
            inertial = Inertial(float(ob[rp.MASS]), np.array(ob.get(rp.COM, [0.0] * 3)),
                                np.array(ob.get(rp.INERTIA, list(np.eye(3).ravel())))
                                .reshape(3, 3))
        except (TypeError, ValueError) as e:
            raise ModelError(el, f"custom properties {rp.MASS}/{rp.COM}/{rp.INERTIA}: {e}") from e
        if bake is not None:
            inertial = _moved_inertial(inertial, bake, el)
    return Part(name, visual, collision, inertial, tuple(float(c) for c in color),
                texture, images), own


def _source(socket, kind: str, output: str | None = None):
    """The node of type ``kind`` linked into ``socket`` (from its ``output``), or None."""
    link = socket.links[0] if socket is not None and socket.links else None
    if link is None or link.from_node.type != kind:
        return None
    if output is not None and link.from_socket.name != output:
        return None
    return link.from_node


def _split_image(socket, channel: str):
    """(image node) behind a Separate Color node's ``channel`` linked into ``socket``."""
    split = _source(socket, "SEPARATE_COLOR", channel)
    return _source(split.inputs["Color"], "TEX_IMAGE") if split is not None else None


def _material_images(material, el: str) -> dict[str, Texture]:
    """The images wired into the material as :func:`to_blender._material` (and Blender's
    glTF importer) wire them: "texture" into Base Color, and the maps. An image wired
    otherwise is not a map the model holds: Roughness and Metallic from different images are
    warned about."""
    if material.node_tree is None:
        return {}
    nodes = material.node_tree.nodes
    bsdf = next((n for n in nodes if n.type == "BSDF_PRINCIPLED"), None)
    if bsdf is None:
        return {}
    found = {"texture": _source(bsdf.inputs["Base Color"], "TEX_IMAGE"),
             "emissive": _source(bsdf.inputs["Emission Color"], "TEX_IMAGE")}
    normal = _source(bsdf.inputs["Normal"], "NORMAL_MAP")
    found["normal"] = _source(normal.inputs["Color"], "TEX_IMAGE") if normal else None
    rough = _split_image(bsdf.inputs["Roughness"], "Green")
    metal = _split_image(bsdf.inputs["Metallic"], "Blue")
    if rough is not None and metal is not None and rough.image == metal.image:
        found["metallic_roughness"] = rough
    elif rough is not None or metal is not None:
        warn(f"{el}: Roughness and Metallic are not the G and B of one image (glTF's "
             "metallic-roughness map); not exported")
    group = next((n for n in nodes if n.type == "GROUP" and n.node_tree is not None
                  and n.node_tree.name.startswith(("glTF Material Output", "glTF Settings"))),
                 None)
    if group is not None and "Occlusion" in group.inputs:
        found["occlusion"] = _split_image(group.inputs["Occlusion"], "Red")
    out = {}
    for role, node in found.items():
        texture = _node_image(node, el) if node is not None and node.image is not None else None
        if texture is not None:
            out[role] = texture
    return out


def _node_image(node, el: str) -> Texture | None:
    """An Image Texture node's image: its packed bytes, or its file; PNG and JPEG only (what
    every format reads)."""
    image = node.image
    if image.packed_file is not None:
        data = bytes(image.packed_file.data)
    else:
        path = bpy.path.abspath(image.filepath)
        try:
            with open(path, "rb") as f:
                data = f.read()
        except OSError as e:
            raise ModelError(el, f"image {image.name!r}: cannot read {path}: {e}") from e
    mime = Texture.sniff(data)
    if mime is None:
        warn(f"{el}: image {image.name!r} is neither PNG nor JPEG; not exported (save it as "
             "PNG)")
        return None
    return Texture(data, mime, sanitize_name(rp.base_name(image)))


def _attached(part_ob, el: str) -> list[bpy.types.Object]:
    """Objects the artist parented to a part (directly or through other such objects) that
    hold geometry; anything else parented there is named in a warning."""
    out, stack = [], [c for c in part_ob.children if rp.role(c) is None]
    while stack:
        ob = stack.pop()
        if ob.type in MESH_LIKE:
            out.append(ob)
        elif ob.type != "EMPTY":
            warn(f"{el}: {ob.type.lower()} {ob.name!r} is parented to the part but has no "
                 "geometry; it is not exported")
        stack.extend(c for c in ob.children if rp.role(c) is None)
    return sorted(out, key=lambda o: o.name)


def _moved_inertial(inertial: Inertial, bake: np.ndarray, el: str) -> Inertial:
    """The mass properties of a body drawn through ``bake`` (a part moved or scaled in its
    frame): the centre of mass is mapped; the inertia follows the mass distribution's second
    moment S -> L S L^T (I = tr(S) E - S); the mass is kept."""
    linear = bake[:3, :3]
    com = linear @ inertial.com + bake[:3, 3]
    second = 0.5 * np.trace(inertial.inertia) * np.eye(3) - inertial.inertia
    second = linear @ second @ linear.T
    inertia = np.trace(second) * np.eye(3) - second
    scale = abs(np.linalg.det(linear)) ** (1.0 / 3.0)
    if abs(scale - 1.0) > rp.SNAP_TOLERANCE:
        warn(f"{el}: drawn at {scale:.4g} times its size; its mass ({inertial.mass:g} kg) is "
             "kept as it was, its centre of mass and inertia follow the shape")
    return Inertial(inertial.mass, com, 0.5 * (inertia + inertia.T))


@dataclass
class _Motion:
    """A joint Empty as Blender shows it (constraints applied), its own motion taken apart."""

    at_rest: np.ndarray  # the joint Empty's world matrix (rig frame) at q = 0
    direction: np.ndarray  # the motion's axis (unit, rig frame)
    value: float  # the joint value in the model's units (radians; metres as shown)
    along: float  # how much a scale above the joint stretches its axis (prismatic values)


def _joint_motion(je, jtype: JointType, world: _Frames) -> _Motion:
    """The Empty's motion channel turns about (angular) or moves along (prismatic) the Z axis
    of the frame its parent gives it; whatever else its own transform holds is its rest."""
    parent = world.matrix(je.parent) @ _matrix(je.matrix_parent_inverse)
    local = np.linalg.inv(parent) @ world.matrix(je)  # (a scaled frame: no rigid inverse)
    along = float(np.linalg.norm(parent[:3, 2]))
    rest, value = local.copy(), 0.0
    if jtype.angular:
        value = math.atan2(local[1, 0], local[0, 0])
        rest[:3, :3] = tf.axis_angle_matrix([0.0, 0.0, 1.0], -value) @ local[:3, :3]
    elif jtype is JointType.PRISMATIC:
        rest[2, 3] -= local[2, 3]
        value = along * local[2, 3]
    return _Motion(parent @ rest, parent[:3, 2] / along, value, along)


def _read_joint(je, parent: str, parent_frame: np.ndarray, child_ob, world: _Frames,
                names: set[str]) -> tuple[Joint, np.ndarray]:
    """The joint between part ``parent`` and ``child_ob`` (its ``child`` is set by the caller,
    once the child part has its name), and the child part's frame as the rig shows it."""
    name = _model_name(je, names)
    el = f"joint {name!r} (object {je.name!r})"
    exact = rp.exact(je)
    built = exact.get("type", je.get(rp.TYPE))
    jtype = _joint_type(je, el, built)
    moves_as = JointType(built) if built is not None else jtype
    motion = _joint_motion(je, moves_as, world)
    if moves_as.angular:
        _check_turns_rigidly(world.matrix(je.parent) @ _matrix(je.matrix_parent_inverse), el)
    child_at_rest = _rigid(motion.at_rest @ _matrix(child_ob.matrix_parent_inverse))
    origin = tf.inverse(parent_frame) @ child_at_rest
    origin[:3, :3] = tf.orthonormalize(origin[:3, :3])
    origin = _snap(origin, exact.get("origin"))
    axis = _snap(child_at_rest[:3, :3].T @ motion.direction, exact.get("axis"))
    along = motion.along if jtype is JointType.PRISMATIC else 1.0
    limits = None
    if rp.LOWER in je or rp.UPPER in je:
        limits = Limits(along * _number(je, rp.LOWER, el), along * _number(je, rp.UPPER, el),
                        _optional(je, rp.EFFORT, el),
                        _scaled(_optional(je, rp.VELOCITY, el), along))
    if jtype is JointType.CONTINUOUS:
        limits = None
    drive_limits = None  # a joint without a range: its effort and velocity, if any
    if limits is None and jtype in (JointType.CONTINUOUS, JointType.PRISMATIC) and (
            rp.EFFORT in je or rp.VELOCITY in je):
        drive_limits = DriveLimits(_optional(je, rp.EFFORT, el),
                                   _scaled(_optional(je, rp.VELOCITY, el), along))
    dynamics = Dynamics(**{k: _number(je, rp.dynamics_key(k), el, 0.0) for k in rp.DYNAMICS})
    state = along * _number(je, rp.STATE, el, 0.0) if jtype.movable else 0.0
    joint = Joint(name, jtype, parent, child_ob.name, origin,
                  axis if jtype.movable else np.array([0.0, 0.0, 1.0]), limits, dynamics, state,
                  drive_limits=drive_limits)
    return joint, parent_frame @ joint.transform(motion.value if jtype.movable else 0.0)


def _scaled(value: float | None, factor: float) -> float | None:
    return None if value is None else factor * value


def _check_turns_rigidly(frame: np.ndarray, el: str) -> None:
    """A hinge turns its part rigidly only where the frame it turns in is not stretched across
    its axis (the same scale along x and y, both square to z); else Blender shears the part
    as it turns, which no simulator can."""
    linear = frame[:3, :3]
    gram = linear.T @ linear
    scale = np.sqrt(np.diag(gram))
    skew = max(abs(gram[0, 1]), abs(gram[0, 2]), abs(gram[1, 2])) / (scale.max() ** 2)
    if abs(scale[0] - scale[1]) > 1e-4 * scale.max() or skew > 1e-4:
        raise ModelError(el, f"its frame is scaled {scale[0]:.4g}, {scale[1]:.4g} across the "
                         "hinge (or skewed), so turning it would shear the part; make the scale "
                         "of the parts above it uniform, or apply it to their meshes with the "
                         "joints at rest")


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
