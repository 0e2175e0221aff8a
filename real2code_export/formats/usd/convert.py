"""USD save and load, run in order over the concept modules (stage, body, geometry, joint).

save: the object at q = state (bodies where the capture saw them), UsdPhysics joints, mass,
collision and looks; deterministic text (.usda), written atomically.
load: UsdPhysics' parser finds bodies and joints (articulation.py); each body becomes a part
whose frame is its parent joint's frame, each joint a model joint.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ... import atomic
from ... import transforms as tf
from ...errors import FormatError, ModelError, warn
from ...meshfiles import write_object_meshes
from ...model import (
    ArticulatedObject,
    Dynamics,
    Joint,
    JointType,
    Mesh,
    Part,
    forward_kinematics,
    metadata_json,
    sanitize_name,
    validate,
)
from ...repairs import unusable_mimics
from . import articulation as art_
from .body import read_inertial, write_body
from .geometry import read_color, read_mesh, shape_mesh, write_part_geometry
from .joint import (
    STATE,
    as_written,
    authored_value,
    axis_in_body1,
    read_dynamics,
    read_limits,
    read_mimic,
    rest_origin,
    state_from_motion,
    write_joint,
    write_mimic,
)
from .stage import (
    GEOMETRY,
    LOOKS,
    NAMESPACE,
    PHYSICS,
    WORLD_JOINT,
    open_stage,
    relative_transform,
    stage_text,
    stage_units,
    world_transforms,
)

METADATA = f"{NAMESPACE}:metadata"
FLOATING_JOINT = f"{NAMESPACE}:floatingJoint"  # on a free body: its floating joint's name


# -- save ------------------------------------------------------------------------------------
def to_usda(obj: ArticulatedObject) -> str:
    import newton_usd_schemas  # noqa: F401  (registers NewtonJointAPI / NewtonMassAPI)
    from pxr import Sdf, UsdPhysics

    from .stage import new_stage

    stage, root = new_stage(obj.name)
    # Fixed base: "this API can be on a direct or indirect parent of the root joint which is
    # connected to the world, or on the joint itself" (UsdPhysicsArticulationRootAPI docs).
    # The object Xform is an indirect parent of the world joint below.
    UsdPhysics.ArticulationRootAPI.Apply(root)
    root.SetAssetInfoByKey("name", obj.name)
    root.CreateAttribute(METADATA, Sdf.ValueTypeNames.String, custom=True).Set(
        metadata_json(obj, sort_keys=True))

    base = f"/{obj.name}"
    written = ArticulatedObject(obj.name, obj.parts, [as_written(j) for j in obj.joints])
    world = forward_kinematics(written, obj.observed_configuration())
    for part in obj.parts:
        body = f"{base}/{GEOMETRY}/{part.name}"
        write_body(stage, body, part, world[part.name])
        write_part_geometry(stage, part, body, f"{base}/{LOOKS}/{part.name}")

    world_joint = sanitize_name(WORLD_JOINT, {j.name for j in obj.joints})
    root_part = obj.root.name
    write_joint(stage, f"{base}/{PHYSICS}/{world_joint}",
                Joint(world_joint, JointType.FIXED, "", root_part), None,
                f"{base}/{GEOMETRY}/{root_part}")
    for j in obj.joints:
        if j.type is JointType.FLOATING:  # a free body: no joint holds it; its name kept
            stage.GetPrimAtPath(f"{base}/{GEOMETRY}/{j.child}").CreateAttribute(
                FLOATING_JOINT, Sdf.ValueTypeNames.String, custom=True).Set(j.name)
            continue
        write_joint(stage, f"{base}/{PHYSICS}/{j.name}", j, f"{base}/{GEOMETRY}/{j.parent}",
                    f"{base}/{GEOMETRY}/{j.child}")
        if j.mimic is not None:
            write_mimic(stage.GetPrimAtPath(f"{base}/{PHYSICS}/{j.name}"), j.mimic,
                        f"{base}/{PHYSICS}/{j.mimic.joint}", j.type.angular)
    return stage_text(stage)


def save(obj: ArticulatedObject, out_dir: str | Path, *, write_meshes: bool = True) -> Path:
    """Write ``out_dir/<name>.usda`` (self-contained: geometry inline) and, if asked, the
    shared mesh files."""
    validate(obj)
    out_dir = Path(out_dir)
    if write_meshes:
        write_object_meshes(obj, out_dir)
    return atomic.write_text(out_dir / f"{obj.name}.usda", to_usda(obj))


# -- load ------------------------------------------------------------------------------------
def load(path: str | Path) -> ArticulatedObject:
    from pxr import Usd, UsdGeom

    path = Path(path)
    stage = open_stage(path)
    mpu, kpu, up = stage_units(stage)
    art = art_.parse(stage, path, mpu)
    prims = {p: stage.GetPrimAtPath(p) for p in art.bodies}
    scale = np.diag([mpu, mpu, mpu, 1.0])
    world = {p: _rigid(scale @ m @ np.linalg.inv(scale), path, p)
             for p, m in world_transforms(stage, prims.values()).items()}
    world[art_.WORLD] = np.eye(4)

    # to_part[b]: body frame -> part frame (metres). A part's frame is its parent joint's
    # frame (shifted by localPos1); the root part's frame is the world.
    to_part = {art_.WORLD: up.copy()}
    if art.root != art_.WORLD:
        placement = art.root_placement if art.root_placement is not None else world[art.root]
        to_part[art.root] = up @ placement
    for e in art.edges:
        if e.desc is None:  # a free body: its part frame is its body frame
            to_part[e.child] = np.eye(4)
            continue
        child_frame = art_.joint_frame(e.desc, 0 if e.reversed else 1, mpu)
        to_part[e.child] = tf.make(translation=-child_frame[:3, 3])

    names: dict[str, str] = {}
    taken: set[str] = set()
    parts = []
    if art.root == art_.WORLD:
        names[art_.WORLD] = sanitize_name("world", taken)
        parts.append(Part(names[art_.WORLD]))
    cache = UsdGeom.XformCache(Usd.TimeCode.Default())
    for body in art.bodies:
        names[body] = sanitize_name(prims[body].GetName(), taken)
        parts.append(_part(prims[body], names[body], art.shapes.get(body, []), to_part[body],
                           cache, stage, mpu, kpu, path))

    joints, joint_names = [], set()
    for e in art.edges:
        joints.append(_joint(stage, e, names, to_part, world, mpu, kpu, path, joint_names))
    joint_at = {e.path: j.name for e, j in zip(art.edges, joints, strict=True)}
    for j in joints:  # a mimic's leader: from its prim path to its joint's name
        if j.mimic is not None:
            j.mimic.joint = joint_at.get(j.mimic.joint, j.mimic.joint)

    root_prim = stage.GetDefaultPrim() or next(iter(stage.GetPseudoRoot().GetChildren()), None)
    name = sanitize_name(root_prim.GetName() if root_prim else path.stem)
    metadata = {}
    if root_prim and root_prim.HasAttribute(METADATA):
        try:
            metadata = json.loads(root_prim.GetAttribute(METADATA).Get() or "{}")
        except json.JSONDecodeError as e:
            raise FormatError(path, f"prim <{root_prim.GetPath()}>",
                              f"{METADATA} is not JSON: {e}") from e
    obj = ArticulatedObject(name, parts, joints, metadata)
    for joint_name, message in unusable_mimics(obj):
        warn(f"{path}: joint {joint_name!r}: {message}")
    try:
        return validate(obj)
    except ModelError as e:
        raise FormatError(path, e.element, e.message) from e


def _rigid(m: np.ndarray, path, prim_path: str) -> np.ndarray:
    if not tf.is_rotation(m[:3, :3], tol=1e-5):
        raise FormatError(path, f"prim <{prim_path}>", "rigid body transform has scale or "
                          "shear; scaled bodies are not supported")
    return m


def _part(prim, name: str, shape_paths: list[str], to_part: np.ndarray, cache, stage,
          mpu: float, kpu: float, path) -> Part:
    from pxr import UsdGeom, UsdPhysics

    where = f"prim <{prim.GetPath()}>"
    units = np.diag([mpu, mpu, mpu, 1.0])

    def placed(p) -> np.ndarray:
        return to_part @ units @ relative_transform(cache, p, prim)

    collision = []
    for sp in shape_paths:
        shape = stage.GetPrimAtPath(sp)
        if shape.IsA(UsdGeom.Mesh):
            collision.append(read_mesh(shape, placed(shape), path, f"prim <{sp}>"))
        else:
            mesh = shape_mesh(shape, placed(shape))
            if mesh is None:
                warn(f"{path}: collider <{sp}> ({shape.GetTypeName()}) cannot be meshed; ignored")
            else:
                collision.append(mesh)
    shown = (UsdGeom.Tokens.default_, UsdGeom.Tokens.render)
    visual_prims = [p for p in _own_descendants(prim)
                    if p.IsA(UsdGeom.Mesh) and not p.HasAPI(UsdPhysics.CollisionAPI)
                    and UsdGeom.Imageable(p).ComputePurpose() in shown
                    and UsdGeom.Imageable(p).ComputeVisibility() != UsdGeom.Tokens.invisible]
    visuals = [read_mesh(p, placed(p), path, f"prim <{p.GetPath()}>") for p in visual_prims]
    visual = (visuals[0] if len(visuals) == 1 else Mesh.concatenate(visuals)) if visuals else None
    inertial = read_inertial(prim, to_part, collision or visuals, mpu, kpu, f"{path}: {where}")
    return Part(name, visual=visual, collision=collision, inertial=inertial,
                color=read_color(prim, visual_prims, path))


def _own_descendants(prim):
    """Descendants of a body prim, not entering nested rigid bodies (they are parts)."""
    from pxr import UsdPhysics

    for child in prim.GetChildren():
        if child.HasAPI(UsdPhysics.RigidBodyAPI):
            continue
        yield child
        yield from _own_descendants(child)


def _joint(stage, e, names, to_part, world, mpu, kpu, path, taken: set[str]) -> Joint:
    """A model joint from a parsed one: origin = (parent body -> part) T_parent R_child^-1,
    axis = R_child * token (negated for a joint that runs child -> parent), state from the
    bodies' poses."""
    if e.kind is JointType.FLOATING:  # a free body, where it stands in the root part
        named = stage.GetPrimAtPath(e.child).GetAttribute(FLOATING_JOINT)
        raw = named.Get() if named and named.HasAuthoredValue() else None
        return Joint(sanitize_name(raw or f"{names[e.child]}_floating", taken), e.kind,
                     names[e.parent], names[e.child],
                     origin=_rigid(to_part[e.parent] @ tf.inverse(world[e.parent])
                                   @ world[e.child], path, e.child))
    prim = stage.GetPrimAtPath(e.path)
    where = f"{path}: joint prim <{e.path}>"
    kind = e.kind
    t0, t1 = art_.joint_frame(e.desc, 0, mpu), art_.joint_frame(e.desc, 1, mpu)
    parent_frame = t1 if e.reversed else t0
    parent_quat, child_quat = (_quat(e.desc, 1), _quat(e.desc, 0)) if e.reversed \
        else (_quat(e.desc, 0), _quat(e.desc, 1))
    origin = to_part[e.parent] @ rest_origin(parent_frame[:3, 3], parent_quat, child_quat)
    if not kind.movable:
        dynamics = read_dynamics(prim, True, mpu, kpu, where) if kind.multi_dof else None
        return Joint(sanitize_name(prim.GetName(), taken), kind, names[e.parent],
                     names[e.child], origin=origin, dynamics=dynamics or Dynamics())
    token = str(e.desc.axis)
    axis = axis_in_body1(child_quat, token) * (-1.0 if e.reversed else 1.0)
    motion = tf.inverse(world[e.body0] @ t0) @ (world[e.body1] @ t1)
    state = _choose_state(state_from_motion(motion, kind, token, where),
                          authored_value(prim, STATE), kind, where)
    limits = read_limits(e.desc, kind, prim, mpu, kpu, where)
    if limits is not None:
        state = _into_limits(state, limits, kind, where)
    return Joint(sanitize_name(prim.GetName(), taken), kind, names[e.parent], names[e.child],
                 origin=origin, axis=axis, limits=limits, state=state,
                 dynamics=read_dynamics(prim, kind.angular, mpu, kpu, where),
                 mimic=read_mimic(prim, kind.angular, mpu))


def _quat(desc, side: int) -> np.ndarray:
    q = desc.localPose0Orientation if side == 0 else desc.localPose1Orientation
    return np.array([q.GetReal(), *q.GetImaginary()], dtype=float)


def _choose_state(from_poses: float, exact: float | None, kind: JointType, where: str) -> float:
    """The bodies' poses say where the joint is; our float64 copy is used when it agrees."""
    if exact is None:
        return from_poses
    gap = exact - from_poses
    if kind.angular:
        gap = math.remainder(gap, 2.0 * math.pi)
    if abs(gap) <= 1e-6:
        return exact
    warn(f"{where}: {STATE} = {exact} but the bodies stand at {from_poses}; using the bodies")
    return from_poses


def _into_limits(state: float, limits, kind: JointType, where: str) -> float:
    if kind.angular:  # the poses give an angle modulo 2 pi
        k = math.ceil((limits.lower - state) / (2.0 * math.pi) - 1e-9)
        if k > 0 and state + 2.0 * math.pi * k <= limits.upper + 1e-9:
            state += 2.0 * math.pi * k
        k = math.floor((limits.upper - state) / (2.0 * math.pi) + 1e-9)
        if k < 0 and state + 2.0 * math.pi * k >= limits.lower - 1e-9:
            state += 2.0 * math.pi * k
    clamped = min(max(state, limits.lower), limits.upper)
    if abs(clamped - state) > 1e-6:
        warn(f"{where}: state {state} is outside the limits; clamped to {clamped}")
    return clamped
