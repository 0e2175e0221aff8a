"""The articulated-object model every importer fills and every exporter reads.

Conventions (docs/design.md): SI units, Z up, right-handed. A part's frame is its joint frame
(URDF style): ``joint.origin`` is the pose of the child frame in the parent frame at q = 0,
``joint.axis`` a unit vector in that frame. A part's visual and collision meshes and its
inertial are expressed in the part frame. Colours are linear RGBA in [0, 1].

The dataclasses hold data only; :func:`validate` checks a whole object and raises a
:class:`ModelError` naming the part or joint and what is wrong; :func:`forward_kinematics`
gives the world pose of every part.
"""

from __future__ import annotations

import hashlib
import math
import re
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np

from . import transforms as tf
from .errors import ModelError, NameNotFoundError
from .primitives import Primitive

NAME_PATTERN = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
AXIS_UNIT_TOLERANCE = 1e-6
# A limit this large or larger is no limit (SDF's and Gazebo's convention, +-1e16): the URDF
# writer writes it for a slide without limits, since URDF requires a prismatic <limit>.
UNBOUNDED_LIMIT = 1e16
# How far sampling moves a slide without limits (m, either way from 0): kinematics are checked
# over a span where a wrong axis or origin shows.
UNBOUNDED_SLIDE_SPAN = 1.0
DEFAULT_COLOR = (0.7, 0.7, 0.7, 1.0)
WHITE = (1.0, 1.0, 1.0, 1.0)  # the tint of an image whose colours are all its own
RGBA = tuple[float, float, float, float]


class JointType(StrEnum):
    REVOLUTE = "revolute"
    PRISMATIC = "prismatic"
    CONTINUOUS = "continuous"
    FIXED = "fixed"
    BALL = "ball"  # three rotations about the joint origin (MJCF ball, USD spherical)
    FLOATING = "floating"  # six degrees of freedom: a free body (MJCF free, URDF floating)

    @property
    def movable(self) -> bool:
        """Posed by one joint value (``q`` by joint name, a state, an axis, limits)."""
        return self in (JointType.REVOLUTE, JointType.PRISMATIC, JointType.CONTINUOUS)

    @property
    def multi_dof(self) -> bool:
        """Moves with several degrees of freedom the model gives no value: the child is held
        at the joint origin (its reference pose) in kinematics, as MuJoCo's ``qpos0`` and
        Pinocchio's neutral configuration hold it; no axis, limits or state."""
        return self in (JointType.BALL, JointType.FLOATING)

    @property
    def angular(self) -> bool:
        return self in (JointType.REVOLUTE, JointType.CONTINUOUS)


@dataclass(frozen=True, eq=False)
class Placement:
    """A stretch of a mesh's own triangles that is mesh ``asset`` moved by the rigid
    ``pose``: the mesh's vertices ``vertex:vertex + len(asset.vertices)`` are
    ``asset.transformed(pose)``'s (to float64 rounding, where poses were composed) and its
    faces ``face:face + len(asset.faces)`` are ``asset.faces + vertex``. A reader that places
    one mesh file several times (MJCF's mesh assets, each used by several geoms) says so,
    so that a writer whose format can place one mesh data several times (USD's references)
    writes it once; every other reader and writer takes the mesh as it is."""

    asset: Mesh  # a mesh of its own: no shapes, no placements
    pose: np.ndarray  # 4x4, rigid
    vertex: int
    face: int

    @property
    def vertex_end(self) -> int:
        return self.vertex + len(self.asset.vertices)

    @property
    def face_end(self) -> int:
        return self.face + len(self.asset.faces)

    def shifted(self, vertices: int, faces: int, before: np.ndarray | None = None) -> Placement:
        """The placement in a mesh that has ``vertices`` and ``faces`` more before it (and,
        ``before``, is moved by that rigid transform)."""
        pose = self.pose if before is None else before @ self.pose
        return Placement(self.asset, pose, self.vertex + vertices, self.face + faces)


def corner_bounds(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``points.min(axis=0)`` and ``points.max(axis=0)`` of (N, 3) points, bit for bit (a
    zero's sign too: that reduction keeps the last of equal values, so this does), from the
    columns copied to rows: numpy reduces an (N, 3) array down its rows three numbers at a
    time, 30 to 50 times slower (4 ms for 20,000 points, where copy and reduce take 0.1)."""
    columns = np.asarray(points).T.copy()
    low, high = columns.min(axis=1), columns.max(axis=1)
    for out in (low, high):
        for j in np.flatnonzero(out == 0):
            out[j] = columns[j][np.flatnonzero(columns[j] == 0)[-1]]
    return low, high


@dataclass(eq=False)
class Mesh:
    """A triangle mesh: float64 vertices (N, 3), int64 faces (M, 3) and, for a textured
    mesh, one texture coordinate per vertex (N, 2; u right, v up, as OBJ, glTF after its
    flip, and USD's st have it). A vertex seen with two UVs is two vertices.

    ``primitives``: the shapes (box, cylinder, ...) whose fixed tessellations end the mesh,
    in order (:mod:`.primitives`); the vertices and faces before them are the mesh's own
    (:meth:`remainder`). Writers whose format has the shape write the shape.

    ``colors``: a visual of several colours (a robot link's visuals each with its own
    material) as runs (face count, RGBA) over the faces in order, summing to their number;
    empty: one colour, the part's (:meth:`color_pieces`).

    ``placements``: stretches of its own triangles that are one mesh placed (:class:`Placement`,
    :meth:`placed`); kept through :meth:`transformed`, :meth:`remainder` and
    :meth:`concatenate`, dropped by everything else that makes a new mesh."""

    vertices: np.ndarray
    faces: np.ndarray
    uv: np.ndarray | None = None
    primitives: tuple[Primitive, ...] = ()
    colors: tuple[tuple[int, RGBA], ...] = ()
    placements: tuple[Placement, ...] = ()

    def __post_init__(self) -> None:
        self.vertices = np.ascontiguousarray(self.vertices, dtype=np.float64).reshape(-1, 3)
        self.faces = np.ascontiguousarray(self.faces, dtype=np.int64).reshape(-1, 3)
        self.primitives = tuple(self.primitives)
        self.colors = tuple((int(n), tuple(float(c) for c in rgba)) for n, rgba in self.colors)
        if self.colors and (sum(n for n, _ in self.colors) != len(self.faces)
                            or any(n <= 0 or len(rgba) != 4 or not all(0.0 <= c <= 1.0
                                                                       for c in rgba)
                                   for n, rgba in self.colors)):
            raise ModelError("mesh", f"colour runs {[n for n, _ in self.colors]} must be "
                             f"positive face counts summing to {len(self.faces)} faces, "
                             "each with an RGBA in [0, 1]")
        if self.uv is not None:
            self.uv = np.ascontiguousarray(self.uv, dtype=np.float64).reshape(-1, 2)
            if len(self.uv) != len(self.vertices):
                raise ModelError("mesh", f"{len(self.uv)} texture coordinates for "
                                 f"{len(self.vertices)} vertices")

    @classmethod
    def placed(cls, asset: Mesh, pose: np.ndarray | None = None) -> Mesh:
        """``asset`` moved by the rigid ``pose`` (None: where it is), saying so
        (:attr:`placements`): an asset used several times is written once where a format
        can place it. The asset's own vertices are kept exactly where it is not moved."""
        if asset.primitives or asset.placements:
            return asset if pose is None else asset.transformed(pose)
        moved = asset if pose is None else asset.transformed(pose)
        pose = np.eye(4) if pose is None else np.asarray(pose, dtype=np.float64)
        return cls(moved.vertices, moved.faces, moved.uv, colors=moved.colors,
                   placements=(Placement(asset, pose, 0, 0),))

    @classmethod
    def of_primitive(cls, primitive: Primitive) -> Mesh:
        """The shape's fixed tessellation, the shape kept."""
        vertices, faces = primitive.tessellation()
        return cls(vertices, faces, primitives=(primitive,))

    @property
    def primitive(self) -> Primitive | None:
        """The one shape this mesh is, or None (a mesh of its own, or several shapes)."""
        if len(self.primitives) != 1:
            return None
        return self.primitives[0] if self._primitive_counts() == (
            len(self.vertices), len(self.faces)) else None

    def _primitive_counts(self) -> tuple[int, int]:
        counts = [p.counts() for p in self.primitives]
        return sum(c[0] for c in counts), sum(c[1] for c in counts)

    def remainder(self) -> Mesh | None:
        """The mesh without its primitives' tessellations (None when nothing is left)."""
        if not self.primitives:
            return self
        nv, nf = self._primitive_counts()
        kept_v, kept_f = len(self.vertices) - nv, len(self.faces) - nf
        if kept_f <= 0:
            return None
        uv = None if self.uv is None else self.uv[:kept_v]
        return Mesh(self.vertices[:kept_v], self.faces[:kept_f], uv,
                    colors=_runs_upto(self.colors, kept_f),
                    placements=tuple(p for p in self.placements if p.face_end <= kept_f))

    def face_color_runs(self) -> list[tuple[int, int, RGBA]]:
        """(first face, end face, RGBA) of each colour run ([] for a mesh of one colour)."""
        out, start = [], 0
        for n, rgba in self.colors:
            out.append((start, start + n, rgba))
            start += n
        return out

    def color_pieces(self) -> list[tuple[Mesh, RGBA | None]]:
        """The mesh's own faces (its shapes left out) cut at its colour runs, each with the
        vertices its faces use, in order: [(the remainder, None)] for a mesh of one colour
        (None: the part's colour), [] when only shapes are left."""
        cached = self.__dict__.get("_color_pieces")  # (every writer asks, some per part)
        if cached is not None:
            return list(cached)
        own = self.remainder()
        out = [] if own is None else [(own, None)] if not own.colors else []
        for start, end, rgba in own.face_color_runs() if own is not None else ():
            faces = own.faces[start:end]
            low, high = int(faces.min()), int(faces.max()) + 1
            used = np.zeros(high - low, dtype=bool)
            used[(faces - low).ravel()] = True
            index = np.flatnonzero(used) + low  # the vertices its faces use, in order
            remap = np.cumsum(used) - 1
            out.append((Mesh(own.vertices[index], remap[faces - low],
                             None if own.uv is None else own.uv[index]), rgba))
        self.__dict__["_color_pieces"] = tuple(out)
        return out

    def shape_colors(self) -> list[RGBA | None]:
        """Each shape's colour (its tessellation's run), None for a mesh of one colour."""
        if not self.colors:
            return [None] * len(self.primitives)
        runs, out = self.face_color_runs(), []
        first = len(self.faces) - self._primitive_counts()[1]
        for p in self.primitives:
            out.append(next(rgba for start, end, rgba in runs if start <= first < end))
            first += p.counts()[1]
        return out

    def digest(self) -> str:
        """A content hash (used for caching collision decompositions and naming files)."""
        h = hashlib.sha256()
        h.update(self.vertices.tobytes())
        h.update(self.faces.tobytes())
        return h.hexdigest()

    def transformed(self, transform: np.ndarray) -> Mesh:
        """The mesh moved by a rigid ``transform`` (its shapes with it; a mirroring transform
        keeps the triangles only)."""
        transform = np.asarray(transform, dtype=np.float64)
        v = self.vertices @ transform[:3, :3].T + transform[:3, 3]
        rigid = np.linalg.det(transform[:3, :3]) > 0
        shapes = tuple(p.transformed(transform) for p in self.primitives) if rigid else ()
        placements = tuple(p.shifted(0, 0, transform) for p in self.placements) \
            if rigid else ()
        return Mesh(v, self.faces.copy(), None if self.uv is None else self.uv.copy(), shapes,
                    self.colors, placements)

    def bounds(self) -> np.ndarray:
        return np.stack(corner_bounds(self.vertices))

    def to_trimesh(self):
        import trimesh

        return trimesh.Trimesh(self.vertices, self.faces, process=False)

    @classmethod
    def from_trimesh(cls, mesh) -> Mesh:
        return cls(np.asarray(mesh.vertices), np.asarray(mesh.faces))

    @staticmethod
    def join_colored(pieces: list[Mesh], runs: list[list[tuple[int, RGBA | None]]]) -> Mesh:
        """The pieces of a visual read from a file (each with its colour runs over its
        faces, a colour None where it has none) as one mesh (:meth:`concatenate`): with
        colour runs where every face has a colour and they differ; one piece keeps its
        faces' order, of several a piece of several colours is cut into one per run."""
        return _join_colored(pieces, runs)

    @staticmethod
    def concatenate(meshes: list[Mesh], colors: list[RGBA] | None = None) -> Mesh:
        """One mesh of all; texture coordinates kept only when every mesh has them. The
        meshes' own triangles come first, then every shape's tessellation in order, so the
        same meshes and shapes give the same mesh whatever order a file lists them in.
        ``colors``: one per mesh; where they differ the result has colour runs, its own
        triangles grouped by colour (in the order the colours first come), so a file that
        writes one piece per colour reads back the same mesh."""
        if colors is not None and len({tuple(c) for c in colors}) > 1:
            return _concatenate_colored(meshes, [tuple(float(x) for x in c) for c in colors])
        own = [m.remainder() for m in meshes]
        own = [m for m in own if m is not None]
        shapes = tuple(p for m in meshes for p in m.primitives)
        pieces = own + [Mesh(*p.tessellation()) for p in shapes]
        verts, faces, placements, offset, face_offset = [], [], [], 0, 0
        for m in pieces:
            verts.append(m.vertices)
            faces.append(m.faces + offset)
            placements += [p.shifted(offset, face_offset) for p in m.placements]
            offset += len(m.vertices)
            face_offset += len(m.faces)
        if not verts:
            return Mesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64))
        uv = None
        if all(m.uv is not None for m in pieces):
            uv = np.concatenate([m.uv for m in pieces])
        return Mesh(np.concatenate(verts), np.concatenate(faces), uv, shapes,
                    placements=tuple(placements))


def _join_colored(pieces: list[Mesh], runs: list[list[tuple[int, RGBA | None]]]) -> Mesh:
    """:meth:`Mesh.join_colored`."""
    colours = [c for piece in runs for _, c in piece]
    if None in colours or len(set(colours)) < 2:
        return Mesh.concatenate(pieces)
    if len(pieces) == 1:  # its faces in their order, the runs over them
        one = pieces[0]
        return Mesh(one.vertices, one.faces, one.uv, one.primitives,
                    _runs_upto(runs[0], len(one.faces)))
    flat: list[tuple[Mesh, RGBA]] = []
    for piece, piece_runs in zip(pieces, runs, strict=True):
        if len(piece_runs) == 1:
            flat.append((piece, piece_runs[0][1]))
        else:  # (its faces' own vertices each: a file written a piece per colour)
            flat += Mesh(piece.vertices, piece.faces, piece.uv,
                         colors=piece_runs).color_pieces()
    return Mesh.concatenate([m for m, _ in flat], [c for _, c in flat])


def _runs_upto(runs, n_faces: int) -> tuple[tuple[int, RGBA], ...]:
    """Colour runs cut to the first ``n_faces`` faces (neighbouring runs of one colour
    merged)."""
    out: list[tuple[int, RGBA]] = []
    left = n_faces
    for n, rgba in runs:
        take = min(n, left)
        if take <= 0:
            break
        if out and out[-1][1] == rgba:
            out[-1] = (out[-1][0] + take, rgba)
        else:
            out.append((take, rgba))
        left -= take
    return tuple(out) if len(out) > 1 else ()


def _concatenate_colored(meshes: list[Mesh], colors: list[RGBA]) -> Mesh:
    """:meth:`Mesh.concatenate` of meshes of several colours, each mesh one colour."""
    order: dict[RGBA, int] = {}
    for c in colors:
        order.setdefault(c, len(order))
    own = sorted(((m.remainder(), c) for m, c in zip(meshes, colors, strict=True)),
                 key=lambda mc: order[mc[1]])  # stable: a colour's pieces in file order
    own = [(m, c) for m, c in own if m is not None]
    shaped = [(p, c) for m, c in zip(meshes, colors, strict=True) for p in m.primitives]
    pieces = own + [(Mesh(*p.tessellation()), c) for p, c in shaped]
    joined = Mesh.concatenate([m for m, _ in pieces])
    runs: list[tuple[int, RGBA]] = []
    for m, c in pieces:
        if len(m.faces) == 0:
            continue
        if runs and runs[-1][1] == c:
            runs[-1] = (runs[-1][0] + len(m.faces), c)
        else:
            runs.append((len(m.faces), c))
    shapes = tuple(p for p, _ in shaped)
    return Mesh(joined.vertices, joined.faces, joined.uv, shapes,
                tuple(runs) if len(runs) > 1 else (), joined.placements)


IMAGE_SUFFIXES = {"image/png": ".png", "image/jpeg": ".jpg"}


@dataclass(eq=False)
class Texture:
    """An image on a part's visual mesh, through the mesh's texture coordinates: the encoded
    file (PNG or JPEG) as read, so every format writes the very same pixels, never
    re-encoded. ``name`` is the stem its file gets next to the meshes."""

    image: bytes
    mime: str
    name: str

    def __post_init__(self) -> None:
        if self.mime not in IMAGE_SUFFIXES:
            raise ModelError(f"texture {self.name!r}", f"image type {self.mime!r}: PNG or JPEG "
                             "only (what glTF, USD and MuJoCo all read)")

    @property
    def suffix(self) -> str:
        return IMAGE_SUFFIXES[self.mime]

    @property
    def digest(self) -> str:
        """SHA-256 of the encoded image, hex (computed once: files are named by it)."""
        cached = self.__dict__.get("_digest")
        if cached is None:
            import hashlib

            cached = self.__dict__["_digest"] = hashlib.sha256(self.image).hexdigest()
        return cached

    @staticmethod
    def sniff(data: bytes) -> str | None:
        """The MIME type of PNG or JPEG bytes, from their signature; None for anything else."""
        if data.startswith(b"\x89PNG\r\n\x1a\n"):
            return "image/png"
        if data.startswith(b"\xff\xd8\xff"):
            return "image/jpeg"
        return None


@dataclass(eq=False)
class Inertial:
    """Mass (kg), centre of mass (m, part frame) and inertia tensor about the centre of mass
    (kg m^2, axes of the part frame)."""

    mass: float
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.eye(3) * 1e-6)

    def __post_init__(self) -> None:
        self.mass = float(self.mass)
        self.com = np.asarray(self.com, dtype=np.float64).reshape(3)
        self.inertia = np.asarray(self.inertia, dtype=np.float64).reshape(3, 3)

    def principal(self) -> tuple[np.ndarray, np.ndarray]:
        """Principal moments (ascending) and a right-handed rotation whose columns are the
        principal axes in the part frame."""
        moments, axes = np.linalg.eigh(0.5 * (self.inertia + self.inertia.T))
        if np.linalg.det(axes) < 0:
            axes[:, 2] *= -1
        return moments, axes


@dataclass
class Limits:
    """Joint range (rad or m) and, where known, effort (N m or N) and velocity limits."""

    lower: float
    upper: float
    effort: float | None = None
    velocity: float | None = None


@dataclass
class DriveLimits:
    """Effort (N m or N) and velocity (rad/s or m/s) limits of a joint without a range: a
    continuous joint (URDF's ``<limit effort velocity>`` on one), a slide without limits.
    A joint with a range holds them in its :class:`Limits`."""

    effort: float | None = None
    velocity: float | None = None


@dataclass
class Dynamics:
    """Joint dynamics in SI units (angular joints: per radian).

    ``friction`` is Coulomb (dry) friction, the MJCF ``frictionloss``; ``stiffness`` is a
    spring pulling toward ``spring_ref``; ``armature`` is reflected rotor inertia.
    """

    damping: float = 0.0
    friction: float = 0.0
    stiffness: float = 0.0
    spring_ref: float = 0.0
    armature: float = 0.0

    def is_zero(self) -> bool:
        return not any((self.damping, self.friction, self.stiffness, self.armature))


@dataclass
class Mimic:
    """A joint coupled to another (URDF ``<mimic>``, MJCF joint equality, NewtonMimicAPI):
    q = multiplier * q[joint] + offset (offset in rad or m). The coupling is physics, not
    kinematics: poses are still given for every joint value."""

    joint: str  # the leader
    multiplier: float = 1.0
    offset: float = 0.0


class DriveKind(StrEnum):
    POSITION = "position"  # holds a position target: stiffness (and damping)
    VELOCITY = "velocity"  # holds a velocity target: damping only
    EFFORT = "effort"  # applies the target as a force (a motor): no gains


@dataclass
class Drive:
    """An actuator on a joint's one axis (MJCF ``<position>``, ``<velocity>``, ``<motor>``;
    USD ``PhysicsDriveAPI``), every value at the joint in SI units, angles in radians:
    the force it applies (N m for an angular joint, N for a slide), clamped to
    ``force_limit`` when set, is

    - position: ``stiffness * (target - q) - damping * qdot``
      (stiffness N m/rad or N/m, damping N m s/rad or N s/m);
    - velocity: ``damping * (target - qdot)`` (target rad/s or m/s);
    - effort: ``target`` itself (a motor's command).

    ``target`` is the command the drive starts with (USD's target; MuJoCo's ctrl, 0 unless
    set); ``target_range`` bounds the command (MuJoCo's ctrlrange, in the same joint units).
    ``name`` and ``gear`` are the MJCF actuator's (its name; the ratio its ``ctrl`` is in:
    ctrl = gear * target, and the values above have it folded in), kept so that an MJCF
    file comes back with the same actuator names and command scale."""

    kind: DriveKind
    stiffness: float = 0.0
    damping: float = 0.0
    target: float = 0.0
    force_limit: float | None = None
    target_range: tuple[float, float] | None = None
    name: str | None = None
    gear: float = 1.0

    def __post_init__(self) -> None:
        self.kind = DriveKind(self.kind)
        self.stiffness, self.damping = float(self.stiffness), float(self.damping)
        self.target, self.gear = float(self.target), float(self.gear)
        if self.force_limit is not None:
            self.force_limit = float(self.force_limit)
        if self.target_range is not None:
            self.target_range = (float(self.target_range[0]), float(self.target_range[1]))

    def problem(self) -> str | None:
        """What makes the drive not one of its kind (None when it is one)."""
        values = [self.stiffness, self.damping, self.target, self.gear,
                  *(() if self.force_limit is None else (self.force_limit,)),
                  *(self.target_range or ())]
        if not all(math.isfinite(v) for v in values):
            return f"drive values must be finite, got {values}"
        if self.stiffness < 0 or self.damping < 0:
            return f"drive stiffness and damping must be >= 0, got {self.stiffness}, " \
                   f"{self.damping}"
        if self.kind is DriveKind.POSITION and self.stiffness <= 0:
            return "a position drive needs a stiffness > 0"
        if self.kind is DriveKind.VELOCITY and (self.stiffness != 0 or self.damping <= 0):
            return "a velocity drive has no stiffness and a damping > 0"
        if self.kind is DriveKind.EFFORT and (self.stiffness or self.damping):
            return "an effort drive has no stiffness nor damping"
        if self.force_limit is not None and self.force_limit <= 0:
            return f"drive force limit must be > 0, got {self.force_limit}"
        if self.target_range is not None and self.target_range[0] > self.target_range[1]:
            return f"drive target range {list(self.target_range)} is inverted"
        if self.gear == 0:
            return "drive gear must not be 0"
        return None

    def differences(self, other: Drive, tol: float) -> list[str]:
        """What differs beyond ``tol`` (relative and absolute) between two drives."""
        out = []
        if self.kind != other.kind:
            out.append(f"kind {self.kind.value} != {other.kind.value}")
        if self.name != other.name:
            out.append(f"name {self.name!r} != {other.name!r}")
        for attr in ("stiffness", "damping", "target", "gear", "force_limit", "target_range"):
            u, v = getattr(self, attr), getattr(other, attr)
            if (u is None) != (v is None) or (u is not None and not np.allclose(
                    u, v, atol=tol, rtol=tol)):
                out.append(f"{attr} {u} != {v}")
        return out


@dataclass(eq=False)
class Joint:
    name: str
    type: JointType
    parent: str
    child: str
    origin: np.ndarray = field(default_factory=lambda: np.eye(4))
    axis: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    # None: unbounded (a continuous joint; a prismatic one slides freely, as an MJCF slide
    # without a range, e.g. a planar walker's root); revolute joints always have limits.
    limits: Limits | None = None
    dynamics: Dynamics = field(default_factory=Dynamics)
    state: float = 0.0  # the joint value observed at capture time
    mimic: Mimic | None = None
    # effort and velocity limits where ``limits`` is None (a joint without a range)
    drive_limits: DriveLimits | None = None
    # a ball joint's cone (rad): the largest rotation from its rest, about any axis (MuJoCo's
    # range; 0: the ball held at its rest, as MuJoCo compiles a limited ball without a range);
    # ball range); None: free
    cone_limit: float | None = None
    # the actuator driving the joint's one axis (a revolute, continuous or prismatic joint)
    drive: Drive | None = None

    @property
    def effort_limit(self) -> float | None:
        """The effort limit (N m or N), from :attr:`limits` or :attr:`drive_limits`."""
        held = self.limits if self.limits is not None else self.drive_limits
        return None if held is None else held.effort

    @property
    def velocity_limit(self) -> float | None:
        """The velocity limit (rad/s or m/s), from :attr:`limits` or :attr:`drive_limits`."""
        held = self.limits if self.limits is not None else self.drive_limits
        return None if held is None else held.velocity

    def __post_init__(self) -> None:
        self.type = JointType(self.type)
        self.origin = np.asarray(self.origin, dtype=np.float64).reshape(4, 4)
        self.axis = np.asarray(self.axis, dtype=np.float64).reshape(3)
        self.state = float(self.state)

    def motion(self, q: float) -> np.ndarray:
        """Transform of the child frame relative to its q = 0 pose."""
        if self.type.angular:
            return tf.make(rotation=tf.axis_angle_matrix(self.axis, q))
        if self.type is JointType.PRISMATIC:
            return tf.make(translation=self.axis * q)
        return np.eye(4)

    def transform(self, q: float) -> np.ndarray:
        """Pose of the child frame in the parent frame at joint value ``q``."""
        return self.origin @ self.motion(q)


# The material maps beside the base colour, as glTF 2.0 defines them (the formats map them
# to theirs): metallic_roughness (G roughness, B metallic, linear), normal (tangent space,
# +Y up as OpenGL), occlusion (R, linear), emissive (sRGB colour).
PBR_MAPS = ("metallic_roughness", "normal", "occlusion", "emissive")


@dataclass(eq=False)
class Part:
    name: str
    visual: Mesh | None = None
    collision: list[Mesh] = field(default_factory=list)
    inertial: Inertial | None = None
    color: tuple[float, float, float, float] = DEFAULT_COLOR
    texture: Texture | None = None  # the colour image on the visual mesh (needs its UVs)
    maps: dict[str, Texture] = field(default_factory=dict)  # PBR_MAPS role -> image

    def __post_init__(self) -> None:
        self.color = tuple(float(c) for c in self.color)
        unknown = sorted(set(self.maps) - set(PBR_MAPS))
        if unknown:
            raise ModelError(f"part {self.name!r}", f"unknown material maps {unknown}: "
                             f"one of {', '.join(PBR_MAPS)}")
        if (self.texture is not None or self.maps) and (self.visual is None
                                                        or self.visual.uv is None):
            raise ModelError(f"part {self.name!r}", "a texture needs a visual mesh with "
                             "texture coordinates")

    @property
    def color_not_first_run(self) -> bool:
        """Whether the part's one colour (what a renderer of one colour per part draws: for a
        mesh file's colours, their mean) is not its visual's first colour run, which is the
        colour a reader of a format of colours per geometry gives the part: such a format
        carries it beside the runs."""
        return self.visual is not None and bool(self.visual.colors) \
            and self.color != self.visual.colors[0][1]


@dataclass(eq=False)
class ArticulatedObject:
    """Parts connected by joints in one tree with a single, fixed root. A floating base is
    a root part for the world (often massless, named ``world``) and a floating joint to it.

    ``metadata`` holds JSON-serialisable facts about the object (category, source file, ...);
    exporters that have a place for free data keep it namespaced.
    """

    name: str
    parts: list[Part] = field(default_factory=list)
    joints: list[Joint] = field(default_factory=list)
    metadata: dict[str, Any] = field(default_factory=dict)

    # -- lookups (each scans a list; a walk over the whole tree takes ``tree()``) ----------
    def tree(self) -> Tree:
        """The parts and joints indexed by name once (:class:`Tree`)."""
        children: dict[str, list[Joint]] = {p.name: [] for p in self.parts}
        for j in self.joints:
            children.setdefault(j.parent, []).append(j)
        return Tree({p.name: p for p in self.parts}, {j.name: j for j in self.joints},
                    {j.child: j for j in self.joints}, children)

    def part(self, name: str) -> Part:
        for p in self.parts:
            if p.name == name:
                return p
        raise NameNotFoundError(f"no part named {name!r} in {self.name!r}")

    def joint(self, name: str) -> Joint:
        for j in self.joints:
            if j.name == name:
                return j
        raise NameNotFoundError(f"no joint named {name!r} in {self.name!r}")

    def parent_joint(self, part_name: str) -> Joint | None:
        for j in self.joints:
            if j.child == part_name:
                return j
        return None

    def child_joints(self, part_name: str) -> list[Joint]:
        return [j for j in self.joints if j.parent == part_name]

    @property
    def root(self) -> Part:
        children = {j.child for j in self.joints}
        roots = [p for p in self.parts if p.name not in children]
        if len(roots) != 1:
            raise ModelError(f"object {self.name!r}", f"expected one root part, found {len(roots)}")
        return roots[0]

    @property
    def movable_joints(self) -> list[Joint]:
        """The joints posed by one value (ball and floating joints are not among them)."""
        return [j for j in self.joints if j.type.movable]

    def joints_in_tree_order(self, tree: Tree | None = None) -> Iterator[Joint]:
        """Joints in depth-first pre-order from the root (children in declaration order):
        every joint comes after its parent's joint, as in Pinocchio (``tree``: the object's
        :class:`Tree` where the caller has built it)."""
        children = (tree or self.tree()).children
        stack = list(reversed(children[self.root.name]))
        while stack:
            joint = stack.pop()
            yield joint
            stack.extend(reversed(children.get(joint.child, ())))

    def parts_in_tree_order(self) -> list[Part]:
        tree = self.tree()  # one index for both walks
        order = [self.root.name] + [j.child for j in self.joints_in_tree_order(tree)]
        return [tree.parts[n] for n in order]

    def frame_parts(self) -> set[str]:
        """Frames: parts with no mass and no geometry, fixed to their parent, with no part
        hanging from them (an MJCF site, a URDF frame-only link, a USD Xform in a body)."""
        tree = self.tree()
        return {j.child for j in self.joints
                if j.type is JointType.FIXED and not tree.children[j.child]
                and _is_frame(tree.parts[j.child])}

    def observed_configuration(self) -> dict[str, float]:
        return {j.name: j.state for j in self.movable_joints}

    def total_mass(self) -> float:
        return sum(p.inertial.mass for p in self.parts if p.inertial is not None)


@dataclass(frozen=True)
class Tree:
    """An object's parts and joints indexed by name once (``ArticulatedObject.tree()``), for
    work that walks the whole tree: the object's own lookups scan its lists, which over every
    part grows with the square of the parts (a flex of 3881 parts). A snapshot: build it
    again after changing the object's parts or joints."""

    parts: dict[str, Part]
    joints: dict[str, Joint]
    parent: dict[str, Joint]  # part name -> its parent joint (the root has none)
    children: dict[str, list[Joint]]  # part name -> its child joints, in declaration order


def _is_frame(part: Part) -> bool:
    return part.inertial is None and part.visual is None and not part.collision


# -- names -----------------------------------------------------------------------------------
def sanitize_name(raw: str, taken: set[str] | None = None) -> str:
    """A name valid in every format (an identifier: USD prim names are the strictest), made
    unique against ``taken`` by a numeric suffix. Importers call it once; exporters never
    rename."""
    name = re.sub(r"[^A-Za-z0-9_]", "_", raw.strip()) or "unnamed"
    if not re.match(r"[A-Za-z_]", name[0]):
        name = "_" + name
    if taken is not None:
        base, k = name, 1
        while name in taken:
            name = f"{base}_{k}"
            k += 1
        taken.add(name)
    return name


# -- validation ------------------------------------------------------------------------------
def _finite(values, element: str, what: str) -> None:
    if type(values) is float and math.isfinite(values):  # (a joint's dynamics: no array)
        return
    arr = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise ModelError(element, f"{what} is not finite: {arr.tolist()}")


_HOMOGENEOUS_ROW = np.array([0.0, 0.0, 0.0, 1.0])  # a rigid transform's last row


def validate_inertial(inertial: Inertial, element: str, tol: float = 1e-9) -> None:
    if not math.isfinite(inertial.mass) or inertial.mass <= 0:
        raise ModelError(element, f"mass must be positive and finite, got {inertial.mass}")
    _finite(inertial.com, element, "centre of mass")
    _finite(inertial.inertia, element, "inertia")
    inertia = inertial.inertia
    scale = max(float(np.abs(inertia).max()), 1e-30)
    if not tf.allclose_to_finite(inertia, inertia.T, atol=1e-9 * scale):  # (finite: above)
        raise ModelError(element, "inertia tensor is not symmetric")
    moments = np.linalg.eigvalsh(inertia)
    if moments[0] <= 0:
        raise ModelError(
            element, f"inertia tensor is not positive definite (principal moments {moments.tolist()})"
        )
    a, b, c = moments
    if a + b < c * (1 - tol) - tol * scale:
        raise ModelError(
            element,
            f"principal moments {moments.tolist()} violate the triangle inequality (A + B >= C)",
        )


def validate_mesh(mesh: Mesh, element: str) -> None:
    if len(mesh.vertices) == 0 or len(mesh.faces) == 0:
        raise ModelError(element, "mesh is empty")
    _finite(mesh.vertices, element, "mesh vertices")
    if mesh.faces.min() < 0 or mesh.faces.max() >= len(mesh.vertices):
        raise ModelError(element, "mesh face indices out of range")
    for k, shape in enumerate(mesh.primitives):
        problem = shape.problem()
        if problem is not None:
            raise ModelError(f"{element} shape {k}", problem)
    if mesh.primitives:
        nv, nf = mesh._primitive_counts()
        own_v, own_f = len(mesh.vertices) - nv, len(mesh.faces) - nf
        if own_v < 0 or own_f < 0 or (own_f and mesh.faces[:own_f].max() >= own_v):
            raise ModelError(element, "the mesh does not end with its shapes' tessellations")


def metadata_json(obj: ArticulatedObject, **dumps_options: Any) -> str:
    """``obj.metadata`` as JSON text, as every format stores it; the same ModelError for
    every format when it cannot be (NaN, infinity, a value JSON has no type for)."""
    import json

    try:
        return json.dumps(obj.metadata, allow_nan=False, **dumps_options)
    except (TypeError, ValueError) as e:
        raise ModelError(f"object {obj.name!r} metadata",
                         f"not JSON (finite numbers, strings, lists, dicts only): {e}") from e


# the object a ``validated`` block has checked: validate() of it returns at once
_VALIDATED: ContextVar[ArticulatedObject | None] = ContextVar("validated", default=None)


@contextmanager
def validated(obj: ArticulatedObject) -> Iterator[ArticulatedObject]:
    """Validate ``obj`` once for the block: inside it, :func:`validate` of this same object
    returns at once. Each writer validates what it is given (a library call needs that);
    writing one object in several formats (``formats.write_formats``) validates it once
    this way. The block must not change ``obj``."""
    validate(obj)
    token = _VALIDATED.set(obj)
    try:
        yield obj
    finally:
        _VALIDATED.reset(token)


def validate(obj: ArticulatedObject) -> ArticulatedObject:
    """Check the whole object; raise :class:`ModelError` at the first problem. Returns ``obj``
    (at once inside a :func:`validated` block of the same object)."""
    if _VALIDATED.get() is obj:
        return obj
    if not NAME_PATTERN.match(obj.name or ""):
        raise ModelError(f"object {obj.name!r}", "name must be an identifier ([A-Za-z_][A-Za-z0-9_]*)")
    metadata_json(obj)
    if not obj.parts:
        raise ModelError(f"object {obj.name!r}", "has no parts")
    seen: set[str] = set()
    for p in obj.parts:
        el = f"part {p.name!r}"
        if not NAME_PATTERN.match(p.name or ""):
            raise ModelError(el, "name must be an identifier ([A-Za-z_][A-Za-z0-9_]*)")
        if p.name in seen:
            raise ModelError(el, "duplicate part name")
        seen.add(p.name)
        if len(p.color) != 4 or not all(0.0 <= c <= 1.0 for c in p.color):
            raise ModelError(el, f"colour must be RGBA in [0, 1], got {list(p.color)}")
        if p.visual is not None:
            validate_mesh(p.visual, el + " visual")
        for k, piece in enumerate(p.collision):
            validate_mesh(piece, f"{el} collision piece {k}")
        if p.inertial is not None:
            validate_inertial(p.inertial, el)

    joint_names: set[str] = set()
    drive_names: set[str] = set()
    child_of: dict[str, str] = {}
    for j in obj.joints:
        el = f"joint {j.name!r}"
        if not NAME_PATTERN.match(j.name or ""):
            raise ModelError(el, "name must be an identifier ([A-Za-z_][A-Za-z0-9_]*)")
        if j.name in joint_names:
            raise ModelError(el, "duplicate joint name")
        joint_names.add(j.name)
        for role, part in (("parent", j.parent), ("child", j.child)):
            if part not in seen:
                raise ModelError(el, f"{role} part {part!r} does not exist")
        if j.parent == j.child:
            raise ModelError(el, f"joins part {j.child!r} to itself")
        if j.child in child_of:
            raise ModelError(
                el, f"part {j.child!r} already has parent joint {child_of[j.child]!r} (not a tree)"
            )
        child_of[j.child] = j.name
        _finite(j.origin, el, "origin")
        if not tf.allclose_to_finite(j.origin[3], _HOMOGENEOUS_ROW) \
                or not tf.is_rotation(j.origin[:3, :3]):
            raise ModelError(el, "origin is not a rigid transform (rotation must be orthonormal)")
        _finite(j.axis, el, "axis")
        norm = float(np.linalg.norm(j.axis))
        if j.type.movable and norm < 1e-12:
            raise ModelError(el, "axis has zero length")
        if j.type.movable and abs(norm - 1.0) > AXIS_UNIT_TOLERANCE:
            raise ModelError(el, f"axis must be a unit vector, has length {norm:.9g}")
        _finite(j.state, el, "state")
        d = j.dynamics
        for attr in ("damping", "friction", "stiffness", "spring_ref", "armature"):
            _finite(getattr(d, attr), el, attr)
        for attr in ("damping", "friction", "stiffness", "armature"):
            if getattr(d, attr) < 0:
                raise ModelError(el, f"{attr} must be >= 0, got {getattr(d, attr)}")
        if j.type is JointType.REVOLUTE and j.limits is None:
            raise ModelError(el, "a revolute joint needs limits (continuous has none)")
        if j.type in (JointType.REVOLUTE, JointType.PRISMATIC) and j.limits is not None:
            lim = j.limits
            _finite([lim.lower, lim.upper], el, "limits")
            if lim.lower > lim.upper:
                raise ModelError(el, f"lower limit {lim.lower} > upper limit {lim.upper}")
            for attr in ("effort", "velocity"):
                v = getattr(lim, attr)
                if v is not None and (not math.isfinite(v) or v < 0):
                    raise ModelError(el, f"{attr} limit must be finite and >= 0, got {v}")
            slack = 1e-9 * max(1.0, abs(lim.lower), abs(lim.upper))
            if not lim.lower - slack <= j.state <= lim.upper + slack:
                raise ModelError(
                    el, f"observed state {j.state} is outside the limits [{lim.lower}, {lim.upper}]"
                )
        elif j.limits is not None:
            raise ModelError(el, f"a {j.type.value} joint takes no limits")
        if j.cone_limit is not None:
            if j.type is not JointType.BALL:
                raise ModelError(el, f"a {j.type.value} joint takes no cone limit (a ball's)")
            _finite(j.cone_limit, el, "cone limit")
            if j.cone_limit < 0:  # (0: held at its rest, MuJoCo's limited ball of no range)
                raise ModelError(el, f"cone limit must be >= 0 rad, got {j.cone_limit}")
        if j.drive_limits is not None:
            if j.limits is not None or j.type not in (JointType.CONTINUOUS,
                                                      JointType.PRISMATIC):
                raise ModelError(el, "drive_limits are for a continuous joint or a slide "
                                     "without a range (others hold them in limits)")
            for attr in ("effort", "velocity"):
                v = getattr(j.drive_limits, attr)
                if v is not None and (not math.isfinite(v) or v < 0):
                    raise ModelError(el, f"{attr} limit must be finite and >= 0, got {v}")
        if not j.type.movable and j.state != 0.0:
            raise ModelError(el, f"a {j.type.value} joint has no state")
        if j.drive is not None:
            if not j.type.movable:
                raise ModelError(el, f"a {j.type.value} joint takes no drive (a drive moves "
                                     "one axis: revolute, continuous or prismatic)")
            problem = j.drive.problem()
            if problem is not None:
                raise ModelError(el, problem)
            if j.drive.name is not None:
                if not j.drive.name or j.drive.name in drive_names:
                    raise ModelError(el, f"drive name {j.drive.name!r} is empty or already "
                                         "another joint's drive's")
                drive_names.add(j.drive.name)

    by_name = {j.name: j for j in obj.joints}
    for j in obj.joints:
        if j.mimic is not None:
            _validate_mimic(j, by_name)

    roots = [p.name for p in obj.parts if p.name not in child_of]
    if len(roots) != 1:
        detail = f"parts without a parent joint: {roots}" if roots else "every part has a parent (a cycle)"
        raise ModelError(f"object {obj.name!r}", f"expected exactly one root part; {detail}")
    tree = obj.tree()
    reached = {roots[0]}
    frontier = [roots[0]]
    while frontier:
        name = frontier.pop()
        for j in tree.children[name]:
            if j.child not in reached:
                reached.add(j.child)
                frontier.append(j.child)
    if reached != seen:
        cyc = sorted(seen - reached)
        raise ModelError(f"object {obj.name!r}", f"joints form a cycle through parts {cyc}")

    # A floating body hangs from the world: MuJoCo allows free joints on top-level bodies only.
    for j in obj.joints:
        if j.type is JointType.FLOATING and j.parent != roots[0]:
            raise ModelError(f"joint {j.name!r}", f"a floating joint must hang from the root "
                             f"part {roots[0]!r} (the world), not from {j.parent!r}")
    # A joint that moves must move something with mass (MuJoCo and Pinocchio both need it).
    for j in obj.joints:
        if j.type is not JointType.FIXED and rigid_group_mass(tree, j.child) <= 0:
            raise ModelError(
                f"joint {j.name!r}",
                f"child part {j.child!r} (with the parts fixed to it) has no mass",
            )
    return obj


def _validate_mimic(j: Joint, by_name: dict[str, Joint]) -> None:
    el, m = f"joint {j.name!r}", j.mimic
    _finite([m.multiplier, m.offset], el, "mimic multiplier/offset")
    leader = by_name.get(m.joint)
    if leader is None:
        raise ModelError(el, f"mimics joint {m.joint!r}, which does not exist")
    if leader is j:
        raise ModelError(el, "mimics itself")
    if not (j.type.movable and leader.type.movable):
        raise ModelError(el, f"a mimic couples two one-value joints ({j.type.value} mimics "
                         f"{leader.type.value})")
    if leader.mimic is not None:
        raise ModelError(el, f"mimics {m.joint!r}, which mimics another joint itself")


def rigid_group_mass(tree: Tree, part_name: str) -> float:
    """The mass of a part and of every part fixed to it below it (``tree``: the object's
    :class:`Tree`)."""
    mass, stack = 0.0, [part_name]
    while stack:
        name = stack.pop()
        inertial = tree.parts[name].inertial
        mass += inertial.mass if inertial is not None else 0.0
        stack += [j.child for j in tree.children[name] if j.type is JointType.FIXED]
    return mass


# -- kinematics ------------------------------------------------------------------------------
def forward_kinematics(
    obj: ArticulatedObject,
    q: Mapping[str, float] | None = None,
    base: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """World pose (4x4) of every part for joint values ``q`` (by joint name; missing
    movable joints are at 0). Unknown joint names raise ``KeyError``."""
    q = dict(q or {})
    unknown = set(q) - {j.name for j in obj.movable_joints}
    if unknown:
        raise NameNotFoundError(f"unknown joint(s) {sorted(unknown)} for {obj.name!r}")
    poses = {obj.root.name: np.eye(4) if base is None else np.asarray(base, float)}
    for j in obj.joints_in_tree_order():
        poses[j.child] = poses[j.parent] @ j.transform(q.get(j.name, 0.0))
    return poses


def sample_configuration(obj: ArticulatedObject, rng: np.random.Generator) -> dict[str, float]:
    """Joint values drawn uniformly within limits (continuous joints in [-pi, pi], slides
    without limits within :data:`UNBOUNDED_SLIDE_SPAN`)."""
    out = {}
    for j in obj.movable_joints:
        if j.limits is None:
            span = UNBOUNDED_SLIDE_SPAN if j.type is JointType.PRISMATIC else np.pi
            out[j.name] = float(rng.uniform(-span, span))
        else:
            out[j.name] = float(rng.uniform(j.limits.lower, j.limits.upper))
    return out


# -- tolerance-based comparison (round-trip tests compare models, not text) -----------------
def differences(a: ArticulatedObject, b: ArticulatedObject, tol: float = 1e-6) -> list[str]:
    """Every difference between two models beyond ``tol``; an empty list means equal."""
    out: list[str] = []

    def close(x, y) -> bool:
        x, y = np.asarray(x, float), np.asarray(y, float)
        return x.shape == y.shape and bool(np.allclose(x, y, atol=tol, rtol=tol))

    if a.name != b.name:
        out.append(f"object name {a.name!r} != {b.name!r}")
    pa, pb = {p.name: p for p in a.parts}, {p.name: p for p in b.parts}
    if set(pa) != set(pb):
        out.append(f"parts differ: only in first {sorted(set(pa) - set(pb))}, "
                   f"only in second {sorted(set(pb) - set(pa))}")
    for name in sorted(set(pa) & set(pb)):
        x, y = pa[name], pb[name]
        el = f"part {name!r}"
        if not close(x.color, y.color):
            out.append(f"{el}: colour {x.color} != {y.color}")
        if (x.inertial is None) != (y.inertial is None):
            out.append(f"{el}: inertial present in only one")
        elif x.inertial is not None:
            if not close(x.inertial.mass, y.inertial.mass):
                out.append(f"{el}: mass {x.inertial.mass} != {y.inertial.mass}")
            if not close(x.inertial.com, y.inertial.com):
                out.append(f"{el}: centre of mass differs")
            if not close(x.inertial.inertia, y.inertial.inertia):
                out.append(f"{el}: inertia differs")
        out.extend(_mesh_differences(el + " visual", x.visual, y.visual, tol))
        out.extend(_texture_differences(el, x.texture, y.texture))
        for role in PBR_MAPS:
            out.extend(_texture_differences(f"{el} {role} map", x.maps.get(role),
                                            y.maps.get(role)))
        if len(x.collision) != len(y.collision):
            out.append(f"{el}: {len(x.collision)} vs {len(y.collision)} collision pieces")
        else:
            for k, (m, n) in enumerate(zip(x.collision, y.collision, strict=True)):
                out.extend(_mesh_differences(f"{el} collision {k}", m, n, tol))
    ja, jb = {j.name: j for j in a.joints}, {j.name: j for j in b.joints}
    if set(ja) != set(jb):
        out.append(f"joints differ: only in first {sorted(set(ja) - set(jb))}, "
                   f"only in second {sorted(set(jb) - set(ja))}")
    for name in sorted(set(ja) & set(jb)):
        x, y = ja[name], jb[name]
        el = f"joint {name!r}"
        for attr in ("type", "parent", "child"):
            if getattr(x, attr) != getattr(y, attr):
                out.append(f"{el}: {attr} {getattr(x, attr)!r} != {getattr(y, attr)!r}")
        if not close(x.origin, y.origin):
            out.append(f"{el}: origin differs")
        if x.type.movable and not close(x.axis, y.axis):
            out.append(f"{el}: axis {x.axis.tolist()} != {y.axis.tolist()}")
        if not close(x.state, y.state):
            out.append(f"{el}: state {x.state} != {y.state}")
        if (x.limits is None) != (y.limits is None):
            out.append(f"{el}: limits present in only one")
        elif x.limits is not None:
            for attr in ("lower", "upper", "effort", "velocity"):
                u, v = getattr(x.limits, attr), getattr(y.limits, attr)
                if (u is None) != (v is None) or (u is not None and not close(u, v)):
                    out.append(f"{el}: {attr} limit {u} != {v}")
        if (x.cone_limit is None) != (y.cone_limit is None) or (
                x.cone_limit is not None and not close(x.cone_limit, y.cone_limit)):
            out.append(f"{el}: cone limit {x.cone_limit} != {y.cone_limit}")
        if x.limits is None and y.limits is None:  # a joint without a range: drive_limits
            for attr in ("effort", "velocity"):
                u, v = getattr(x, f"{attr}_limit"), getattr(y, f"{attr}_limit")
                if (u is None) != (v is None) or (u is not None and not close(u, v)):
                    out.append(f"{el}: {attr} limit {u} != {v}")
        for attr in ("damping", "friction", "stiffness", "spring_ref", "armature"):
            u, v = getattr(x.dynamics, attr), getattr(y.dynamics, attr)
            if not close(u, v):
                out.append(f"{el}: {attr} {u} != {v}")
        if (x.mimic is None) != (y.mimic is None) or (
                x.mimic is not None and (x.mimic.joint != y.mimic.joint or not close(
                    [x.mimic.multiplier, x.mimic.offset], [y.mimic.multiplier, y.mimic.offset]))):
            out.append(f"{el}: mimic {x.mimic} != {y.mimic}")
        if (x.drive is None) != (y.drive is None):
            out.append(f"{el}: drive present in only one")
        elif x.drive is not None:
            out.extend(f"{el}: drive {d}" for d in x.drive.differences(y.drive, tol))
    return out


def _mesh_differences(el: str, x: Mesh | None, y: Mesh | None, tol: float) -> list[str]:
    if x is None or y is None:
        return [] if x is y else [f"{el}: mesh present in only one"]
    if len(x.primitives) != len(y.primitives):
        return [f"{el}: {len(x.primitives)} vs {len(y.primitives)} shapes (box, cylinder, ...)"]
    shapes = [f"{el} shape {k}: {d}" for k, (p, q) in enumerate(zip(x.primitives, y.primitives,
                                                                      strict=True))
              for d in p.differences(q, tol)]
    if shapes:
        return shapes
    if x.faces.shape != y.faces.shape or x.vertices.shape != y.vertices.shape:
        return [f"{el}: mesh sizes differ ({len(x.vertices)}/{len(x.faces)} vs "
                f"{len(y.vertices)}/{len(y.faces)} vertices/faces)"]
    if not np.array_equal(x.faces, y.faces):
        return [f"{el}: mesh faces differ"]
    if not np.allclose(x.vertices, y.vertices, atol=tol, rtol=0):
        err = float(np.abs(x.vertices - y.vertices).max())
        return [f"{el}: mesh vertices differ by up to {err:.3g}"]
    if (x.uv is None) != (y.uv is None):
        return [f"{el}: texture coordinates in only one"]
    if x.uv is not None and not np.allclose(x.uv, y.uv, atol=tol, rtol=0):
        return [f"{el}: texture coordinates differ by up to "
                f"{float(np.abs(x.uv - y.uv).max()):.3g}"]
    if [n for n, _ in x.colors] != [n for n, _ in y.colors] or not all(
            np.allclose(a, b, atol=tol, rtol=0)
            for (_, a), (_, b) in zip(x.colors, y.colors, strict=True)):
        return [f"{el}: colours per face differ ({[(n, c) for n, c in x.colors]} vs "
                f"{[(n, c) for n, c in y.colors]})"]
    return []


def _texture_differences(el: str, x: Texture | None, y: Texture | None) -> list[str]:
    """Textures are equal when their images are: the same bytes, or the same pixels."""
    if x is None or y is None:
        return [] if x is y else [f"{el}: texture in only one"]
    if x.image == y.image:
        return []
    try:
        from io import BytesIO

        from PIL import Image

        a, b = (np.asarray(Image.open(BytesIO(t.image)).convert("RGBA")) for t in (x, y))
    except Exception as e:  # an image PIL cannot decode is a difference, said as such
        return [f"{el}: texture images differ and cannot be compared ({e})"]
    if a.shape != b.shape or not np.array_equal(a, b):
        return [f"{el}: texture images differ ({a.shape[1]}x{a.shape[0]} vs "
                f"{b.shape[1]}x{b.shape[0]})"]
    return []
