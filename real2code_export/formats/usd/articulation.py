"""Reading the articulation: UsdPhysics' own parser (UsdPhysicsLoadStageFromPrimRange, the
non-deprecated name of LoadUsdPhysicsFromRange in usd-core 26.11) lists the rigid bodies,
joints and collision shapes; this module checks them and orients the joints into a tree
from the part fixed to the world. No prim names or paths are assumed.

The world: one fixed joint to the world -> its body is the root when the joint holds it at
the world's frame; held elsewhere (an MJCF root body's pos and quat, as mujoco-usd-converter
writes them), the body keeps its own frame, held by that joint to a massless part "world",
the root, as the MJCF reader reads such a body (its frame was moved to the world's); no
joint to the world -> the bodies are free, as PhysX and Newton simulate them: a massless
part "world" is the root and the first body floats from it (a floating base: an ant), or
each group the joints connect does (a scene of free bodies: a palletizer's crates), warned;
a kinematic first body (``physics:kinematicEnabled``) is the root, fixed where it stands
(warned); several joints to the world, or a moving one -> a massless part "world" becomes
the root (warned). A body no joint connects to the root is free (UsdPhysics' free body): a
floating joint from the root part holds it. A joint between two bodies the walk from the
root has reached already closes a kinematic loop: kept aside (``Articulation.loops``; the
file's ``physics:excludeFromArticulation`` joints are walked last, so they are the ones). A
generic joint (D6) carries its free degrees of freedom (:mod:`.d6`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ... import transforms as tf
from ...errors import FormatError, warn
from ...model import JointType
from . import d6, mjc_actuator
from .conventions import load_physics

WORLD = ""  # the parser's body path for the world side of a joint
KINDS = {"RevoluteJoint": None, "PrismaticJoint": JointType.PRISMATIC,
         "FixedJoint": JointType.FIXED, "SphericalJoint": JointType.BALL}


@dataclass
class Edge:
    """One parsed joint, oriented parent -> child once the tree is known."""

    path: str
    desc: object  # None for a free body's floating joint (no prim)
    kind: JointType
    body0: str
    body1: str
    reversed: bool = False  # True when body1 is the parent in the tree
    dofs: list | None = None  # a generic joint's (D6) free degrees of freedom (d6.Dof)
    # A side whose prim is no rigid body (a static collider, an Xform: UsdPhysics holds the
    # joint to the world there): that prim's world transform (translation in metres).
    static: dict[int, np.ndarray] = field(default_factory=dict)
    # Hinges and slides stacked after this one between the same two bodies, in stage order:
    # one MJCF body's joints as mujoco-usd-converter writes them (:func:`_stacked`)
    stack: list[Edge] = field(default_factory=list)

    @property
    def parent(self) -> str:
        return self.body1 if self.reversed else self.body0

    @property
    def child(self) -> str:
        return self.body0 if self.reversed else self.body1


@dataclass
class Articulation:
    bodies: list[str]  # rigid body prim paths, in stage order
    shapes: dict[str, list[str]]  # body path -> collision shape prim paths, in stage order
    edges: list[Edge]  # tree joints, in stage order, oriented
    root: str  # a body path, or WORLD for a virtual world part
    root_placement: np.ndarray | None  # pose of the root body in the world, from its joint
    loops: list[Edge] = field(default_factory=list)  # joints closing kinematic loops
    actuators: list = field(default_factory=list)  # MjcActuator prims (.mjc_actuator)


def parse(stage, path, mpu: float) -> Articulation:
    """The checked articulation; positions in metres (``mpu``: metres per stage unit)."""
    from pxr import Tf, Usd

    try:
        parsed = load_physics(stage)
    except Tf.ErrorException as e:
        raise FormatError(path, None, f"UsdPhysics cannot parse the stage: {e}") from e
    # (instance proxies too: UsdPhysics parses the colliders of instanceable prims)
    prims = list(Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies()))
    order = {str(p.GetPath()): i for i, p in enumerate(prims)}
    # A prim typed by no schema (a misspelt or retired type: "DistancePhysicsJoint") is
    # skipped by UsdPhysics' parser, and so by PhysX and Newton: said, not passed over.
    unknown = [f"<{p.GetPath()}> ({p.GetTypeName()})" for p in prims
               if p.GetTypeName() and p.GetPrimTypeInfo().GetSchemaType().isUnknown
               and p.GetTypeName() != mjc_actuator.TYPE_NAME]  # (read by .mjc_actuator)
    if unknown:
        warn(f"{path}: prims of a type no schema defines, which UsdPhysics' parser skips: "
             f"{', '.join(unknown)}; not read")
    bodies, shapes, edges, kinematic = [], {}, [], set()
    for kind, (paths, descs) in parsed.items():
        name = kind.name
        for p, d in zip(paths, descs, strict=True):
            p = str(p)
            if name == "RigidBody":
                bodies.append(p)
                if d.kinematicBody:
                    kinematic.add(p)
            elif name.endswith("Shape"):
                body = str(d.rigidBody)
                if body:
                    shapes.setdefault(body, []).append(p)
                else:
                    warn(f"{path}: collider <{p}> belongs to no rigid body (static); ignored")
            elif name.endswith("Joint"):
                edges.append(_edge(stage, path, p, d, name))
    if not bodies:
        raise FormatError(path, None, "no rigid bodies (PhysicsRigidBodyAPI) found")
    for e in edges:
        _static_sides(stage, path, e, set(bodies), mpu)
    bodies.sort(key=order.__getitem__)
    for body_shapes in shapes.values():
        body_shapes.sort(key=order.__getitem__)
    edges = _stacked(path, sorted(edges, key=lambda e: order[e.path]))
    art = _tree(path, bodies, edges, mpu, kinematic)
    for e in art.edges:  # a stack walked child -> parent: its order is not MuJoCo's
        if e.stack and e.reversed:
            warn(f"{path}: joint prims {', '.join(f'<{x.path}>' for x in e.stack)} stacked "
                 f"on <{e.path}> run from the tree's child to its parent: not read as one "
                 "body's joints")
            art.loops += e.stack
            e.stack = []
    art.edges.sort(key=lambda e: order[e.path])
    art.shapes = shapes
    art.actuators = [p for p in prims if p.GetTypeName() == mjc_actuator.TYPE_NAME]
    return art


def welded(art: Articulation) -> set[str]:
    """The bodies that cannot move: the root and what fixed joints hold to it (or to the
    world)."""
    out, fixed = {art.root}, [e for e in art.edges if e.kind is JointType.FIXED]
    while True:
        more = {e.child for e in fixed if e.parent in out} - out
        if not more:
            return out
        out |= more


def _stacked(path, edges: list[Edge]) -> list[Edge]:
    """``edges`` (in stage order) with the hinges and slides between the same two rigid
    bodies (body0 the same, body1 the same) gathered on the first (:attr:`Edge.stack`):
    mujoco-usd-converter writes an MJCF body's joints so, each about its own anchor, and
    MuJoCo applies them in order (Newton's importer merges them into one joint as well).
    They were read as one joint and loop closers (degrees of freedom lost); so were those
    from the world to a body (an MJCF body of several joints in the worldbody, through the
    converter) until session 32."""
    movable = (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC)
    groups: dict[tuple[str, str], list[Edge]] = {}
    for e in edges:
        if e.dofs is None and e.kind in movable and not e.desc.excludeFromArticulation:
            groups.setdefault((e.body0, e.body1), []).append(e)
    out = []
    for e in edges:
        group = groups.get((e.body0, e.body1), [])
        if len(group) > 1 and e in group:
            if e is not group[0]:
                continue
            e.stack = group[1:]
            warn(f"{path}: joint prims {', '.join(f'<{x.path}>' for x in group)} join the same "
                 "two bodies: read as one body's joints in that order (MJCF's, as "
                 "mujoco-usd-converter writes them), a chain of massless parts between them")
        out.append(e)
    return out


def _edge(stage, path, prim_path: str, desc, kind_name: str) -> Edge:
    element = f"joint prim <{prim_path}>"
    if kind_name not in KINDS and kind_name != "D6Joint":
        raise FormatError(path, element, f"{kind_name} cannot be represented (only revolute, "
                          "prismatic, spherical, fixed and generic (D6) joints)")
    sides = []
    for k, body, rel in ((0, desc.body0, desc.rel0), (1, desc.body1, desc.rel1)):
        body, rel = str(body), str(rel)
        if not body and rel and not stage.GetPrimAtPath(rel).IsValid():
            raise FormatError(path, element, f"body{k} <{rel}> does not exist")
        sides.append(body)
    if sides == [WORLD, WORLD]:
        raise FormatError(path, element, "neither body0 nor body1 is a rigid body")
    if not desc.jointEnabled:
        warn(f"{path}: {element}: joint is disabled (physics:jointEnabled = 0); kept")
    if kind_name == "D6Joint":
        dofs = d6.free_dofs(desc, path, element)
        return Edge(prim_path, desc, d6.kind(dofs), sides[0], sides[1], dofs=dofs)
    kind = KINDS[kind_name]
    if kind is None:  # revolute: continuous when its limit is off or infinite
        lim = desc.limit
        limited = lim.enabled and np.isfinite(lim.lower) and np.isfinite(lim.upper)
        kind = JointType.REVOLUTE if limited else JointType.CONTINUOUS
    return Edge(prim_path, desc, kind, sides[0], sides[1])


def _static_sides(stage, path, e: Edge, bodies: set[str], mpu: float) -> None:
    """A side whose body is a prim without PhysicsRigidBodyAPI (UsdPhysics' parser names it;
    the schema holds such a joint to the static world, at that prim's frame): the world
    side, with the prim's world transform kept for its frame (:func:`joint_frame`)."""
    from pxr import Usd, UsdGeom

    for side in (0, 1):
        body = e.body0 if side == 0 else e.body1
        if body == WORLD or body in bodies:
            continue
        prim = stage.GetPrimAtPath(body)
        m = np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(
            Usd.TimeCode.Default()), dtype=float).T if prim.IsA(UsdGeom.Xformable) \
            else np.eye(4)
        m[:3, 3] *= mpu
        e.static[side] = m
        if side == 0:
            e.body0 = WORLD
        else:
            e.body1 = WORLD
        warn(f"{path}: joint prim <{e.path}>: body{side} <{body}> is no rigid body (a static "
             "prim): the joint holds to the world at that prim's frame, as UsdPhysics has it")
    if e.body0 == WORLD and e.body1 == WORLD:
        raise FormatError(path, f"joint prim <{e.path}>",
                          "neither body0 nor body1 is a rigid body")


def joint_frame(e: Edge, side: int, mpu: float) -> np.ndarray:
    """The parsed joint frame in body0 (side 0) or body1 (side 1), positions in metres; a
    static side's (:func:`_static_sides`) in the world, through the prim's rotation and
    translation (UsdPhysics' parser has scaled the local position by the prim's scale)."""
    from .conventions import pose

    desc = e.desc
    local = pose(desc.localPose0Position, desc.localPose0Orientation, mpu) if side == 0 \
        else pose(desc.localPose1Position, desc.localPose1Orientation, mpu)
    static = e.static.get(side)
    if static is None:
        return local
    rotation = tf.orthonormalize(static[:3, :3])
    return tf.make(rotation @ local[:3, :3], rotation @ local[:3, 3] + static[:3, 3])


def joint_quat(e: Edge, side: int) -> np.ndarray:
    """The joint frame's rotation in body0 (side 0) or body1 (side 1), as a (w, x, y, z)
    quaternion; a static side's in the world (:func:`joint_frame`)."""
    q = e.desc.localPose0Orientation if side == 0 else e.desc.localPose1Orientation
    quat = np.array([q.GetReal(), *q.GetImaginary()], dtype=float)
    static = e.static.get(side)
    if static is None:
        return quat
    return tf.matrix_to_quat(tf.orthonormalize(static[:3, :3]) @ tf.quat_to_matrix(quat))


def _tree(path, bodies: list[str], edges: list[Edge], mpu: float,
          kinematic: set[str]) -> Articulation:
    world_edges = [e for e in edges if WORLD in (e.body0, e.body1)]
    root_placement = None
    floats = None  # the first body that floats from the world part, where one is chosen
    placed = None  # the one joint to the world, fixed: where it holds its body
    if len(world_edges) == 1 and world_edges[0].kind is JointType.FIXED:
        e = world_edges[0]
        world_side, body_side = (0, 1) if e.body1 else (1, 0)
        placed = joint_frame(e, world_side, mpu) @ tf.inverse(joint_frame(e, body_side, mpu))
    if placed is not None and np.allclose(placed, np.eye(4), rtol=0.0, atol=1e-9):
        # at the world's frame: the body is the root part, whose frame is the world's
        edges = [x for x in edges if x is not e]
        root = e.body1 or e.body0
        root_placement = placed
    elif placed is not None:
        # elsewhere (an MJCF root body's pos and quat, as mujoco-usd-converter writes them):
        # the body keeps its own frame, held by that joint to a massless part 'world', as
        # the MJCF reader reads such a body
        root = WORLD
    elif world_edges:
        warn(f"{path}: {len(world_edges)} joint(s) to the world "
             f"({', '.join(e.path for e in world_edges)}): a massless part 'world' is the root")
        root = WORLD
    elif len(groups := _groups(bodies, edges)) > 1:
        # A scene: bodies no joint holds to the world or to each other are free (UsdPhysics'
        # free bodies), none more than another; each group's first body floats from a
        # massless world part.
        warn(f"{path}: no joint fixes a body to the world and the {len(bodies)} bodies form "
             f"{len(groups)} groups no joint connects: each is free (a floating joint from a "
             "massless part 'world')")
        root = WORLD
    elif bodies[0] in kinematic:  # moved by the user, not by the simulation
        root = bodies[0]
        warn(f"{path}: no joint fixes the object to the world; its first body <{root}> is "
             "kinematic (physics:kinematicEnabled): taken as fixed where it stands")
    else:
        # One group no joint holds: PhysX and Newton simulate it free (a floating base: an
        # ant, a humanoid, a prop), so it is free here, from its first body.
        root, floats = WORLD, bodies[0]
        warn(f"{path}: no joint fixes the object to the world: it is free, as UsdPhysics' "
             f"simulators take it (its first body <{floats}> floats from a massless part "
             "'world')")
    # Breadth first from the root: orient every joint parent -> child. A joint between two
    # bodies already reached closes a kinematic loop: it is kept aside (``loops``). Joints
    # the file excludes from the articulation (physics:excludeFromArticulation, the author's
    # loop closers) are walked after every other, so that they are the ones kept aside.
    reached, order, tree, loops = {root}, [root], [], []
    pending = list(edges)

    def walk(frontier: list[str], excluded_too: bool) -> None:
        while frontier:
            body = frontier.pop(0)
            for e in [x for x in pending if body in (x.body0, x.body1)
                      and (excluded_too or not x.desc.excludeFromArticulation)]:
                pending.remove(e)
                e.reversed = e.body1 == body
                if e.child in reached:
                    loops.append(e)
                    continue
                reached.add(e.child)
                order.append(e.child)
                frontier.append(e.child)
                tree.append(e)

    start = [root]
    while True:
        walk(start, False)
        walk(list(order), True)
        # A body no joint reaches is free; of its group, the one that is no joint's body1.
        unreached = [b for b in bodies if b not in reached]
        if not unreached:
            break
        held = {e.body1 for e in pending}
        free = floats if floats in unreached else \
            next((b for b in unreached if b not in held), unreached[0])
        tree.append(Edge(free, None, JointType.FLOATING, root, free))
        reached.add(free)
        order.append(free)
        start = [free]
    return Articulation(bodies, {}, tree, root, root_placement, loops)


def _groups(bodies: list[str], edges: list[Edge]) -> list[set[str]]:
    """The bodies in groups the joints connect (none of them to the world)."""
    group = {b: {b} for b in bodies}
    for e in edges:
        a, b = group[e.body0], group[e.body1]
        if a is not b:
            a |= b
            for body in b:
                group[body] = a
    return list({id(g): g for g in group.values()}.values())
