"""Building blocks shared by every category: box and cylinder primitives, parts assembled
from them, joints, colours and observed states.

Every category lays its primitives out in the object frame (Z up, the front facing +X, the
root standing on z = 0) with the object closed (q = 0); :func:`make_part` then moves them
into the part frame (the joint frame: a translation only, since no joint origin rotates)
and derives the visual mesh (the concatenated primitives), the collision pieces (one convex
primitive each) and the inertial (exact box inertials combined, each primitive with its own
density).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from real2code_export import transforms as tf
from real2code_export.inertia import box_inertial, combine_inertials, inertial_from_mesh
from real2code_export.model import Dynamics, Inertial, Joint, JointType, Limits, Mesh, Part

FRONT = np.array([1.0, 0.0, 0.0])  # the front of every generated object faces +X
UP = np.array([0.0, 0.0, 1.0])
CYLINDER_SECTIONS = 12  # knobs, round legs and feet: enough to read as round, few triangles

# Densities (kg/m^3) of the materials the generator uses. Panels are solid boxes here, so
# "insulated" stands for a steel skin with a foam core and "laptop" for a shell with parts.
DENSITY = {
    "wood": 650.0,
    "particleboard": 700.0,
    "cardboard": 250.0,
    "plastic": 950.0,
    "aluminium": 2700.0,
    "steel": 7850.0,
    "glass": 2500.0,
    "insulated": 220.0,
    "laptop_base": 750.0,
    "laptop_lid": 900.0,
    "hollow_core": 380.0,  # an interior door: veneered frame over a honeycomb core
    "plaster": 850.0,  # a stud wall with plasterboard, taken as solid
}


class PrimitiveError(ValueError):
    """A primitive with no volume: a bug in a category's layout, never a user error."""


@dataclass(frozen=True)
class Box:
    """An axis-aligned solid box between corners ``lo`` and ``hi`` (object frame)."""

    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    density: float

    def __post_init__(self) -> None:
        lo, hi = np.asarray(self.lo, float), np.asarray(self.hi, float)
        if lo.shape != (3,) or hi.shape != (3,) or not np.all(hi - lo > 1e-6):
            raise PrimitiveError(f"degenerate box {lo.tolist()} .. {hi.tolist()}")
        object.__setattr__(self, "lo", tuple(float(v) for v in lo))
        object.__setattr__(self, "hi", tuple(float(v) for v in hi))

    def moved(self, offset: np.ndarray) -> Box:
        return Box(tuple(np.add(self.lo, offset)), tuple(np.add(self.hi, offset)), self.density)

    def mesh(self) -> Mesh:
        import trimesh

        return Mesh.from_trimesh(trimesh.creation.box(bounds=np.array([self.lo, self.hi])))

    def inertial(self) -> Inertial:
        lo, hi = np.asarray(self.lo), np.asarray(self.hi)
        return box_inertial(hi - lo, density=self.density, center=0.5 * (lo + hi))


# Rotations taking a z-aligned cylinder (trimesh's) onto each world axis.
_AXIS_ROTATIONS = (
    tf.axis_angle_matrix([0.0, 1.0, 0.0], np.pi / 2),
    tf.axis_angle_matrix([1.0, 0.0, 0.0], -np.pi / 2),
    np.eye(3),
)


@dataclass(frozen=True)
class Cylinder:
    """A solid cylinder (a 12-sided prism) along world axis ``axis`` (0, 1, 2)."""

    center: tuple[float, float, float]
    axis: int
    radius: float
    length: float
    density: float

    def __post_init__(self) -> None:
        if self.axis not in (0, 1, 2) or not (self.radius > 1e-6 and self.length > 1e-6):
            raise PrimitiveError(f"degenerate cylinder r={self.radius} l={self.length}")
        object.__setattr__(self, "center", tuple(float(v) for v in self.center))

    def moved(self, offset: np.ndarray) -> Cylinder:
        return Cylinder(tuple(np.add(self.center, offset)), self.axis, self.radius, self.length,
                        self.density)

    def mesh(self) -> Mesh:
        import trimesh

        transform = tf.make(_AXIS_ROTATIONS[self.axis], self.center)
        return Mesh.from_trimesh(trimesh.creation.cylinder(
            radius=self.radius, height=self.length, sections=CYLINDER_SECTIONS, transform=transform))

    def inertial(self) -> Inertial:
        # The exact prism (closed mesh): what the collision piece and the visual really are.
        return inertial_from_mesh(self.mesh(), self.density)


Primitive = Box | Cylinder


def make_part(name: str, primitives: list[Primitive], frame: np.ndarray,
              color: tuple[float, float, float, float]) -> Part:
    """A part from primitives laid out in the object frame at q = 0, expressed in its own
    frame, whose origin is ``frame`` (object coordinates; the axes are the object's)."""
    offset = -np.asarray(frame, dtype=float)
    local = [p.moved(offset) for p in primitives]
    pieces = [p.mesh() for p in local]
    inertial = combine_inertials([(p.inertial(), np.eye(4)) for p in local])
    return Part(name=name, visual=Mesh.concatenate(pieces), collision=pieces, inertial=inertial,
                color=color)


def shell(lo, hi, wall: float, density: float, open_side: str) -> list[Box]:
    """The walls of a hollow box between corners ``lo`` and ``hi`` with one side left open
    (``"front"``: +X, an appliance's cavity; ``"top"``: +Z, a bin): five panels of
    thickness ``wall``, none overlapping another."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    w = wall
    if open_side == "front":
        return [
            Box((x0, y0, z0), (x1, y0 + w, z1), density), Box((x0, y1 - w, z0), (x1, y1, z1), density),
            Box((x0, y0 + w, z0), (x1, y1 - w, z0 + w), density),
            Box((x0, y0 + w, z1 - w), (x1, y1 - w, z1), density),
            Box((x0, y0 + w, z0 + w), (x0 + w, y1 - w, z1 - w), density),
        ]
    if open_side == "top":
        return [
            Box((x0, y0, z0), (x1, y1, z0 + w), density),
            Box((x0, y0, z0 + w), (x0 + w, y1, z1), density), Box((x1 - w, y0, z0 + w), (x1, y1, z1), density),
            Box((x0 + w, y0, z0 + w), (x1 - w, y0 + w, z1), density),
            Box((x0 + w, y1 - w, z0 + w), (x1 - w, y1, z1), density),
        ]
    raise PrimitiveError(f"no open side {open_side!r}")


# -- joints ------------------------------------------------------------------------------------
def observed_state(rng: np.random.Generator, limits: Limits, p_closed: float = 0.15) -> float:
    """The value at capture time: mostly partially open (Real2Code renders its objects with
    every door and drawer partly open), sometimes closed."""
    if rng.random() < p_closed:
        return float(limits.lower)
    return float(limits.lower + (limits.upper - limits.lower) * rng.uniform(0.15, 0.9))


def revolute(rng: np.random.Generator, name: str, child: str, hinge: np.ndarray, axis,
             upper: float, *, damping: float, friction: float, effort: float) -> Joint:
    """A hinge on the body: origin at ``hinge`` (object frame), 0 = closed, positive opens."""
    limits = Limits(0.0, float(upper), effort=effort, velocity=3.0)
    return Joint(name=name, type=JointType.REVOLUTE, parent="body", child=child,
                 origin=tf.make(translation=hinge), axis=np.asarray(axis, float), limits=limits,
                 dynamics=Dynamics(damping=damping, friction=friction),
                 state=observed_state(rng, limits))


def prismatic(rng: np.random.Generator, name: str, child: str, rest: np.ndarray,
              travel: float, *, damping: float, friction: float, axis=FRONT) -> Joint:
    """A slide along ``axis`` (a drawer's: the front normal), origin at the part's closed
    position."""
    limits = Limits(0.0, float(travel), effort=100.0, velocity=1.0)
    return Joint(name=name, type=JointType.PRISMATIC, parent="body", child=child,
                 origin=tf.make(translation=rest), axis=np.array(axis, dtype=float),
                 limits=limits,
                 dynamics=Dynamics(damping=damping, friction=friction),
                 state=observed_state(rng, limits))


# -- colours -----------------------------------------------------------------------------------
# sRGB swatches (what a designer would pick); parts store linear RGBA.
PALETTES: dict[str, dict[str, tuple[float, float, float]]] = {
    "wood": {
        "oak": (0.78, 0.62, 0.42), "walnut": (0.42, 0.28, 0.17), "cherry": (0.60, 0.33, 0.20),
        "birch": (0.86, 0.76, 0.58), "pine": (0.83, 0.66, 0.43), "wenge": (0.26, 0.19, 0.14),
    },
    "paint": {
        "white": (0.93, 0.93, 0.91), "grey": (0.55, 0.56, 0.57), "black": (0.12, 0.12, 0.13),
        "navy": (0.18, 0.24, 0.38), "sage": (0.60, 0.68, 0.58), "cream": (0.92, 0.88, 0.78),
        "red": (0.66, 0.16, 0.14), "teal": (0.16, 0.47, 0.49),
    },
    "appliance": {
        "white": (0.94, 0.94, 0.93), "stainless": (0.74, 0.75, 0.76), "black": (0.10, 0.10, 0.11),
        "cream": (0.93, 0.89, 0.76), "mint": (0.67, 0.85, 0.78), "red": (0.72, 0.12, 0.12),
    },
    "laptop": {
        "silver": (0.78, 0.79, 0.80), "space_grey": (0.36, 0.37, 0.39),
        "black": (0.09, 0.09, 0.10), "gold": (0.86, 0.76, 0.64),
    },
    "cardboard": {"kraft": (0.70, 0.55, 0.38), "white": (0.92, 0.91, 0.88)},
    "plastic": {
        "clear_blue": (0.55, 0.70, 0.85), "black": (0.10, 0.10, 0.10), "grey": (0.50, 0.52, 0.55),
        "green": (0.35, 0.60, 0.35), "yellow": (0.92, 0.78, 0.25),
    },
}


def srgb_to_linear(c: float) -> float:
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


def pick_color(rng: np.random.Generator, palette: str) -> tuple[str, tuple[float, float, float, float]]:
    """A swatch name and its linear RGBA, jittered a little so no two objects match exactly."""
    names = sorted(PALETTES[palette])
    name = names[int(rng.integers(len(names)))]
    srgb = np.clip(np.asarray(PALETTES[palette][name]) + rng.uniform(-0.03, 0.03, 3), 0.0, 1.0)
    return name, (*(srgb_to_linear(float(c)) for c in srgb), 1.0)


# -- the result of one category --------------------------------------------------------------
@dataclass
class Assembly:
    """What a category builds: parts (root first), joints, semantic labels and style facts
    (JSON-serialisable) for the metadata."""

    parts: list[Part] = field(default_factory=list)
    joints: list[Joint] = field(default_factory=list)
    part_labels: dict[str, str] = field(default_factory=dict)
    joint_labels: dict[str, str] = field(default_factory=dict)
    hinge_sides: dict[str, str] = field(default_factory=dict)
    style: dict[str, object] = field(default_factory=dict)

    def add(self, part: Part, label: str, joint: Joint | None = None, side: str | None = None):
        self.parts.append(part)
        self.part_labels[part.name] = label
        if joint is not None:
            self.joints.append(joint)
            self.joint_labels[joint.name] = label
            if side is not None:
                self.hinge_sides[joint.name] = side


def uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(rng.uniform(lo, hi))


def choice(rng: np.random.Generator, options: list[str] | tuple[str, ...],
           p: list[float] | None = None) -> str:
    return str(options[int(rng.choice(len(options), p=p))])


# -- observed states without collisions ------------------------------------------------------
def _local_boxes(part: Part) -> tuple[np.ndarray, np.ndarray]:
    """Centres and half extents of the part's collision pieces in its frame (boxes exactly,
    cylinders by their bounding boxes)."""
    bounds = np.array([piece.bounds() for piece in part.collision])  # (N, 2, 3)
    return 0.5 * (bounds[:, 0] + bounds[:, 1]), 0.5 * (bounds[:, 1] - bounds[:, 0])


def _penetrates(a: tuple, b: tuple, pose_a: np.ndarray, pose_b: np.ndarray) -> bool:
    """Whether any piece of one part overlaps a piece of the other (beyond 0.1 mm).

    The separating-axis test for oriented boxes, written here because the pieces are boxes
    in their part's axes and no collision library (fcl) is a dependency."""
    ra, rb = pose_a[:3, :3], pose_b[:3, :3]
    axes = [ra[:, i] for i in range(3)] + [rb[:, i] for i in range(3)]
    for i in range(3):
        for k in range(3):
            c = np.cross(ra[:, i], rb[:, k])
            if np.linalg.norm(c) > 1e-9:
                axes.append(c / np.linalg.norm(c))
    axes = np.array(axes).T  # (3, n_axes)
    ca = a[0] @ ra.T + pose_a[:3, 3]
    cb = b[0] @ rb.T + pose_b[:3, 3]
    rad_a = a[1] @ np.abs(ra.T @ axes)  # (Na, n_axes): each box's half width along each axis
    rad_b = b[1] @ np.abs(rb.T @ axes)
    dist = np.abs((ca @ axes)[:, None, :] - (cb @ axes)[None, :, :])
    gap = (dist - rad_a[:, None, :] - rad_b[None, :, :]).max(axis=2)
    return bool(np.any(gap < -1e-4))


def close_clashing_fronts(parts: list[Part], joints: list[Joint]) -> None:
    """Make the observed configuration collision-free: where two open parts overlap (a door
    swung in front of a pulled-out drawer) or one hits the body, close the later one (or,
    when it is already closed, the earlier one). All closed, nothing overlaps."""
    boxes = {p.name: _local_boxes(p) for p in parts}
    by_child = {j.child: j for j in joints}
    while True:
        poses = {parts[0].name: np.eye(4)}
        for j in joints:  # every joint hangs off the root
            poses[j.child] = j.transform(j.state)
        def is_open(name: str) -> bool:
            return name in by_child and by_child[name].state != by_child[name].limits.lower

        names = [p.name for p in parts]  # the root first, so a clash's second part moves
        clash = next(((a, b) for i, a in enumerate(names) for b in names[i + 1:]
                      if (is_open(a) or is_open(b))
                      and _penetrates(boxes[a], boxes[b], poses[a], poses[b])), None)
        if clash is None:
            return
        joint = by_child[clash[1]] if is_open(clash[1]) else by_child[clash[0]]
        joint.state = float(joint.limits.lower)
