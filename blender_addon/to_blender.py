"""The model into Blender: one object per part, parented along the kinematic tree.

Layout of a rig (``<x>`` are model names)::

    collection <object>                      linked under the scene's collection, last
        <object>        Empty   the object (move it to place the whole rig)
        <root part>     Mesh    child of the object Empty
        <joint>         Empty   child of its parent part; the joint's frame
        <child part>    Mesh    child of its joint Empty
        collection <object> collision        hidden: the convex collision pieces,
            <part>_collision_<k>  Mesh       each a child of its part

A joint Empty's parent inverse is the joint frame at q = 0, turned so that its Z axis is the
joint axis (the arrow it draws); its own transform is the motion alone: a rotation about
local Z (revolute, continuous) or a translation along it (prismatic). So a part's local
transform is ``origin @ motion(q)``, its world matrix is the model's forward kinematics, and
the joint's limits are plain Limit Rotation / Limit Location constraints in local space.
The joint value is that motion channel itself (the panel's slider, the rotate and move tools
and keyframes all pose it); the limits are the custom properties
``real2code_lower``/``real2code_upper``, which drivers copy into the constraint, so the
gizmo stops at an edited limit too. Faces are smooth with edges sharper than
``SHARP_ANGLE`` marked sharp, as Blender's "Shade Auto Smooth" does: box furniture looks
flat, a rounded handle round.

Nothing is linked into the scene until every datablock exists; on any error all of them are
removed again, so a failed import leaves the file exactly as it was.
"""

from __future__ import annotations

import json
import math

import bpy
import numpy as np
from mathutils import Matrix

from real2code_export import transforms as tf
from real2code_export.model import ArticulatedObject, Joint, JointType, Part, forward_kinematics

from . import mesh_data
from . import rig_props as rp

Z = np.array([0.0, 0.0, 1.0])
SHARP_ANGLE = math.radians(30.0)


def joint_alignment(joint: Joint) -> np.ndarray:
    """Rotation (4x4) taking the joint Empty's local Z onto the joint axis (identity for a
    fixed joint). Export reads it back from the child part's parent inverse."""
    if not joint.type.movable:
        return np.eye(4)
    return tf.make(rotation=tf.rotation_between(Z, joint.axis))


def build_rig(obj: ArticulatedObject, scene: bpy.types.Scene, source: str = "") -> bpy.types.Object:
    """Make ``obj``'s rig in ``scene``, posed at the observed state; returns the object Empty."""
    made = _Made()
    try:
        root = _build(obj, made, source)
        scene.collection.children.link(made.collection)
    except BaseException:
        made.remove_all()
        raise
    return root


def remove_rig(root: bpy.types.Object) -> None:
    """Remove a rig this module built: its collections, objects, meshes and materials."""
    collections = [c for c in root.users_collection if root.name in c.objects]
    ids: set = set()
    for coll in collections:
        for c in [coll, *coll.children_recursive]:
            ids.add(c)
            for ob in c.objects:
                ids.add(ob)
                if ob.data is not None:
                    ids.add(ob.data)
                    ids.update(m for m in getattr(ob.data, "materials", []) if m is not None)
    bpy.data.batch_remove(ids)


class _Made:
    """Every datablock made so far, so that a failure can remove them all."""

    def __init__(self) -> None:
        self.ids: list[bpy.types.ID] = []
        self.collection: bpy.types.Collection | None = None

    def add(self, datablock):
        self.ids.append(datablock)
        return datablock

    def remove_all(self) -> None:
        if self.ids:
            bpy.data.batch_remove(self.ids)
        self.ids.clear()


def _build(obj: ArticulatedObject, made: _Made, source: str) -> bpy.types.Object:
    rig = made.collection = made.add(bpy.data.collections.new(obj.name))
    hidden = made.add(bpy.data.collections.new(f"{obj.name} collision"))
    hidden.hide_viewport = hidden.hide_render = True
    rig[rp.ROLE], hidden[rp.ROLE] = rp.ROLE_OBJECT, rp.ROLE_COLLISION
    rig.children.link(hidden)
    size = _object_size(obj)

    root = made.add(bpy.data.objects.new(obj.name, None))
    root.empty_display_type, root.empty_display_size = "PLAIN_AXES", 0.25 * size
    root[rp.ROLE], root[rp.NAME] = rp.ROLE_OBJECT, obj.name
    root[rp.METADATA] = json.dumps(obj.metadata, sort_keys=True)
    root[rp.SOURCE] = source
    rig.objects.link(root)

    part_objects = {}
    for part in obj.parts_in_tree_order():
        joint = obj.parent_joint(part.name)
        if joint is None:
            parent, parent_inverse = root, np.eye(4)
        else:
            parent = _joint_empty(joint, obj.joints.index(joint), part_objects[joint.parent],
                                  made, rig, size)
            parent_inverse = tf.inverse(joint_alignment(joint))
        part_objects[part.name] = _part_object(obj.name, part, obj.parts.index(part), parent,
                                               parent_inverse, made, rig, hidden)
    return root


def _object_size(obj: ArticulatedObject) -> float:
    """A length for drawing Empties: the diagonal of the parts' extent at rest."""
    poses = forward_kinematics(obj)
    corners = [p.visual.transformed(poses[p.name]).bounds() for p in obj.parts
               if p.visual is not None]
    if not corners:
        return 1.0
    points = np.concatenate(corners)
    return float(np.linalg.norm(points.max(axis=0) - points.min(axis=0))) or 1.0


def _part_object(object_name: str, part: Part, index: int, parent, parent_inverse: np.ndarray,
                 made: _Made, rig, hidden) -> bpy.types.Object:
    data = None
    if part.visual is not None:
        data = made.add(mesh_data.to_blender(part.name, part.visual))
        data.set_sharp_from_angle(angle=SHARP_ANGLE)
        data.materials.append(_material(f"{object_name}.{part.name}", part.color, made,
                                        part.texture, part.maps))
    ob = made.add(bpy.data.objects.new(part.name, data))
    if data is None:
        ob.empty_display_type, ob.empty_display_size = "CUBE", 0.02
    ob[rp.ROLE], ob[rp.NAME], ob[rp.INDEX] = rp.ROLE_PART, part.name, index
    rp.set_exact(ob, {"color": list(part.color)})
    if part.inertial is not None:
        ob[rp.MASS] = part.inertial.mass
        ob[rp.COM] = part.inertial.com.tolist()
        ob[rp.INERTIA] = part.inertial.inertia.reshape(-1).tolist()
        ob.id_properties_ui(rp.MASS).update(min=0.0, description="kg")
    rig.objects.link(ob)
    ob.parent = parent
    ob.matrix_parent_inverse = Matrix(parent_inverse.tolist())
    for k, piece in enumerate(part.collision):
        name = f"{part.name}_collision_{k}"
        pob = made.add(bpy.data.objects.new(name, made.add(mesh_data.to_blender(name, piece))))
        pob[rp.ROLE], pob[rp.NAME], pob[rp.INDEX] = rp.ROLE_COLLISION, name, k
        pob.display_type = "WIRE"
        hidden.objects.link(pob)
        pob.parent = ob
    return ob


def _material(name: str, color, made: _Made, texture=None, maps=None) -> bpy.types.Material:
    """The part's material: its colour, and its images wired into the Principled BSDF as
    Blender's own glTF importer wires them (so its glTF exporter finds them too): the base
    colour image into Base Color; the metallic-roughness map's G and B into Roughness and
    Metallic; the normal map through a Normal Map node; emissive into Emission Color;
    occlusion's R into the "glTF Material Output" group's Occlusion."""
    mat = made.add(bpy.data.materials.new(name))
    mat.diffuse_color = color  # the viewport (Solid, Workbench) colour
    if mat.node_tree is None:  # Blender < 5.0 makes no node tree by default
        mat.use_nodes = True
    bsdf = next((n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
    if bsdf is None:
        return mat
    bsdf.inputs["Base Color"].default_value = color
    bsdf.inputs["Alpha"].default_value = color[3]
    nodes, links = mat.node_tree.nodes, mat.node_tree.links

    def image_node(t, colour: bool):
        node = nodes.new("ShaderNodeTexImage")
        node.image = _image(t, made)
        if not colour:
            node.image.colorspace_settings.name = "Non-Color"
        return node

    def channels(t):
        split = nodes.new("ShaderNodeSeparateColor")
        links.new(image_node(t, False).outputs["Color"], split.inputs["Color"])
        return split

    maps = maps or {}
    if texture is not None:
        links.new(image_node(texture, True).outputs["Color"], bsdf.inputs["Base Color"])
    if "metallic_roughness" in maps:
        split = channels(maps["metallic_roughness"])
        links.new(split.outputs["Green"], bsdf.inputs["Roughness"])
        links.new(split.outputs["Blue"], bsdf.inputs["Metallic"])
    if "normal" in maps:
        normal = nodes.new("ShaderNodeNormalMap")
        links.new(image_node(maps["normal"], False).outputs["Color"], normal.inputs["Color"])
        links.new(normal.outputs["Normal"], bsdf.inputs["Normal"])
    if "emissive" in maps:
        links.new(image_node(maps["emissive"], True).outputs["Color"],
                  bsdf.inputs["Emission Color"])
        bsdf.inputs["Emission Strength"].default_value = 1.0
    if "occlusion" in maps:
        output = nodes.new("ShaderNodeGroup")
        output.node_tree = _gltf_output_group()
        links.new(channels(maps["occlusion"]).outputs["Red"], output.inputs["Occlusion"])
    return mat


GLTF_OUTPUT = "glTF Material Output"  # the group Blender's glTF add-on reads occlusion from


def _gltf_output_group() -> bpy.types.NodeTree:
    """Blender's glTF add-on's own group for what the Principled BSDF has no input for
    (occlusion): found by name, made as it makes it where the file has none yet."""
    group = bpy.data.node_groups.get(GLTF_OUTPUT)
    if group is None:
        group = bpy.data.node_groups.new(GLTF_OUTPUT, "ShaderNodeTree")
        group.interface.new_socket("Occlusion", in_out="INPUT", socket_type="NodeSocketFloat")
        group.nodes.new("NodeGroupInput")
    return group


def _image(texture, made: _Made) -> bpy.types.Image:
    """The texture's file packed into the .blend as it is (never re-encoded), as Blender's
    own glTF importer packs images."""
    image = made.add(bpy.data.images.new(texture.name, 8, 8))
    image.pack(data=texture.image, data_len=len(texture.image))
    image.source = "FILE"
    image.filepath_raw = f"//{texture.name}{texture.suffix}"
    return image


def _joint_empty(joint: Joint, index: int, parent, made: _Made, rig,
                 size: float) -> bpy.types.Object:
    je = made.add(bpy.data.objects.new(joint.name, None))
    je[rp.INDEX] = index
    je.empty_display_type = "SINGLE_ARROW" if joint.type.movable else "PLAIN_AXES"
    je.empty_display_size = 0.15 * size
    je[rp.ROLE], je[rp.NAME] = rp.ROLE_JOINT, joint.name
    je[rp.TYPE] = joint.type.value
    je[rp.AXIS] = joint.axis.tolist()
    rp.set_exact(je, {"type": joint.type.value, "origin": joint.origin.reshape(-1).tolist(),
                      "axis": joint.axis.tolist()})
    _joint_properties(je, joint)
    rig.objects.link(je)
    je.parent = parent
    je.matrix_parent_inverse = Matrix((joint.origin @ joint_alignment(joint)).tolist())
    je.lock_location = je.lock_rotation = je.lock_scale = (True, True, True)
    if joint.type.angular:
        je.lock_rotation = (True, True, False)
    elif joint.type is JointType.PRISMATIC:
        je.lock_location = (True, True, False)
    if joint.type.movable:
        path, index = rp.motion_channel(je)
        getattr(je, path)[index] = joint.state
    if joint.type.movable:
        _limit_constraint(je, joint)
    return je


def _joint_properties(je, joint: Joint) -> None:
    unit = "ANGLE" if joint.type.angular else "DISTANCE"
    if joint.type.movable:
        je[rp.STATE] = joint.state
        je.id_properties_ui(rp.STATE).update(subtype=unit)
    if joint.limits is not None:
        je[rp.LOWER], je[rp.UPPER] = joint.limits.lower, joint.limits.upper
        for key in (rp.LOWER, rp.UPPER):
            je.id_properties_ui(key).update(subtype=unit)
    # effort and velocity, with a range or without (a continuous joint's drive_limits)
    if joint.effort_limit is not None:
        je[rp.EFFORT] = joint.effort_limit
    if joint.velocity_limit is not None:
        je[rp.VELOCITY] = joint.velocity_limit
    for name in rp.DYNAMICS:
        je[rp.dynamics_key(name)] = float(getattr(joint.dynamics, name))


def _drive(target, path: str, index: int, source, prop: str):
    """A driver copying ``source[prop]`` into ``target.path[index]``: a plain property copy,
    so it runs without Python scripts being trusted."""
    curve = target.driver_add(path, index)
    driver = curve.driver
    driver.type = "AVERAGE"
    var = driver.variables.new()
    var.type = "SINGLE_PROP"
    var.targets[0].id_type = "OBJECT"
    var.targets[0].id = source
    var.targets[0].data_path = f'["{prop}"]'
    return curve


def _limit_constraint(je, joint: Joint) -> None:
    """Limit Rotation (about local Z) or Limit Location (along local Z), in local space, with
    the other two axes held at zero; the range follows the lower/upper custom properties.

    Limit Rotation reads angles in (-pi, pi]: a revolute range beyond that (rare) gets no
    constraint, and the slider's own range is the only limit shown."""
    if joint.type is JointType.PRISMATIC:
        con = je.constraints.new("LIMIT_LOCATION")
        for axis in "xyz":
            setattr(con, f"use_min_{axis}", True)
            setattr(con, f"use_max_{axis}", True)
    else:
        lim = joint.limits
        bounded = lim is not None and -math.pi <= lim.lower and lim.upper <= math.pi
        con = je.constraints.new("LIMIT_ROTATION")
        con.use_limit_x = con.use_limit_y = True
        con.use_limit_z = bounded
    con.name = f"{joint.name} limits"
    con.owner_space = "LOCAL"
    con.use_transform_limit = True
    if joint.limits is not None and (joint.type is JointType.PRISMATIC or con.use_limit_z):
        _drive(con, "min_z", -1, je, rp.LOWER)
        _drive(con, "max_z", -1, je, rp.UPPER)
