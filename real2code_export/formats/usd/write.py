"""USD save: the object at q = state (bodies where the capture saw them), UsdPhysics joints,
mass, collision and looks, through the concept modules (body, geometry, joint) in the layout
of ``conventions``, authored through Sdf (``layer``); deterministic text (.usda) over a binary
layer of the mesh arrays (``meshes/<name>.usdc``), each written atomically. A massless part
fixed to its parent (a frame; a URDF ``ee_link`` with only a collision box; a chain of
collision-only links; an arm's flange the hand hangs from) is an Xform in its parent's body
(or in such an Xform), its geometry below it, no rigid body of its own: UsdPhysics has no
way to say "no mass" (0 means "compute it"), and PhysX would give it a mass from its
colliders' density or a default 1 kg (:func:`.body.in_parent_body`); a joint hanging from
it is written from the body holding it, naming it. So are the parts welded under a moving
part with no mass of its own (an MJCF free body whose mass lies in a body welded below
it), its body stating their summed mass (:func:`.body.carry_welded_mass`)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from ... import atomic
from ...meshfiles import MESH_DIR, write_object_meshes, write_texture_images
from ...model import (
    ArticulatedObject,
    Joint,
    JointType,
    forward_kinematics,
    metadata_json,
    sanitize_name,
    validate,
)
from .. import output_file
from . import d6
from .body import carry_welded_mass, hanging_pose, in_parent_body, write_body, write_frame
from .conventions import (
    FLOATING_JOINT,
    GEOMETRY,
    LOOKS,
    METADATA,
    PARENT_PART,
    PHYSICS,
    SCENE,
    WORLD_JOINT,
)
from .drive import write_drives
from .geometry import LateNormals, MeshAssets, move_mesh_arrays, write_part_geometry
from .joint import as_written, joint_frames, write_free_dynamics, write_joint, write_mimic
from .layer import apply, attribute, new_layer
from .loop import write_loops


def _layer(obj: ArticulatedObject):
    from pxr import Sdf

    with Sdf.ChangeBlock(), LateNormals() as normals:
        layer = _author(obj, normals)
        normals.finish()
        return layer


def _author(obj: ArticulatedObject, normals: LateNormals):
    layer, root = new_layer(obj.name, SCENE if obj.name != SCENE else f"{SCENE}_1")
    # Fixed base: "this API can be on a direct or indirect parent of the root joint which is
    # connected to the world, or on the joint itself" (UsdPhysicsArticulationRootAPI docs).
    # The object Xform is an indirect parent of the world joint below.
    apply(root, "PhysicsArticulationRootAPI")
    root.assetInfo = {"name": obj.name}
    attribute(root, METADATA, "String", metadata_json(obj, sort_keys=True), custom=True)

    base = f"/{obj.name}"
    # each joint's frames once: the bodies are placed with them and the joints written
    frames_of = {j.name: joint_frames(j) for j in obj.joints}
    written = ArticulatedObject(obj.name, obj.parts,
                                [as_written(j, frames_of[j.name]) for j in obj.joints])
    world = forward_kinematics(written, obj.observed_configuration())
    # chains the reader made of a generic joint (D6): written back as one, no bodies between
    generic = d6.chains(obj)
    between = {part for c in generic for part in c.between}
    in_generic = {j.name: c for c in generic for j in c.joints}
    in_body = in_parent_body(obj, set(in_generic))  # parents first
    frames = set(in_body)
    visuals: dict = {}  # the visual meshes written so far, which later meshes may refer to
    assets = MeshAssets(layer, base, obj, normals)  # assets placed more than once: once
    path_of = {}  # part -> its prim: a body's, or a frame's in its parent's prim
    for part in obj.parts:
        if part.name in frames or part.name in between:
            continue
        body = path_of[part.name] = f"{base}/{GEOMETRY}/{part.name}"
        write_body(layer, body, part, world[part.name])
        write_part_geometry(layer, part, body, f"{base}/{LOOKS}/{part.name}", visuals, assets)
    joint_of = {j.child: j for j in obj.joints}
    for name in in_body:  # an Xform in its parent's prim
        joint, frame = joint_of[name], obj.part(name)
        path = f"{path_of[joint.parent]}/{frame.name}"
        if layer.GetPrimAtPath(path):  # the name is one of the parent's own prims': a body
            frames.discard(frame.name)
            path = f"{base}/{GEOMETRY}/{frame.name}"
            write_body(layer, path, frame, world[frame.name])
        else:
            write_frame(layer, path, joint)
        path_of[name] = path
        write_part_geometry(layer, frame, path, f"{base}/{LOOKS}/{frame.name}", visuals,
                            assets)
    written_frames = [n for n in in_body if n in frames]
    carry_welded_mass(layer, obj, written_frames, path_of)
    hanging = hanging_pose(obj, written_frames)  # frame -> the body holding it, its pose there

    world_joint = sanitize_name(WORLD_JOINT, {j.name for j in obj.joints})
    root_part = obj.root.name
    write_joint(layer, f"{base}/{PHYSICS}/{world_joint}",
                Joint(world_joint, JointType.FIXED, "", root_part), None,
                f"{base}/{GEOMETRY}/{root_part}")
    for j in obj.joints:
        if j.child in frames:
            continue
        if j.name in in_generic:
            chain = in_generic[j.name]
            if j is chain.joints[0]:
                d6.write_chain(layer, f"{base}/{PHYSICS}/{chain.name}", chain,
                               f"{base}/{GEOMETRY}/{j.parent}",
                               f"{base}/{GEOMETRY}/{chain.joints[-1].child}")
            continue
        if j.type is JointType.FLOATING:  # a free body: no joint holds it; its name kept
            body = layer.GetPrimAtPath(f"{base}/{GEOMETRY}/{j.child}")
            attribute(body, FLOATING_JOINT, "String", j.name, custom=True)
            write_free_dynamics(body, j.dynamics)
            continue
        if j.parent in hanging:  # from the body holding the part it hangs from
            body, pose = hanging[j.parent]
            joint = write_joint(layer, f"{base}/{PHYSICS}/{j.name}",
                                replace(j, origin=pose @ j.origin), path_of[body],
                                f"{base}/{GEOMETRY}/{j.child}")
            attribute(joint, PARENT_PART, "String", j.parent, custom=True)
        else:
            joint = write_joint(layer, f"{base}/{PHYSICS}/{j.name}", j,
                                f"{base}/{GEOMETRY}/{j.parent}", f"{base}/{GEOMETRY}/{j.child}",
                                frames_of[j.name])
        if j.mimic is not None:
            write_mimic(joint, j.mimic, f"{base}/{PHYSICS}/{j.mimic.joint}", j.type.angular)
    taken = {j.name for j in obj.joints} | {world_joint}
    write_loops(layer, obj, lambda name: f"{base}/{PHYSICS}/{sanitize_name(name, taken)}",
                path_of.__getitem__)
    def driven(name: str):  # a joint's prim and the drive instance it takes there
        if name in in_generic:  # a generic joint's axis
            chain = in_generic[name]
            return layer.GetPrimAtPath(f"{base}/{PHYSICS}/{chain.name}"), \
                chain.dofs[[j.name for j in chain.joints].index(name)].name
        known = name in {j.name for j in obj.joints}
        return (layer.GetPrimAtPath(f"{base}/{PHYSICS}/{name}"), None) if known else None

    write_drives(layer, obj, driven)
    return layer


def save(obj: ArticulatedObject, out_dir: str | Path, *, write_meshes: bool = True) -> Path:
    """Write ``out_dir/<name>.usda`` and the mesh arrays it sublayers,
    ``out_dir/meshes/<name>.usdc`` (:func:`mesh_layer_path`; texture images as files in
    ``meshes/`` too, which USD refers to) and, if asked, the shared mesh files. The binary
    layer is written first: a .usda is never left without its meshes."""
    validate(obj)
    out_dir = Path(out_dir)
    if write_meshes:
        write_object_meshes(obj, out_dir)
    else:
        write_texture_images(obj, out_dir)
    layer = _layer(obj)
    data = move_mesh_arrays(layer)
    if data is not None:
        relative = mesh_layer_path(obj.name)
        atomic.write_with(out_dir / relative, lambda tmp: _export_on_one_thread(data, tmp))
        layer.subLayerPaths.append(f"./{relative}")
    return atomic.write_with(output_file("usd", out_dir, obj.name), lambda tmp: _export(layer, tmp))


def mesh_layer_path(name: str) -> str:
    """Where object ``name``'s binary mesh layer lies, relative to its .usda (in the mesh
    folder, so that no folder of exports holds a second model file for batch or check)."""
    return f"{MESH_DIR}/{name}.usdc"


def _export_on_one_thread(layer, path: Path) -> None:
    """:func:`_export`, USD's own threads held to one: its binary (crate) writer on several
    laid the same arrays out in another order now and then on a busy machine (the same
    content, other bytes: 2 of ~3000 files in session 28's runs, on d240c31 as since), and
    an export is to be the same bytes every time."""
    from pxr import Work

    limit = Work.GetConcurrencyLimit()
    Work.SetConcurrencyLimit(1)
    try:
        _export(layer, path)
    finally:
        Work.SetConcurrencyLimit(limit)


def _export(layer, path: Path) -> None:
    """``layer`` written to ``path`` by USD itself, in the format its suffix names (.usda
    text, .usdc binary), without passing the bytes through Python."""
    if not layer.Export(str(path)):
        raise OSError(f"USD could not write {path}")
