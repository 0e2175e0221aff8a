"""The contact experiments of the dynamic check: what a robot does with the object.

- ``drop``: every joint opened to 90 % of its range from its closed end, the hinges held
  there (made fixed); a 5 cm box released 2 cm above the floor of every open drawer (a
  slide's child with a floor a box fits on, reached from above without touching anything
  else). It must come to rest on that floor: inside its extent, neither through it nor on
  anything above it (within ``REST_TOLERANCE``).
- ``shut``: every door (a limited hinge with a closed end) started 0.5 rad open and thrown
  shut at 1 rad/s, no gravity, its joint laws off, its frame and its neighbours colliding
  with it: it must come to its closed value and stop there (within ``STOP_TOLERANCE``),
  neither held off by pieces in its way nor kicked back or through by them. Its limit stays:
  an inset door (the shipped cabinet's) has nothing in front of it but its hinge's stop,
  which is its limit; a door that meets its frame meets it at the limit.

Both collide every pair of parts (``self_contacts``: the file's exclusions lifted; the
collision geometry is separated at rest and along the ranges, docs/engines.md), with the
object's own collision pieces. Contacts are not compared with MuJoCo sample by sample
(engines' contact models differ and an impact amplifies them): every engine, MuJoCo
included, is judged on the outcome. The closed end of a joint is the limit at its modelled
pose (q = 0), where the parts were modelled shut.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..model import ArticulatedObject, Dynamics, Joint, JointType, forward_kinematics
from . import Experiment, Trajectory
from .experiments import without_velocity_limits

BOX_SIZE = 0.05  # m, the dropped cube's edge
BOX_MASS = 0.1  # kg
DROP_CLEARANCE = 0.02  # m between the box's underside and the floor when released
OPEN_FRACTION = 0.9
FLOOR_BELOW_RIM = 0.01  # m: a floor at least this far below its drawer's top is inside it
FLOOR_FLATNESS = 0.01  # m: the rays under the box's footprint meet the floor this level
RAY_SPACING = 0.005  # m between the downward rays that find a drawer's floor
SHUT_OPEN = 0.5  # rad from the closed end (or 90 % of a shorter range)
SHUT_SPEED = 1.0  # rad/s
STOP_TOLERANCE = 0.02  # rad past the closed value: a door further in went through its frame
REST_TOLERANCE = 0.01  # m: the box's final centre this close to resting on the floor (a
# floor's levels apart, an engine's contact depth)


@dataclass
class Verdict:
    ok: bool
    message: str
    angle: float = 0.0  # rad, the worst door's travel past its closed value
    distance: float = 0.0  # m, the worst box's distance from resting on its floor, inside


Judge = Callable[[Trajectory], Verdict]


def closed_end(joint: Joint) -> float | None:
    """The limit at the joint's modelled pose (q = 0), None when the joint has no closed
    end: unlimited, or 0 well inside its range (a door swinging both ways)."""
    if joint.limits is None or joint.type is JointType.CONTINUOUS:
        return None
    lower, upper = joint.limits.lower, joint.limits.upper
    end = lower if abs(lower) <= abs(upper) else upper
    return end if abs(end) <= 0.05 * (upper - lower) else None


def _opened(joint: Joint) -> float:
    """90 % of the way from its closed end (the observed state when it has none)."""
    closed = closed_end(joint)
    if closed is None:
        return joint.state if joint.limits is None else \
            min(max(joint.state, joint.limits.lower), joint.limits.upper)
    far = joint.limits.upper if closed == joint.limits.lower else joint.limits.lower
    return closed + OPEN_FRACTION * (far - closed)


def _experiment(name: str, obj: ArticulatedObject, q0: dict[str, float],
                v0: dict[str, float], **kw) -> Experiment:
    joints = obj.movable_joints
    return Experiment(name, tuple(j.name for j in joints), tuple(j.type.angular for j in joints),
                      tuple(q0[j.name] for j in joints),
                      tuple(v0.get(j.name, 0.0) for j in joints),
                      contacts=True, self_contacts=True, **kw)


# -- drop: a box into every open drawer -------------------------------------------------------

@dataclass(frozen=True)
class Floor:
    joint: str
    axis: np.ndarray  # the slide's world direction
    height: float  # m, world z of the floor where the box lands
    low: float  # m, world z of the floor's lowest level (an uneven floor: 1 cm below at most)
    inside: np.ndarray  # (2, 2): the floor's xy extent at the open state
    centre: tuple[float, float, float]  # where the box is released


def _world_pieces(obj: ArticulatedObject, q: dict[str, float]):
    """All parts' collision pieces in the world at ``q``, one trimesh, and each face's part."""
    import trimesh

    poses = forward_kinematics(obj, q)
    meshes, owner = [], []
    for index, part in enumerate(obj.parts):
        for piece in part.collision:
            meshes.append(piece.transformed(poses[part.name]).to_trimesh())
            owner.append(np.full(len(piece.faces), index))
    if not meshes:
        return None, None
    return trimesh.util.concatenate(meshes), np.concatenate(owner)


def find_floor(obj: ArticulatedObject, joint: Joint, q: dict[str, float], scene, owner,
               box_size: float = BOX_SIZE) -> Floor | None:
    """Where a box dropped from above lands on ``joint``'s child and nothing else: downward
    rays every ``RAY_SPACING`` over the child's extent; a spot is a floor when every ray
    under the box's footprint (with a margin) first meets the child at one level, at least
    ``FLOOR_BELOW_RIM`` below the child's top. The lowest such level; on it, the spot
    nearest the middle of that floor."""
    from trimesh.ray.ray_triangle import RayMeshIntersector

    child = next(i for i, p in enumerate(obj.parts) if p.name == joint.child)
    pose = forward_kinematics(obj, q)[joint.child]
    pieces = [m.transformed(pose) for m in obj.parts[child].collision]
    if not pieces:
        return None
    lo = np.min([m.vertices.min(axis=0) for m in pieces], axis=0)
    hi = np.max([m.vertices.max(axis=0) for m in pieces], axis=0)
    xs = np.arange(lo[0] + RAY_SPACING / 2, hi[0], RAY_SPACING)
    ys = np.arange(lo[1] + RAY_SPACING / 2, hi[1], RAY_SPACING)
    if len(xs) < 2 or len(ys) < 2:
        return None
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    top = float(scene.bounds[1][2]) + 0.1
    origins = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, top)])
    down = np.tile([0.0, 0.0, -1.0], (len(origins), 1))
    where, ray, face = RayMeshIntersector(scene).intersects_location(origins, down,
                                                                     multiple_hits=False)
    z = np.full(len(origins), np.nan)
    z[ray[owner[face] == child]] = where[owner[face] == child][:, 2]
    z = z.reshape(gx.shape)  # NaN: the ray missed the child or met another part first
    reach = int(np.ceil((box_size / 2 + RAY_SPACING) / RAY_SPACING))
    candidates = []
    for i in range(reach, gx.shape[0] - reach):
        for k in range(reach, gx.shape[1] - reach):
            under = z[i - reach:i + reach + 1, k - reach:k + reach + 1]
            if np.all(np.isfinite(under)) and np.ptp(under) <= FLOOR_FLATNESS and \
                    z[i, k] <= hi[2] - FLOOR_BELOW_RIM:
                candidates.append((z[i, k], i, k))
    if not candidates:
        return None
    lowest = min(c[0] for c in candidates)
    level = [(i, k) for h, i, k in candidates if h <= lowest + FLOOR_FLATNESS]
    floor = np.isfinite(z) & (np.abs(z - lowest) <= FLOOR_FLATNESS)
    inside = np.array([[gx[floor].min(), gy[floor].min()], [gx[floor].max(), gy[floor].max()]])
    middle = np.mean([(gx[i, k], gy[i, k]) for i, k in level], axis=0)
    i, k = min(level, key=lambda ik: np.hypot(gx[ik] - middle[0], gy[ik] - middle[1]))
    height = float(max(z[i - reach:i + reach + 1, k - reach:k + reach + 1].max(), lowest))
    parent_pose = forward_kinematics(obj, q)[joint.parent] @ joint.origin
    return Floor(joint.name, parent_pose[:3, :3] @ joint.axis, height, float(lowest), inside,
                 (float(gx[i, k]), float(gy[i, k]),
                  height + DROP_CLEARANCE + box_size / 2))


def drop(obj: ArticulatedObject
         ) -> tuple[ArticulatedObject, Experiment | None, Judge, list[str]]:
    """Every joint open; a box over every drawer's floor (no experiment without one). Notes
    name drawers without one."""
    variant = without_velocity_limits(obj)
    q = {j.name: _opened(j) for j in variant.movable_joints}
    for joint in variant.movable_joints:  # the doors held open: only drawers move
        if joint.type is not JointType.PRISMATIC:
            joint.origin = joint.transform(q.pop(joint.name))
            joint.type, joint.limits, joint.dynamics = JointType.FIXED, None, Dynamics()
            joint.state, joint.mimic = 0.0, None
    held = {j.name for j in variant.joints if j.type is JointType.FIXED}
    for joint in variant.movable_joints:  # a drawer coupled to a door held open: uncoupled
        if joint.mimic is not None and joint.mimic.joint in held:
            joint.mimic = None
    scene, owner = _world_pieces(variant, q)
    floors, notes = [], []
    for joint in variant.movable_joints:
        if joint.type is not JointType.PRISMATIC or closed_end(joint) is None:
            continue
        floor = find_floor(variant, joint, q, scene, owner) if scene is not None else None
        if floor is None:
            notes.append(f"{joint.name}: no floor a {BOX_SIZE * 100:g} cm box can be dropped "
                         f"on, reached from above when open")
        else:
            floors.append(floor)
    experiment = _experiment("drop", variant, q, {},
                             boxes=tuple(f.centre for f in floors), box_size=BOX_SIZE,
                             box_mass=BOX_MASS) if floors else None
    return variant, experiment, _drop_judge(floors, BOX_SIZE / 2), notes


def _drop_judge(floors: list[Floor], half: float) -> Judge:
    def judge(trajectory: Trajectory) -> Verdict:
        column = {n: i for i, n in enumerate(trajectory.joints)}
        worst, deepest, said = 0.0, -np.inf, []
        for b, floor in enumerate(floors):
            i = column[floor.joint]
            moved = (trajectory.q[-1, i] - trajectory.q[0, i]) * floor.axis
            centre = trajectory.boxes[-1, b] - moved  # in the drawer as it was opened
            outside = np.maximum(np.maximum(floor.inside[0] - centre[:2],
                                            centre[:2] - floor.inside[1]), 0.0)
            # resting on the floor: neither through it nor on anything above it
            z = float(centre[2])
            miss = max(float(np.linalg.norm(outside)), floor.low + half - REST_TOLERANCE - z,
                       z - (floor.height + half + REST_TOLERANCE), 0.0)
            if not np.all(np.isfinite(centre)):
                miss = float("inf")
            worst = max(worst, miss)
            deepest = max(deepest, floor.height + half - z)  # into the floor's top level
            if miss > 0:
                said.append(f"the box in {floor.joint} ended {miss * 1000:.0f} mm off its floor")
        depth = f"{deepest * 1000:.1f} mm into the floor at most" if deepest >= 0 else \
            f"{-deepest * 1000:.1f} mm above it"  # an engine's contact offset
        message = "; ".join(said) or f"{len(floors)} box(es) at rest in their drawers, {depth}"
        return Verdict(not said, message, distance=worst)

    return judge


# -- shut: every door against its frame -------------------------------------------------------

def shut(obj: ArticulatedObject
         ) -> tuple[ArticulatedObject, Experiment | None, Judge, list[str]]:
    """Every door thrown shut (no experiment without a door); notes name hinges without a
    closed end."""
    variant = without_velocity_limits(obj)
    q, v, doors, notes = {}, {}, {}, []
    for joint in variant.movable_joints:
        closed = closed_end(joint)
        q[joint.name] = closed if closed is not None else _opened(joint)
        joint.dynamics = Dynamics(armature=joint.dynamics.armature)
        if not joint.type.angular:
            continue
        if closed is None:
            notes.append(f"{joint.name}: no closed end (limits "
                         f"{'none' if joint.limits is None else 'around 0'})")
            continue
        lower, upper = joint.limits.lower, joint.limits.upper
        sign = 1.0 if closed == upper else -1.0  # from open toward closed
        q[joint.name] = closed - sign * min(SHUT_OPEN, OPEN_FRACTION * (upper - lower))
        v[joint.name] = sign * SHUT_SPEED
        doors[joint.name] = (closed, sign)
    experiment = _experiment("shut", variant, q, v, gravity=(0.0, 0.0, 0.0)) if doors else None
    return variant, experiment, _shut_judge(doors), notes


def _shut_judge(doors: dict[str, tuple[float, float]]) -> Judge:
    def judge(trajectory: Trajectory) -> Verdict:
        column = {n: i for i, n in enumerate(trajectory.joints)}
        worst, said = 0.0, []
        for name, (closed, sign) in doors.items():
            travel = sign * (trajectory.q[:, column[name]] - closed)  # > 0: past closed
            past = float(np.nanmax(travel)) if np.all(np.isfinite(travel)) else float("inf")
            worst = max(worst, past)
            if past > STOP_TOLERANCE:
                said.append(f"{name} went {past:.3f} rad past its closed value")
            elif past < -STOP_TOLERANCE:
                said.append(f"{name} stopped {-past:.3f} rad before its closed value")
        message = "; ".join(said) or f"{len(doors)} door(s) stopped at their frames"
        return Verdict(not said, message, angle=max(worst, 0.0))

    return judge


CONTACT_EXPERIMENTS = {"drop": drop, "shut": shut}
