"""A USD file as UsdPhysics sees it: its parser (UsdPhysicsLoadStageFromPrimRange, the
non-deprecated LoadUsdPhysicsFromRange) lists the joints (body0, body1, localPose0/1, axis
token, limits); the probe walks them from the world and poses every body.

Independent of our USD reader on purpose: only the parsed joints are used, never our
custom attributes or the body poses written in the file (except for a body with no joint
path to the world, which stands where the file puts it).

A body's reported pose is its frame moved to its parent joint's frame origin (localPos on
the body's side; zero in files we write), the model's "part frame = joint frame". An Xform in
a body with nothing to draw below it is a frame, reported by its prim name; so is one naming
its fixed joint (``real2code:fixedJoint``), where our writer puts a massless part's geometry
in its parent's body. Bodies, joints and frames are named as their prims, decoded as the
source named them where usd-exchange encoded the name (``conventions.source_name``) and made
identifiers, as every reader names them. Hinges and slides stacked between the same two
bodies are one MJCF body's joints, applied in stage order (:func:`_stacks`). A hinge or
slide whose limits are equal is held there, as PhysX and Newton hold it: no joint.
"""

from __future__ import annotations

import collections
import contextlib
import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import transforms as tf
from ..errors import CheckError
from ..formats.usd.conventions import FRAME_JOINT, load_physics, source_name
from ..model import sanitize_name
from . import JointInfo, joint_motions

WORLD = ""
AXES = {"X": np.array([1.0, 0.0, 0.0]), "Y": np.array([0.0, 1.0, 0.0]),
        "Z": np.array([0.0, 0.0, 1.0])}


@dataclass(frozen=True)
class _Link:
    name: str  # joint prim name
    kind: str  # revolute, continuous, prismatic, fixed, ball (held at its rest pose)
    parent: str  # body path (WORLD for the world)
    child: str
    to_joint: np.ndarray  # joint frame in the parent body (metres)
    from_joint: np.ndarray  # inverse of the joint frame in the child body
    axis: np.ndarray  # in the joint frame; negated when the joint runs child -> parent
    child_offset: np.ndarray  # translation from the body frame to its part frame
    lower: float | None = None  # rad or m; None: unbounded
    upper: float | None = None
    prim: str = ""  # the joint prim's path
    instance: str = ""  # its drive's instance: angular, linear, or a generic joint's rotX


def _frame(position, orientation, mpu: float) -> np.ndarray:
    w, (x, y, z) = orientation.GetReal(), orientation.GetImaginary()
    return tf.make(tf.quat_to_matrix([w, x, y, z]), np.array(list(position), float) * mpu)


class UsdProbe:
    label = "USD (UsdPhysics)"

    def __init__(self, path: Path):
        from pxr import Tf, Usd, UsdGeom

        self.path = path
        with contextlib.suppress(ImportError):  # our NewtonMassAPI / NewtonJointAPI
            import newton_usd_schemas  # noqa: F401
        try:
            stage = Usd.Stage.Open(str(path))
            parsed = load_physics(stage)
        except Tf.ErrorException as e:
            raise CheckError(f"{path}: cannot load with UsdPhysics: {e}") from e
        # kept while the probe lives: the file's layer stays loaded, and check's USD
        # validator, opening the same file, composes it without parsing it again; the
        # dynamics against a source read its masses and joint laws from it
        self.stage, self.parsed = stage, parsed
        mpu = float(UsdGeom.GetStageMetersPerUnit(stage))
        self.meters_per_unit = mpu
        self._world = np.eye(4)
        if UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y:
            self._world[:3, :3] = tf.axis_angle_matrix([1.0, 0.0, 0.0], math.pi / 2)

        bodies, joints = [], []
        for kind, (paths, descs) in parsed.items():
            for p, d in zip(paths, descs, strict=True):
                if kind.name == "RigidBody":
                    bodies.append(str(p))
                elif kind.name.endswith("Joint"):
                    # (a generic joint only beside the articulation, closing a loop: below)
                    if kind.name not in ("RevoluteJoint", "PrismaticJoint", "FixedJoint",
                                         "SphericalJoint", "D6Joint"):
                        raise CheckError(f"{path}: joint <{p}>: {kind.name} is not supported")
                    joints.append((str(p), kind.name, d))
        if not bodies:
            raise CheckError(f"{path}: UsdPhysics finds no rigid bodies")
        # stage order (instance proxies too, as UsdPhysics parses them), bodies and joints:
        # the walk below meets the joints in the reader's order, so a loop is closed by the
        # same joint
        stage_order = {str(p.GetPath()): i for i, p in enumerate(
            Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies()))}
        bodies.sort(key=stage_order.__getitem__)
        joints.sort(key=lambda j: stage_order[j[0]])
        # (names that repeat, a foot in each of several robots of a scene, a frame in each
        # leg, made unique in stage order, bodies first, as our reader makes them)
        taken: set[str] = set()
        self.parts = [sanitize_name(_name(stage.GetPrimAtPath(b)), taken) for b in bodies]
        self._names = dict(zip(bodies, self.parts, strict=True))
        # frames: Xforms with nothing to draw below them, in a body, moving with it
        self._frames = [(sanitize_name(name, taken), body, local) for body in bodies
                        for name, local in _frames(stage.GetPrimAtPath(body), mpu)
                        if name not in self._names.values()]
        self.parts += [name for name, _, _ in self._frames]

        # breadth first from the world; a body never reached stands where the file puts it
        cache = UsdGeom.XformCache(Usd.TimeCode.Default())
        self._roots: dict[str, np.ndarray] = {}
        self._links: list[_Link] = []
        at: dict[str, list[int]] = {}  # body path -> its joints (indices into ``joints``)
        for k, (_, _, d) in enumerate(joints):
            for end in dict.fromkeys((str(d.body0), str(d.body1))):
                at.setdefault(end, []).append(k)
        walked, reached, order = set(), {WORLD}, [WORLD]
        # a joint excluded from the articulation (physics:excludeFromArticulation) is walked
        # after every other; one closing a loop is a constraint beside the tree, not posed
        # (the reader warns of it)
        excluded = {k for k, (_, _, d) in enumerate(joints) if d.excludeFromArticulation}
        stacks = _stacks(joints, excluded, stage_order)
        stacked = {k for rest in stacks.values() for k in rest}

        def walk(frontier: collections.deque, excluded_too: bool) -> None:
            while frontier:
                body = frontier.popleft()
                for k in at.get(body, ()):
                    if k in walked or (k in excluded and not excluded_too):
                        continue
                    walked.add(k)
                    if k in stacked:
                        continue  # posed with the first joint of its stack
                    d = joints[k][2]
                    if (str(d.body1) if str(d.body0) == body else str(d.body0)) in reached:
                        continue  # closes a loop: beside the tree, as the reader keeps it
                    if joints[k][1] == "D6Joint":
                        links = self._d6_links(joints[k], body, mpu, path)
                    elif k in stacks and str(joints[k][2].body0) == body:
                        links = self._stacked_links([joints[i] for i in (k, *stacks[k])],
                                                    body, mpu)
                    else:  # one joint (a stack's first walked from its body1 too: the
                        # others then close loops, as the reader reads them)
                        links = [self._link(joints[k], body, mpu)]
                    child = links[-1].child
                    reached.add(child)
                    order.append(child)
                    frontier.append(child)
                    self._links += links

        unreached = iter(bodies)  # (in stage order: the first one not reached is a root)
        frontier = collections.deque([WORLD])
        while True:
            walk(frontier, False)
            walk(collections.deque(order), True)
            root = next((b for b in unreached if b not in reached), None)
            if root is None:
                break
            m = np.array(cache.GetLocalToWorldTransform(stage.GetPrimAtPath(root))).T
            m[:3, 3] *= mpu
            m[:3, :3] = tf.orthonormalize(m[:3, :3])  # (its frame: a scale, its shapes')
            self._roots[root] = self._world @ m
            reached.add(root)
            order.append(root)
            frontier.append(root)

        # joint names that repeat (each robot of a scene its own "hip") made unique in the
        # stage order of their prims, as our reader names them
        taken: set[str] = set()
        renamed = {id(k): sanitize_name(k.name, taken) for k in sorted(
            self._links, key=lambda k: stage_order.get(k.prim, -1))}
        # (joint prim, drive instance) -> joint name: what the file's drives drive
        self.joint_names = {(k.prim, k.instance): renamed[id(k)] for k in self._links}
        self._links = [dataclasses.replace(k, name=renamed[id(k)]) for k in self._links]
        self.joints = [JointInfo(k.name, k.kind, k.lower, k.upper) for k in self._links
                       if k.kind not in ("fixed", "ball")]
        self._column = {j.name: k for k, j in enumerate(self.joints)}

    def _link(self, item, parent: str, mpu: float) -> _Link:
        prim_path, kind_name, d = item
        t0 = _frame(d.localPose0Position, d.localPose0Orientation, mpu)
        t1 = _frame(d.localPose1Position, d.localPose1Orientation, mpu)
        forward = str(d.body0) == parent
        to_joint, child_frame = (t0, t1) if forward else (t1, t0)
        child = str(d.body1) if forward else str(d.body0)
        kind, lower, upper = "fixed", None, None
        if kind_name == "SphericalJoint":
            kind = "ball"
        elif kind_name != "FixedJoint":
            lim = d.limit
            limited = bool(lim.enabled) and math.isfinite(lim.lower) and math.isfinite(lim.upper)
            if kind_name == "RevoluteJoint":
                kind = "revolute" if limited else "continuous"
                lower, upper = (math.radians(lim.lower), math.radians(lim.upper)) if limited \
                    else (None, None)
            else:
                kind = "prismatic"
                lower, upper = (lim.lower * mpu, lim.upper * mpu) if limited else (None, None)
        axis = AXES[str(d.axis)] if kind not in ("fixed", "ball") else AXES["X"]
        axis = axis if forward else -axis
        if lower is not None and lower == upper:  # held there, as PhysX and Newton hold it
            to_joint = to_joint @ joint_motions(kind, axis, np.array([lower]))[0]
            kind, lower, upper = "fixed", None, None
        return _Link(_name(self.stage.GetPrimAtPath(prim_path)), kind, parent, child, to_joint,
                     tf.inverse(child_frame), axis, tf.make(translation=child_frame[:3, 3]),
                     lower, upper, prim_path,
                     "linear" if kind_name == "PrismaticJoint" else "angular")

    def _stacked_links(self, items, parent: str, mpu: float) -> list[_Link]:
        """Hinges and slides stacked between the same two bodies, in stage order, as MuJoCo
        applies one body's joints (how mujoco-usd-converter writes such a body): the first
        as any joint, each next one about its own frame in the child body, as the ones before
        moved it. The frames between are reported as the parts ``<child>_<joint>``: the
        child's axes at that joint's anchor, as the model's intermediate parts stand."""
        first = self._link(items[0], parent, mpu)
        child, links, above = first.child, [], parent
        for k, item in enumerate(items):
            link = first if k == 0 else self._link(item, parent, mpu)
            last = k == len(items) - 1
            below = child if last else f"{child}#{link.name}"
            if not last:
                self._names[below] = f"{self._names[child]}_{link.name}"
                self.parts.append(self._names[below])
            _, _, d = item
            in_child = _frame(d.localPose1Position, d.localPose1Orientation, mpu)
            links.append(dataclasses.replace(
                link, parent=above, child=below,
                to_joint=link.to_joint if k == 0 else in_child,
                from_joint=tf.inverse(in_child),
                child_offset=tf.make(translation=in_child[:3, 3])))
            above = below
        return links

    def _d6_links(self, item, parent: str, mpu: float, path) -> list[_Link]:
        """A generic joint (D6) as the links of its free axes (formats.usd.d6: translations,
        then rotations X, Y, Z, each about its axis as the ones before turned it), named
        ``<joint>_<axis>`` when there are several, through frames reported as the parts
        ``<child>_<joint>_<axis>`` (the joint frame turned back to the child's, as the
        model's intermediate parts stand); none free: fixed; three rotations, none limited:
        a ball. Walked from body1, the chain runs backwards, its axes negated."""
        from ..formats.usd import d6

        prim_path, _, d = item
        name = _name(self.stage.GetPrimAtPath(prim_path))
        dofs = d6.free_dofs(d, path, f"joint prim <{prim_path}>")
        t0 = _frame(d.localPose0Position, d.localPose0Orientation, mpu)
        t1 = _frame(d.localPose1Position, d.localPose1Orientation, mpu)
        forward = str(d.body0) == parent
        to_joint, child_frame = (t0, t1) if forward else (t1, t0)
        child = str(d.body1) if forward else str(d.body0)
        offset = tf.make(translation=child_frame[:3, 3])
        if not dofs or d6.is_ball(dofs):
            return [_Link(name, "ball" if dofs else "fixed", parent, child, to_joint,
                          tf.inverse(child_frame), AXES["X"], offset, prim=prim_path)]
        steps = dofs if forward else dofs[::-1]
        sign = 1.0 if forward else -1.0
        turned_back = tf.make(child_frame[:3, :3].T)
        links, above = [], parent
        for k, dof in enumerate(steps):
            last = k == len(steps) - 1
            joint = f"{name}_{dof.name}" if len(steps) > 1 else name
            below = child if last else f"{child}#{joint}"
            if not last:
                self._names[below] = f"{self._names[child]}_{joint}"
                self.parts.append(self._names[below])
            scale = math.pi / 180.0 if dof.angular else mpu
            bounds = (None, None) if dof.lower is None else (dof.lower * scale,
                                                             dof.upper * scale)
            links.append(_Link(joint, dof.kind.value, above, below,
                               to_joint if k == 0 else np.eye(4),
                               tf.inverse(child_frame) if last else np.eye(4),
                               AXES[dof.token] * sign, offset if last else turned_back,
                               *bounds, prim=prim_path, instance=dof.name))
            above = below
        return links

    def poses(self, q: dict[str, float]) -> dict[str, np.ndarray]:
        values = [float(q.get(j.name, 0.0)) for j in self.joints]
        return dict(zip(self.parts, self.pose_array([values])[0], strict=True))

    def pose_array(self, values) -> np.ndarray:
        """(N, len(joints)) joint values in the order of ``joints`` -> (N, len(parts), 4, 4),
        every configuration at once."""
        world = self.body_poses(values)
        out = {self._names[b]: world[b] for b in self._roots}
        out.update((self._names[link.child], world[link.child] @ link.child_offset)
                   for link in self._links)
        for name, body, local in self._frames:
            if body in world:
                out[name] = world[body] @ local
        return np.stack([out[name] for name in self.parts], axis=1)

    def body_poses(self, values) -> dict[str, np.ndarray]:
        """Rigid body prim path (and WORLD) -> (N, 4, 4): each body's own frame in the world
        (metres) at the N rows of ``values`` (joint values in the order of ``joints``)."""
        values = np.atleast_2d(np.asarray(values, dtype=float))
        n = len(values)
        world = {b: np.broadcast_to(pose, (n, 4, 4))
                 for b, pose in {WORLD: self._world, **self._roots}.items()}
        for link in self._links:
            column = self._column.get(link.name)
            q = values[:, column] if column is not None else np.zeros(n)
            motion = joint_motions(link.kind, link.axis, q)
            world[link.child] = world[link.parent] @ link.to_joint @ motion @ link.from_joint
        return world


def _name(prim) -> str:
    """A prim's name as our USD reader names its part or joint (its source's name where
    usd-exchange encoded it, made an identifier), so that files agree by name."""
    return sanitize_name(source_name(prim))


def _stacks(joints, excluded: set[int], order: dict[str, int]) -> dict[int, list[int]]:
    """The hinges and slides that join the same two bodies (body0 the same, body1 the same),
    by their first in stage order -> the others in stage order: one MJCF body's joints
    (formats.usd.articulation reads them so; UsdPhysics itself says nothing of their
    order, so they were loop closers here)."""
    groups: dict[tuple[str, str], list[int]] = {}
    for k, (_, kind, d) in enumerate(joints):
        if kind in ("RevoluteJoint", "PrismaticJoint") and k not in excluded:
            groups.setdefault((str(d.body0), str(d.body1)), []).append(k)
    stacks = {}
    for members in groups.values():
        if len(members) > 1:
            members.sort(key=lambda k: order[joints[k][0]])
            stacks[members[0]] = members[1:]
    return stacks


def _frames(body, mpu: float):
    """(name, pose in the body in metres) of the empty Xforms in a body prim and those naming
    their fixed joint, not entering nested rigid bodies."""
    from pxr import Usd, UsdGeom, UsdPhysics

    cache = UsdGeom.XformCache(Usd.TimeCode.Default())

    def own(prim):
        for child in prim.GetChildren():
            if not child.HasAPI(UsdPhysics.RigidBodyAPI):
                yield child
                yield from own(child)

    for p in own(body):
        if p.GetTypeName() != "Xform" or not p.HasAttribute(FRAME_JOINT) and any(
                d.IsA(UsdGeom.Gprim) for d in own(p)):
            continue
        local = np.array(cache.ComputeRelativeTransform(p, body)[0], dtype=float).T
        if tf.is_rotation(local[:3, :3], tol=1e-5):
            local[:3, 3] *= mpu
            yield _name(p), local


def open_probes(path: str | Path) -> list[UsdProbe]:
    return [UsdProbe(Path(path))]
