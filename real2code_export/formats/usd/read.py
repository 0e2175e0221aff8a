"""USD load: UsdPhysics' own parser finds bodies and joints (``articulation``); each body
becomes a part whose frame is its parent joint's frame, each joint a model joint. What one
read carries (the stage, its units, the frames found so far) is a :class:`Context`, as in the
URDF reader."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ... import transforms as tf
from ...collision import thickened
from ...errors import FormatError, ModelError, warn
from ...model import (
    DEFAULT_COLOR,
    WHITE,
    ArticulatedObject,
    Dynamics,
    Inertial,
    Joint,
    JointType,
    Limits,
    Mesh,
    Part,
    sanitize_name,
    validate,
)
from ...repairs import balanced_inertia, massless_moving_parts, unusable_mimics
from . import articulation as art_
from . import d6, drive, loop, mjc_actuator
from .body import collider_mass, read_inertial, read_own_mass
from .conventions import (
    FLOATING_JOINT,
    FRAME_JOINT,
    METADATA,
    PARENT_PART,
    open_stage,
    relative_transform,
    source_name,
    stage_units,
    world_transforms,
)
from .geometry import (
    bound_runs,
    color_runs,
    ellipsoid_collider,
    read_color,
    read_images,
    read_placed_mesh,
    shape_mesh,
)
from .joint import (
    STATE,
    authored_value,
    axis_in_body1,
    read_cone_limit,
    read_dynamics,
    read_free_dynamics,
    read_limits,
    read_mimic,
    rest_origin,
    state_from_motion,
)


@dataclass
class Context:
    """One read: the file (for messages), the stage and its units, and per body path its
    world transform (metres) and the transform from its frame to its part's frame."""

    path: Path
    stage: object  # pxr.Usd.Stage
    mpu: float  # metres per unit
    kpu: float  # kilograms per unit
    up: np.ndarray  # 4x4: the stage's up axis -> Z up
    xforms: object  # pxr.UsdGeom.XformCache
    world: dict[str, np.ndarray] = field(default_factory=dict)
    # a body Xform's scale (its prim's axes): what lies below it is scaled so (as PhysX scales
    # a body's shapes; UsdPhysics' parser scales the joints' localPos); the body is not
    scale: dict[str, np.ndarray] = field(default_factory=dict)
    to_part: dict[str, np.ndarray] = field(default_factory=dict)
    names: dict[str, str] = field(default_factory=dict)  # body path -> part name
    assets: dict[str, Mesh] = field(default_factory=dict)  # mesh assets placed by reference


def load(path: str | Path) -> ArticulatedObject:
    from pxr import Usd, UsdGeom

    path = Path(path)
    stage = open_stage(path)
    mpu, kpu, up = stage_units(stage)
    ctx = Context(path, stage, mpu, kpu, up, UsdGeom.XformCache(Usd.TimeCode.Default()))
    art = art_.parse(stage, path, mpu)
    prims = {p: stage.GetPrimAtPath(p) for p in art.bodies}
    scale = np.diag([mpu, mpu, mpu, 1.0])
    for p, m in world_transforms(stage, prims.values()).items():
        ctx.world[p], ctx.scale[p] = _rigid_and_scale(scale @ m @ np.linalg.inv(scale), path, p)
    ctx.world[art_.WORLD] = np.eye(4)

    # to_part[b]: body frame -> part frame (metres). A part's frame is its parent joint's
    # frame (shifted by localPos1); the root part's frame is the world.
    ctx.to_part[art_.WORLD] = up.copy()
    if art.root != art_.WORLD:
        placement = art.root_placement if art.root_placement is not None else ctx.world[art.root]
        ctx.to_part[art.root] = up @ placement
    for e in art.edges:
        if e.desc is None:  # a free body: its part frame is its body frame
            ctx.to_part[e.child] = np.eye(4)
            continue
        # (stacked joints: the last one's anchor, as the MJCF reader places the body's part)
        child_frame = art_.joint_frame(e.stack[-1] if e.stack else e, 0 if e.reversed else 1,
                                       mpu)
        ctx.to_part[e.child] = tf.make(translation=-child_frame[:3, 3])

    taken: set[str] = set()
    parts = []
    if art.root == art_.WORLD:
        ctx.names[art_.WORLD] = sanitize_name("world", taken)
        parts.append(Part(ctx.names[art_.WORLD]))
    in_frame: dict[str, list[str]] = {}  # our frame's path -> the colliders below it
    still = art_.welded(art)
    for body in art.bodies:
        ctx.names[body] = sanitize_name(source_name(prims[body]), taken)
        shapes = []
        for s in art.shapes.get(body, []):
            frame = _frame_of(ctx, s)
            (shapes if frame is None else in_frame.setdefault(frame, [])).append(s)
        parts.append(_part(ctx, ctx.names[body], prims[body], shapes, ctx.to_part[body],
                           moves=body not in still))

    joint_names: set[str] = set()
    joints, joint_at, chains, drives = [], {}, [], []
    for e in art.edges:
        if e.stack:  # one MJCF body's joints: a chain through massless parts
            made, between = _stacked_joints(ctx, e, joint_names, taken)
            parts += between
            for member, joint in zip([e, *e.stack], made, strict=True):
                joint_at[member.path] = joint.name
                drives.append((member, [joint]))
            joints += made
            continue
        if e.dofs is None:
            made = [_joint(ctx, e, joint_names)]
        else:  # a generic joint (D6): one joint, or a chain through massless parts
            made, between = _generic_joint(ctx, e, joint_names, taken)
            parts += between
            if between:
                chains.append(f"<{e.path}> ({', '.join(d.name for d in e.dofs)})")
        joint_at[e.path] = made[0].name
        joints += made
        if e.desc is not None:
            drives.append((e, made))
    if chains:
        warn(f"{path}: generic joints (D6) of several free axes split into chains of massless "
             f"parts, an axis each: {'; '.join(chains)}")
    frames = [found for body in art.bodies
              for found in _frames(ctx, body, prims[body], taken, joint_names, in_frame)]
    for j in joints:  # a mimic's leader: from its prim path to its joint's name
        if j.mimic is not None:
            j.mimic.joint = joint_at.get(j.mimic.joint, j.mimic.joint)
    parts += [part for part, _ in frames]
    joints += [joint for _, joint in frames]
    _rehang(ctx, joints, joint_at)

    root_prim = stage.GetDefaultPrim() or next(iter(stage.GetPseudoRoot().GetChildren()), None)
    name = sanitize_name(source_name(root_prim) if root_prim else path.stem)
    metadata = {}
    if root_prim and root_prim.HasAttribute(METADATA):
        try:
            metadata = json.loads(root_prim.GetAttribute(METADATA).Get() or "{}")
        except json.JSONDecodeError as e:
            raise FormatError(path, f"prim <{root_prim.GetPath()}>",
                              f"{METADATA} is not JSON: {e}") from e
    if art.loops:
        metadata = _with_loops(ctx, art.loops, metadata)
    metadata = _with_drives(ctx, drives, metadata)
    obj = ArticulatedObject(name, parts, joints, metadata)
    for joint_name, message in massless_moving_parts(obj) + unusable_mimics(obj):
        warn(f"{path}: joint {joint_name!r}: {message}")
    try:
        validate(obj)
    except ModelError as e:
        raise FormatError(path, e.element, e.message) from e
    return mjc_actuator.read_actuators(path, stage, obj, art.actuators, joint_at)


def _rigid_and_scale(m: np.ndarray, path, prim_path: str) -> tuple[np.ndarray, np.ndarray]:
    """A body's world transform as its rigid pose and the scale along its own axes (a
    ``xformOp:scale`` after its rotation); shear or a mirror is refused."""
    scale = np.linalg.norm(m[:3, :3], axis=0)
    rigid = m.copy()
    if np.all(scale > 1e-12):
        rigid[:3, :3] = m[:3, :3] / scale
    if not np.all(scale > 1e-12) or not tf.is_rotation(rigid[:3, :3], tol=1e-5):
        raise FormatError(path, f"prim <{prim_path}>", "rigid body transform has shear or a "
                          "mirror (a scale along its own axes is read; this is not)")
    return rigid, scale


def _scaled(ctx: Context, prim) -> np.ndarray:
    """4x4: the prim's own scale where it is a scaled body (:attr:`Context.scale`)."""
    s = ctx.scale.get(str(prim.GetPath()))
    return np.eye(4) if s is None else np.diag([*s, 1.0])


def _rigid(m: np.ndarray, path, prim_path: str) -> np.ndarray:
    """``m``, a free body's pose in its root part, checked rigid (both poses are, their
    scales taken out by :func:`_rigid_and_scale`: this names the body should one not be)."""
    if not tf.is_rotation(m[:3, :3], tol=1e-5):
        raise FormatError(path, f"prim <{prim_path}>", "the free body's pose in the root "
                          "part is not rigid (it scales or shears)")
    return m


def _part(ctx: Context, name: str, prim, shape_paths: list[str], to_part: np.ndarray,
          moves: bool = False) -> Part:
    """The part ``name`` of a body prim, or of a frame in one (``prim``): its collision shapes,
    visual meshes, mass and colour; ``to_part`` maps the prim's frame (metres) to the part's.
    A body that ``moves`` with no mass authored gets its colliders' (:func:`read_inertial`)."""
    from pxr import UsdGeom, UsdPhysics

    path = ctx.path
    where = f"prim <{prim.GetPath()}>"
    units = np.diag([ctx.mpu, ctx.mpu, ctx.mpu, 1.0])

    body_scale = _scaled(ctx, prim)

    def placed(p) -> np.ndarray:
        return to_part @ units @ body_scale @ relative_transform(ctx.xforms, p, prim)

    collision, own_mass = [], []  # own_mass: each collider's PhysicsMassAPI (mass, density)
    for sp in shape_paths:
        shape = ctx.stage.GetPrimAtPath(sp)
        if shape.IsA(UsdGeom.Mesh):
            mesh = ellipsoid_collider(shape, placed(shape))
            mesh = mesh if mesh is not None else _with_volume(read_placed_mesh(
                shape, placed(shape), path, f"prim <{sp}>", ctx.assets))
        else:
            mesh = shape_mesh(shape, placed(shape))
            if mesh is None:
                warn(f"{path}: collider <{sp}> ({shape.GetTypeName()}) cannot be meshed; ignored")
                continue
        collision.append(mesh)
        own_mass.append(collider_mass(shape, ctx.mpu, ctx.kpu))
    shown = (UsdGeom.Tokens.default_, UsdGeom.Tokens.render)
    visual_prims = [p for p in _own_descendants(prim)
                    if p.IsA(UsdGeom.Gprim) and not p.HasAPI(UsdPhysics.CollisionAPI)
                    and UsdGeom.Imageable(p).ComputePurpose() in shown
                    and UsdGeom.Imageable(p).ComputeVisibility() != UsdGeom.Tokens.invisible]
    visuals, runs, shown_prims = [], [], []  # runs: each visual's colours (color_runs)
    for p in visual_prims:
        where_p = f"prim <{p.GetPath()}>"
        mesh = read_placed_mesh(p, placed(p), path, where_p, ctx.assets) \
            if p.IsA(UsdGeom.Mesh) else shape_mesh(p, placed(p))
        if mesh is None:
            warn(f"{path}: {where_p} ({p.GetTypeName()}): a shape the model has no place for "
                 "(box, sphere, cylinder, capsule and meshes are read); not shown")
            continue
        visuals.append(mesh)
        runs.append(color_runs(p, len(mesh.faces), path))
        shown_prims.append(p)
    visual = None  # (visuals of several colours: kept per face)
    if visuals:
        visual = Mesh.join_colored(visuals, runs) if len(visuals) > 1 or len(runs[0]) > 1 \
            else visuals[0]
    inertial = read_inertial(prim, to_part, collision or visuals, ctx.mpu, ctx.kpu,
                             f"{path}: {where}", colliders=collision if moves else None,
                             scale=ctx.scale.get(str(prim.GetPath())), collider_mass=own_mass)
    stated, own = read_own_mass(prim, ctx.mpu, ctx.kpu)
    if stated:  # a body stating its welded group's mass, or a frame in it (carry_welded_mass)
        inertial = None if own is None else Inertial(
            own.mass, to_part[:3, :3] @ own.com + to_part[:3, 3],
            to_part[:3, :3] @ own.inertia @ to_part[:3, :3].T)
    if inertial is not None:  # as the URDF and MJCF readers repair what simulators accept
        try:
            inertial, change = balanced_inertia(inertial)
        except ValueError as e:
            raise FormatError(path, where, str(e)) from e
        if change is not None:
            warn(f"{path}: {where}: {change}")
    drawn = [_drawn_by(p, mesh, piece_runs, path)
             for p, mesh, piece_runs in zip(shown_prims, visuals, runs, strict=True)]
    found = [images for piece in drawn for _, _, images in piece if images]
    images = found[0] if found else {}
    color = read_color(prim, visual_prims, path)
    one = all(images.keys() == other.keys() and all(
        images[r].image == other[r].image for r in images) for other in found) \
        and all(i for piece in drawn for _, _, i in piece)
    if images and not (one and visual is not None and visual.uv is not None):
        atlas = _one_image(visuals, drawn) \
            if all(set(i) == {"texture"} for i in found) else None
        if atlas is not None:
            warn(f"{path}: {where}: the images and colours of its {len(visuals)} visual "
                 "mesh(es) and their subsets packed into one image (a part holds one)"
                 + (f": {'; '.join(atlas.notes)}" if atlas.notes else ", every pixel kept"))
            visual, images, color = atlas.mesh, {"texture": atlas.texture}, WHITE
        else:
            warn(f"{path}: {where}: textures ({', '.join(images)}) need texture coordinates "
                 "on every visual mesh they draw, and colour images only where a part has "
                 "several; they are not kept, the colour is")
            images = {}
    images = dict(images)
    texture = images.pop("texture", None)
    return Part(name, visual=visual, collision=collision, inertial=inertial,
                color=color, texture=texture, maps=images)


def _drawn_by(p, mesh: Mesh, colours: list, path) -> list[tuple[int, tuple | None, dict]]:
    """What draws each run of a visual prim's faces (:func:`geometry.bound_runs`): face count,
    colour (:func:`geometry.color_runs`) and the bound material's images (by role; the
    material bound to the prim or inherited from its body where a subset binds none)."""
    owners = bound_runs(p, len(mesh.faces))  # (color_runs' runs, one for one)
    return [(n, c, read_images(q, [], path)) for (n, q), (_, c) in zip(owners, colours,
                                                                       strict=True)]


def _one_image(visuals: list[Mesh], drawn: list) -> object | None:
    """A body's visual meshes, each run of faces drawn by its own image or colour, as one
    mesh with one image (:mod:`...texture_atlas`), or None where an image has no texture
    coordinates to place it."""
    from ...texture_atlas import AtlasPiece, faces_of, pack

    pieces = []
    for mesh, runs in zip(visuals, drawn, strict=True):
        start = 0
        for n, colour, images in runs:
            piece = faces_of(mesh, start, start + n)
            start += n
            if images and piece.uv is None:
                return None
            pieces.append(AtlasPiece(piece, images.get("texture"),
                                     WHITE if images else colour or DEFAULT_COLOR))
    return pack(pieces)


def _rehang(ctx: Context, joints: list[Joint], joint_at: dict[str, str]) -> None:
    """A joint our writer wrote from the body holding the frame it hangs from
    (``real2code:parentPart``, ``body.in_parent_body``) hung from that frame again: its
    origin taken into the frame's (the frames' joints are read by now)."""
    by_child = {j.child: j for j in joints}
    by_name = {j.name: j for j in joints}
    for path, name in joint_at.items():
        attr = ctx.stage.GetPrimAtPath(path).GetAttribute(PARENT_PART)
        frame = attr.Get() if attr and attr.HasAuthoredValue() else None
        joint = by_name.get(name)
        if not isinstance(frame, str) or joint is None or frame == joint.parent:
            continue
        pose, at = np.eye(4), frame
        while at in by_child and at != joint.parent:
            pose = by_child[at].origin @ pose
            at = by_child[at].parent
        if at != joint.parent:
            warn(f"{ctx.path}: joint prim <{path}>: its {PARENT_PART} {frame!r} is no frame "
                 f"in part {joint.parent!r}; the joint hangs from that part")
            continue
        joint.parent, joint.origin = frame, tf.inverse(pose) @ joint.origin


def _with_volume(mesh: Mesh) -> Mesh:
    """A collider mesh with no volume (a flat plate, coplanar points) as the hull PhysX
    takes of it has one: thickened as the URDF reader thickens such a piece
    (``collision.thickened``; MuJoCo refuses to hull coplanar points); any other as read."""
    if mesh.primitives or len(mesh.faces) == 0:
        return mesh
    points = mesh.vertices - mesh.vertices.mean(axis=0)
    spans = np.linalg.svd(points, compute_uv=False) if len(points) > 2 else np.zeros(1)
    if len(spans) == 3 and spans[2] > 1e-9 * max(float(spans[0]), 1e-300):
        return mesh  # (thin is not flat: a panel's hull has a volume; kept as written)
    return thickened(mesh)


def _frames(ctx: Context, body: str, prim, taken: set[str], joint_names: set[str],
            in_frame: dict[str, list[str]], inside: tuple[str, np.ndarray] | None = None):
    """The frames in a body, each a part fixed to the body's part (joint named by
    ``real2code:fixedJoint``, else ``<body>_to_<frame>``): Xforms with nothing to draw below
    them, and ours (``real2code:fixedJoint``) with the geometry below them (a massless part
    the writer put in its parent's body; ``in_frame``: its colliders by frame path) and the
    frames below that, fixed to it (``inside``: the frame's part and its prim -> part map,
    the identity: the writer placed it at the part's frame)."""
    from pxr import UsdGeom

    scale = np.diag([ctx.mpu, ctx.mpu, ctx.mpu, 1.0])
    parent, to_parent = inside if inside is not None else (ctx.names[body], ctx.to_part[body])
    for p in _own_descendants(prim):
        ours = p.HasAttribute(FRAME_JOINT)
        if p.GetTypeName() != "Xform" or not ours and any(
                d.IsA(UsdGeom.Gprim) for d in _own_descendants(p)):
            continue
        where = f"prim <{p.GetPath()}>"
        local = _scaled(ctx, prim) @ relative_transform(ctx.xforms, p, prim)
        if not tf.is_rotation(local[:3, :3], tol=1e-5):
            warn(f"{ctx.path}: {where}: an empty Xform with scale or shear is no frame; ignored")
            continue
        name = sanitize_name(source_name(p), taken)
        origin = to_parent @ scale @ local @ np.linalg.inv(scale)
        kept = p.GetAttribute(FRAME_JOINT).Get() if p.HasAttribute(FRAME_JOINT) else None
        joint = sanitize_name(kept if isinstance(kept, str) and kept else
                              f"{parent}_to_{name}", joint_names)
        part = _part(ctx, name, p, in_frame.get(str(p.GetPath()), []), np.eye(4)) if ours \
            else Part(name, color=read_color(p, [], ctx.path))
        yield part, Joint(joint, JointType.FIXED, parent, name, origin=origin)
        if ours:
            yield from _frames(ctx, body, p, taken, joint_names, in_frame, (name, np.eye(4)))


def _own_descendants(prim):
    """Descendants of a body prim, not entering nested rigid bodies (they are parts) nor
    our frames (their geometry is theirs)."""
    from pxr import Usd, UsdPhysics

    for child in prim.GetFilteredChildren(Usd.TraverseInstanceProxies()):  # instanced too
        if child.HasAPI(UsdPhysics.RigidBodyAPI):
            continue
        yield child
        if not child.HasAttribute(FRAME_JOINT):
            yield from _own_descendants(child)


def _frame_of(ctx: Context, shape_path: str) -> str | None:
    """The path of our frame a collider lies in (None: it is its body's own)."""
    from pxr import UsdPhysics

    prim = ctx.stage.GetPrimAtPath(shape_path).GetParent()
    while prim and not prim.IsPseudoRoot() and not prim.HasAPI(UsdPhysics.RigidBodyAPI):
        if prim.HasAttribute(FRAME_JOINT):
            return str(prim.GetPath())
        prim = prim.GetParent()
    return None


def _joint(ctx: Context, e: art_.Edge, taken: set[str]) -> Joint:
    """A model joint from a parsed one: origin = (parent body -> part) T_parent R_child^-1,
    axis = R_child * token (negated for a joint that runs child -> parent), state from the
    bodies' poses. ``taken``: the joint names given so far."""
    mpu, kpu, names, world = ctx.mpu, ctx.kpu, ctx.names, ctx.world
    if e.kind is JointType.FLOATING:  # a free body, where it stands in the root part
        named = ctx.stage.GetPrimAtPath(e.child).GetAttribute(FLOATING_JOINT)
        raw = named.Get() if named and named.HasAuthoredValue() else None
        return Joint(sanitize_name(raw or f"{names[e.child]}_floating", taken), e.kind,
                     names[e.parent], names[e.child],
                     dynamics=read_free_dynamics(ctx.stage.GetPrimAtPath(e.child)),
                     origin=_rigid(ctx.to_part[e.parent] @ tf.inverse(world[e.parent])
                                   @ world[e.child], ctx.path, e.child))
    prim = ctx.stage.GetPrimAtPath(e.path)
    where = f"{ctx.path}: joint prim <{e.path}>"
    kind = e.kind
    t0, t1 = art_.joint_frame(e, 0, mpu), art_.joint_frame(e, 1, mpu)
    parent_frame = t1 if e.reversed else t0
    parent_quat, child_quat = (art_.joint_quat(e, 1), art_.joint_quat(e, 0)) if e.reversed \
        else (art_.joint_quat(e, 0), art_.joint_quat(e, 1))
    origin = ctx.to_part[e.parent] @ rest_origin(parent_frame[:3, 3], parent_quat, child_quat)
    if not kind.movable:
        dynamics = read_dynamics(prim, True, mpu, kpu, where) if kind.multi_dof else None
        return Joint(sanitize_name(source_name(prim), taken), kind, names[e.parent],
                     names[e.child], origin=origin, dynamics=dynamics or Dynamics(),
                     cone_limit=read_cone_limit(e.desc, where) if kind is JointType.BALL
                     else None)
    token = str(e.desc.axis)
    axis = axis_in_body1(child_quat, token) * (-1.0 if e.reversed else 1.0)
    motion = tf.inverse(world[e.body0] @ t0) @ (world[e.body1] @ t1)
    state = _choose_state(state_from_motion(motion, kind, token, where),
                          authored_value(prim, STATE), kind, where)
    limits, drive_limits = read_limits(e.desc, kind, prim, mpu, kpu, where)
    name = sanitize_name(source_name(prim), taken)
    if limits is not None and limits.lower == limits.upper:
        # PhysX and Newton hold such a joint at that value (MuJoCo refuses the empty range;
        # urdf-usd-converter writes a URDF <limit> of 0 and 0 so)
        value = limits.lower
        warn(f"{where}: physics:lowerLimit == upperLimit ({e.desc.limit.lower:g}): PhysX "
             f"and Newton hold the joint there; read as a fixed joint at q = {value:g}")
        held = Joint(name, kind, names[e.parent], names[e.child], origin=origin, axis=axis)
        return Joint(name, JointType.FIXED, names[e.parent], names[e.child],
                     origin=held.transform(value))
    if limits is not None:
        state = _into_limits(state, limits, kind, where)
    return Joint(name, kind, names[e.parent], names[e.child],
                 origin=origin, axis=axis, limits=limits, state=state,
                 drive_limits=drive_limits,
                 dynamics=read_dynamics(prim, kind.angular, mpu, kpu, where),
                 mimic=read_mimic(prim, kind.angular, mpu))


def _stacked_joints(ctx: Context, e: art_.Edge, taken: set[str],
                    taken_parts: set[str]) -> tuple[list[Joint], list[Part]]:
    """The joints stacked between two bodies (``e`` and :attr:`~.articulation.Edge.stack`:
    one MJCF body's joints) as the MJCF reader makes a body of several joints: a chain
    through massless parts ``<body>_<joint>``, each joint about its anchor in the frame the
    ones before it moved (the first placed as any joint, each next one from the previous
    anchor to its own, in the child body's axes); the child's part frame is at the last
    anchor. The states are each joint's own; the bodies' poses are checked against them."""
    members = [e, *e.stack]
    parent, child = ctx.names[e.parent], ctx.names[e.child]
    joints, between, previous = [], [], None
    for k, member in enumerate(members):
        joint = _joint(ctx, member, taken)
        anchor = art_.joint_frame(member, 1, ctx.mpu)[:3, 3]
        last = k == len(members) - 1
        link = child if last else sanitize_name(f"{child}_{joint.name}", taken_parts)
        if previous is not None:
            joint.origin = tf.make(translation=anchor - previous)
        joint.parent, joint.child = parent, link
        joints.append(joint)
        if not last:
            between.append(Part(link))
        parent, previous = link, anchor
    placed = np.eye(4)
    for joint in joints:
        placed = placed @ joint.transform(joint.state)
    written = ctx.to_part[e.parent] @ tf.inverse(ctx.world[e.parent]) @ ctx.world[e.child] \
        @ tf.inverse(ctx.to_part[e.child])
    off = float(np.abs(placed - written).max())
    if off > 1e-5:
        warn(f"{ctx.path}: joint prims {', '.join(f'<{m.path}>' for m in members)}: the "
             f"bodies' written poses differ from the joints' states by {off:.3g}")
    return joints, between


def _generic_joint(ctx: Context, e: art_.Edge, taken: set[str],
                   taken_parts: set[str]) -> tuple[list[Joint], list[Part]]:
    """The model's joints of a generic joint (D6, :mod:`.d6`) and the massless parts between
    them: origin and axes as for a revolute joint (:func:`_joint`), each free axis's value
    from the bodies' poses. A joint that runs child -> parent is the chain reversed, its axes
    negated."""
    prim = ctx.stage.GetPrimAtPath(e.path)
    where = f"{ctx.path}: joint prim <{e.path}>"
    mpu, kpu = ctx.mpu, ctx.kpu
    t0, t1 = art_.joint_frame(e, 0, mpu), art_.joint_frame(e, 1, mpu)
    parent_frame = t1 if e.reversed else t0
    parent_quat, child_quat = (art_.joint_quat(e, 1), art_.joint_quat(e, 0)) if e.reversed \
        else (art_.joint_quat(e, 0), art_.joint_quat(e, 1))
    origin = ctx.to_part[e.parent] @ rest_origin(parent_frame[:3, 3], parent_quat, child_quat)
    parent, child, name = ctx.names[e.parent], ctx.names[e.child], source_name(prim)
    if not e.dofs or d6.is_ball(e.dofs):
        kind = JointType.BALL if e.dofs else JointType.FIXED
        dynamics = read_dynamics(prim, True, mpu, kpu, where) if e.dofs else Dynamics()
        return [Joint(sanitize_name(name, taken), kind, parent, child, origin=origin,
                      dynamics=dynamics, cone_limit=0.0 if d6.is_held_ball(e.dofs) else None)], []
    moved = tf.inverse(ctx.world[e.body0] @ t0) @ (ctx.world[e.body1] @ t1)
    values, off = d6.values_of(e.dofs, moved)
    if off > 1e-5:
        warn(f"{where}: the bodies violate the joint by {off:.3g} at their written poses")
    order = list(zip(e.dofs, values, strict=True))[::-1 if e.reversed else 1]
    chain = len(order) > 1
    names = [sanitize_name(f"{name}_{dof.name}" if chain else name, taken) for dof, _ in order]
    ends = [parent, *(sanitize_name(f"{child}_{n}", taken_parts) for n in names[:-1]), child]
    joints = []
    for k, ((dof, q), joint_name) in enumerate(zip(order, names, strict=True)):
        q = _choose_state(q, authored_value(prim, f"{STATE}:{dof.name}"), dof.kind, where)
        limits = None
        if dof.lower is not None:
            scale = math.pi / 180.0 if dof.angular else mpu
            limits = Limits(dof.lower * scale, dof.upper * scale)
            q = _into_limits(q, limits, dof.kind, where)
        joints.append(Joint(
            joint_name, dof.kind, ends[k], ends[k + 1], origin=origin if k == 0 else np.eye(4),
            axis=axis_in_body1(child_quat, dof.token) * (-1.0 if e.reversed else 1.0),
            limits=limits, state=q, dynamics=read_dynamics(prim, dof.angular, mpu, kpu, where)))
    return joints, [Part(n) for n in ends[1:-1]]


def _with_drives(ctx: Context, made: list, metadata: dict) -> dict:
    """The joints' drives (:mod:`.drive`; ``made``: each parsed joint and the model joints
    made of it): each a model joint's :class:`Drive` where it is one of the model's laws,
    else kept in ``metadata`` (returned, warned); a drive our writer wrote back from the
    metadata replaces its own entry."""
    found, idle, converted, refused = [], [], [], []
    for e, joints in made:
        prim = ctx.stage.GetPrimAtPath(e.path)
        if e.dofs is None:
            j = joints[0]
            kind = "angular" if j.type.angular else "linear"
            axes = {kind: (j.name, kind)} if j.type.movable else {}
        elif d6.is_ball(e.dofs) or not e.dofs:
            axes = {}
        else:
            dofs = e.dofs[::-1] if e.reversed else e.dofs
            axes = {d.name: (j.name, "angular" if d.angular else "linear")
                    for d, j in zip(dofs, joints, strict=True)}
        entries, unused = drive.read_drives(prim, axes, ctx.mpu, ctx.kpu)
        by_name = {j.name: j for j in joints}
        ours = {name: drive.read_ours(prim, instance) for instance, (name, _) in axes.items()}
        for entry in entries:
            model, why = drive.drive_from_usd(entry["attributes"],
                                              entry["instance"] == "angular",
                                              ours.get(entry["joint"]))
            if model is None:
                found.append(entry)
                refused.append(f"{entry['joint']} ({why})")
            else:
                by_name[entry["joint"]].drive = model
                converted.append(entry["joint"])
        idle += [f"<{e.path}> {instance}" for instance in unused]
    if not found and not idle and not converted:
        return metadata
    if found:
        warn(f"{ctx.path}: drives (PhysicsDriveAPI) the model's drives cannot be: "
             f"{', '.join(refused)}; kept in the metadata {drive.DRIVES_KEY!r} and written "
             "back to USD (the other formats carry them as metadata only)")
    if idle:
        warn(f"{ctx.path}: drives on no free axis (a locked one, a fixed or ball joint) "
             f"ignored: {', '.join(idle)}")
    earlier = {(k.get("joint"), k.get("instance")): k
               for k in metadata.get(drive.DRIVES_KEY, []) if isinstance(k, dict)}
    # our float64 copy where the file's float32 values agree with it (as for the joints)
    found = [earlier[(f["joint"], f["instance"])] if drive.same(
        f, earlier.get((f["joint"], f["instance"]))) else f for f in found]
    ours_kept = {(f["joint"], f["instance"]) for f in found}
    kept = [k for k in metadata.get(drive.DRIVES_KEY, [])
            if not isinstance(k, dict) or ((k.get("joint"), k.get("instance")) not in ours_kept
                                           and k.get("joint") not in converted)]
    out = {k: v for k, v in metadata.items() if k != drive.DRIVES_KEY}
    return {**out, drive.DRIVES_KEY: kept + found} if kept + found else out


def _with_loops(ctx: Context, loops: list, metadata: dict) -> dict:
    """``metadata`` with the joints that close kinematic loops (a four-bar's last joint; the
    model is a tree): each kept as it is under ``loop.LOOPS_KEY`` (:mod:`.loop`), which the
    USD writer writes back, and carried to MuJoCo as an equality ``connect`` of the two
    parts at its anchor (MuJoCo's way to close a loop: the two bodies held together at that
    point, free to turn there; a hinge's axis is not held) in the kept MJCF elements the
    MJCF writer writes back. Warned: URDF and glTF do not act on them. A loop our writer
    wrote back replaces its own entry."""
    from lxml import etree

    from .. import FORMATS

    kept_key = FORMATS["mjcf"].kept_elements  # (the registry's: no format imports another)

    found = {}
    for e in loops:
        name = sanitize_name(source_name(ctx.stage.GetPrimAtPath(e.path)))
        frames = [ctx.to_part[body] @ art_.joint_frame(e, side, ctx.mpu)
                  for side, body in ((0, e.body0), (1, e.body1))]
        found[name] = loop.described(name, e, frames, [ctx.names[e.body0], ctx.names[e.body1]],
                                     ctx.stage.GetPrimAtPath(e.path), ctx.mpu, ctx.kpu)
        warn(f"{ctx.path}: joint prim <{e.path}> ({e.kind.value}) closes a kinematic loop: "
             f"not a joint of the model (a tree); kept in the metadata {loop.LOOPS_KEY!r} and "
             f"written to MJCF as an equality connect of {ctx.names[e.body0]!r} and "
             f"{ctx.names[e.body1]!r} at its anchor (URDF and glTF do not act on it)")
    earlier = {k.get("name"): k for k in metadata.get(loop.LOOPS_KEY, [])
               if isinstance(k, dict)}
    # our float64 copy where the file's float32 frames agree with it (as for the joints)
    found = {name: earlier[name] if loop.same(entry, earlier.get(name)) else entry
             for name, entry in found.items()}
    kept = [k for k in metadata.get(loop.LOOPS_KEY, [])
            if not isinstance(k, dict) or k.get("name") not in found]
    sections = dict(metadata.get(kept_key, {}))
    try:
        equality = etree.fromstring(sections["equality"]) if "equality" in sections \
            else etree.Element("equality")
    except (etree.XMLSyntaxError, TypeError, ValueError) as err:
        raise FormatError(ctx.path, f"{METADATA} {kept_key!r}", f"its equality section is "
                          f"not XML: {err}") from err
    for el in list(equality):
        if el.tag == "connect" and el.get("name") in found:
            equality.remove(el)
    for name, entry in found.items():
        connect = etree.SubElement(equality, "connect")
        connect.set("name", name)
        connect.set("body1", entry["body0"])
        connect.set("body2", entry["body1"])
        connect.set("anchor", " ".join(repr(float(v)) for v in entry["frame0"]["translation"]))
    etree.indent(equality, space="  ")
    sections["equality"] = etree.tostring(equality, encoding="unicode")
    return {**metadata, loop.LOOPS_KEY: kept + list(found.values()), kept_key: sections}


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
