"""Collision pieces of different parts made not to overlap, at q = 0 and along each joint's
range, by cutting convex pieces with planes (a convex piece cut by a plane stays convex).

Source meshes interpenetrate (a PartNet handle sunk into its door, a reconstructed door a
few voxels inside its carcass), and a hull or a coarse box fills a little more than the
surface. An engine that collides such pieces pushes the parts apart from the first step,
and a format without contact exclusions (URDF) has no way to say "ignore this pair". So
every pair of pieces of two different parts is tested with the separating-axis theorem over
both pieces' face normals: when no face normal separates them, the least-overlapping axis
is the cut, and the piece that loses the smaller fraction of its volume is cut back to a
``gap`` behind the other; when either would lose most of itself (one sunk deep into the
other), the larger is carved around the smaller's oriented box instead. Pieces only shrink
(or split), so a pair once separated stays separated; a carved piece's new pieces are
checked in another pass. (Edge-edge axes are not tried: pieces that only they would
separate are cut a little although they do not touch, never left overlapping.)

Beyond q = 0, each movable joint is swept alone over its range and its child's pieces are
separated from its parent's in the same way, in their own frames: at least ``sweep``
values, and as many more as keep the child's farthest piece point within ``SWEEP_STEP`` of
its place at the next value (a long flap swinging through a shelf between two coarse
samples would otherwise stay deep in it), at most ``MAX_SWEEP``.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np

from .collision import DEFAULT_MIN_THICKNESS, convex_hull
from .errors import InputError
from .model import ArticulatedObject, Mesh, forward_kinematics

DEFAULT_GAP = 2e-4  # m left between cut pieces (engines measure 1e-4 as touching)
DEFAULT_SWEEP = 9  # joint values tried across each range at least, the ends included
SWEEP_STEP = 0.01  # m the child's farthest piece point moves between two values, at most
MAX_SWEEP = 64
# A cut may take at most this fraction of a piece's volume; beyond it a piece may only go
# when it is small next to its part (a handle's stem sunk into its door).
MAX_CUT_FRACTION = 0.5
SMALL_PIECE_FRACTION = 0.02
_MAX_PASSES = 8
_MAX_AXES = 256
_AXIS_RESOLUTION = 0.05


@dataclass(frozen=True)
class Cut:
    """What separation did where two parts' pieces overlapped: ``outcome`` is "cut" (a piece
    of ``part`` cut back by a plane), "dropped" (a small piece of ``part`` removed: nothing
    of it was left outside the other), "carved" (a piece of ``part`` split around the
    other's oriented box: a drawer front sunk into a board, a shaft through a block) or
    "left" (even that would take most of it: the overlap is kept and needs the engine's
    contact exclusions); ``depth`` the overlap (m) at ``configuration``."""

    part: str
    other_part: str
    depth: float
    configuration: dict[str, float]
    outcome: str = "cut"


@dataclass
class _Piece:
    part: str
    mesh: Mesh  # in the part frame
    local_planes: np.ndarray  # (F, 4) outward normals and offsets in the part frame
    volume: float
    world: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # at the configuration
    planes: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))  # at the configuration

    @classmethod
    def of(cls, part: str, mesh: Mesh) -> _Piece:
        tm = mesh.to_trimesh()
        normals = np.asarray(tm.face_normals)
        offsets = np.einsum("ij,ij->i", normals, np.asarray(tm.triangles_center))
        return cls(part, mesh, np.column_stack([normals, offsets]), abs(float(tm.volume)))

    def place(self, pose: np.ndarray) -> None:
        rotation, translation = pose[:3, :3], pose[:3, 3]
        self.world = self.mesh.vertices @ rotation.T + translation
        normals = self.local_planes[:, :3] @ rotation.T
        self.planes = np.column_stack([normals, self.local_planes[:, 3] + normals @ translation])


def separate(obj: ArticulatedObject, *, parts: set[str] | None = None, gap: float = DEFAULT_GAP,
             sweep: int = DEFAULT_SWEEP, min_thickness: float = DEFAULT_MIN_THICKNESS
             ) -> tuple[ArticulatedObject, list[Cut]]:
    """A copy of ``obj`` whose parts' collision pieces do not overlap (beyond ``gap``) at
    q = 0 nor with one joint anywhere in its range, and what was cut. Only the pieces of
    ``parts`` (default: all) are cut; a pair of two fixed pieces is left as it is."""
    out = copy.copy(obj)
    out.parts = [copy.copy(p) for p in obj.parts]
    mutable = {p.name for p in obj.parts} if parts is None else set(parts)
    pieces = [_Piece.of(p.name, m) for p in out.parts for m in p.collision]
    small = {p.name: 0.0 for p in out.parts}
    for piece in pieces:
        small[piece.part] += SMALL_PIECE_FRACTION * piece.volume
    cuts: list[Cut] = []
    met: dict[str, set[int]] = {}  # per joint: the pieces whose boxes met along its range
    for q, pair in _configurations(obj, sweep):
        pieces, found, touched = _separate_at(obj, q, pair, pieces, mutable, small, gap,
                                              min_thickness)
        cuts += found
        for name in q:
            met.setdefault(name, set()).update(touched)
    # Halfway between two swept values a corner of one piece may cut across an edge of the
    # other although both values left them clear: the pieces whose bounding boxes met along
    # a range are separated there too.
    for joint in obj.movable_joints:
        if not met.get(joint.name):
            continue
        values = sweep_values(obj, joint, sweep)
        for v in (values[1:] + values[:-1]) / 2:
            pieces, found, _ = _separate_at(obj, {joint.name: float(v)},
                                            (joint.child, joint.parent), pieces, mutable, small,
                                            gap, min_thickness, only=met[joint.name])
            cuts += found
    for part in out.parts:
        part.collision = [p.mesh for p in pieces if p.part == part.name]
    return out, cuts


def _separate_at(obj: ArticulatedObject, q: dict[str, float], pair: tuple[str, str] | None,
                 pieces: list[_Piece], mutable: set[str], small: dict[str, float], gap: float,
                 min_thickness: float, only: set[int] | None = None
                 ) -> tuple[list[_Piece], list[Cut], set[int]]:
    """Separate the pieces at one configuration (of the parts ``pair`` only, when given; of
    the pieces whose ids are in ``only``, when given): the pieces left, what was cut, and
    the ids of the pieces whose bounding boxes met."""
    poses = forward_kinematics(obj, q)
    # along a range only the joint's child and parent are compared: only they are placed
    placed = [p for p in pieces if (pair is None or p.part in pair)
              and (only is None or id(p) in only)]
    for piece in placed:
        piece.place(poses[piece.part])
    cuts: list[Cut] = []
    touched: set[int] = set()
    for _ in range(_MAX_PASSES):  # a carved piece's new pieces are checked on the next pass
        found = []
        for a, b in _candidate_pairs(placed, pair, mutable, gap):
            if a.volume == 0 or b.volume == 0:
                continue
            touched |= {id(a), id(b)}  # their boxes meet: they may meet in between
            cut = _separate_pair(a, b, poses, mutable, small, gap, min_thickness)
            if cut is not None:
                part, other, depth, outcome, new_pieces = cut
                found.append(Cut(part, other, depth, dict(q), outcome))
                touched |= {id(p) for p in new_pieces}
                pieces += new_pieces
                placed += new_pieces
        cuts += found
        pieces = [p for p in pieces if p.volume > 0]
        placed = [p for p in placed if p.volume > 0]
        if not any(c.outcome == "carved" for c in found):
            break
    return pieces, cuts, touched


def _candidate_pairs(pieces: list[_Piece], pair: tuple[str, str] | None, mutable: set[str],
                     gap: float):
    """Pairs of pieces of two different parts (of the two parts ``pair``, when given; at
    least one of them ``mutable``) whose bounding boxes overlap."""
    if len(pieces) < 2:
        return
    low = np.array([p.world.min(axis=0) for p in pieces])
    high = np.array([p.world.max(axis=0) for p in pieces])
    touching = np.all((low[:, None] < high[None] + gap) & (low[None] < high[:, None] + gap),
                      axis=-1)
    for i, j in np.argwhere(np.triu(touching, k=1)):
        a, b = pieces[i], pieces[j]
        if a.part == b.part or (a.part not in mutable and b.part not in mutable):
            continue
        if pair is not None and {a.part, b.part} != set(pair):
            continue
        yield a, b


def _configurations(obj: ArticulatedObject, sweep: int):
    """q = 0 (every pair of parts), then each movable joint alone at ``sweep`` values of its
    range (only its child against its parent: a door against its frame, a drawer against
    its carcass; a drawer that meets a closed door beside it is a real collision)."""
    yield {}, None
    for joint in obj.movable_joints:
        for v in sweep_values(obj, joint, sweep):
            if v != 0.0:
                yield {joint.name: float(v)}, (joint.child, joint.parent)


def sweep_values(obj: ArticulatedObject, joint, sweep: int = DEFAULT_SWEEP,
                 step: float = SWEEP_STEP) -> np.ndarray:
    """The joint values a range is swept at: ``sweep`` or more, evenly, the ends included
    (a continuous joint: one turn), so that the child's pieces move at most ``step`` (m)
    from one to the next (``MAX_SWEEP`` at most)."""
    lower, upper = (-np.pi, np.pi) if joint.limits is None else \
        (joint.limits.lower, joint.limits.upper)
    travel = upper - lower
    if joint.type.angular:  # the farthest piece point from the axis, in the child frame
        points = [m.vertices for p in obj.parts if p.name == joint.child for m in p.collision]
        if points:
            v = np.concatenate(points)
            radius = np.linalg.norm(v - np.outer(v @ joint.axis, joint.axis), axis=1).max()
            travel *= float(radius)
        else:
            travel = 0.0
    count = int(min(MAX_SWEEP, max(sweep, np.ceil(travel / step) + 1)))
    if joint.limits is None:
        return np.linspace(lower, upper, count, endpoint=False)
    return np.linspace(lower, upper, count)


def _separate_pair(a: _Piece, b: _Piece, poses: dict[str, np.ndarray], mutable: set[str],
                   small: dict[str, float], gap: float, min_thickness: float):
    """Cut ``a`` or ``b`` (whichever loses the smaller fraction) back to ``gap`` from the
    other along the axis they overlap least on; None when a face normal separates them by
    ``gap`` already."""
    normals = _axes(np.concatenate([a.planes[:, :3], -b.planes[:, :3]]))
    # along n, a's top minus b's bottom: how far a reaches into b from below
    overlap = (a.world @ normals.T).max(axis=0) - (b.world @ normals.T).min(axis=0)
    best = int(np.argmin(overlap))
    depth = float(overlap[best])
    if depth <= -gap:  # pieces that only touch are parted too: engines see them overlap
        return None
    n = normals[best]
    a_top, b_bottom = float((a.world @ n).max()), float((b.world @ n).min())
    options = []
    if a.part in mutable:
        options.append((a, n, b_bottom - gap))  # keep a below b's bottom
    if b.part in mutable:
        options.append((b, -n, -(a_top + gap)))  # keep b above a's top
    allowed = []
    for piece, normal, offset in options:
        kept = _clipped(piece.world, piece.mesh.faces, normal, offset, min_thickness)
        kept_volume = 0.0 if kept is None else abs(float(kept.to_trimesh().volume))
        loss = 1.0 - kept_volume / max(piece.volume, 1e-18)
        if loss <= MAX_CUT_FRACTION or piece.volume <= small[piece.part]:
            allowed.append((loss, piece, kept))
    if not allowed:
        return _carve(a, b, poses, mutable, gap, min_thickness, depth)
    _, piece, kept = min(allowed, key=lambda r: r[0])
    other = b if piece is a else a
    if kept is None:
        piece.volume = 0.0
        return piece.part, other.part, depth, "dropped", []
    _set_mesh(piece, kept, poses[piece.part])
    return piece.part, other.part, depth, "cut", []


def _axes(normals: np.ndarray) -> np.ndarray:
    """The candidate axes, fine hulls' thousands of face normals thinned to one per
    ``_AXIS_RESOLUTION`` cell of directions (any axis that separates proves separation, so
    thinning only makes a rare cut unnecessary, never misses an overlap)."""
    if len(normals) <= _MAX_AXES:
        return normals
    _, first = np.unique(np.round(normals / _AXIS_RESOLUTION), axis=0, return_index=True)
    return normals[np.sort(first)]


def _carve(a: _Piece, b: _Piece, poses: dict[str, np.ndarray], mutable: set[str],
           gap: float, min_thickness: float, depth: float):
    """A piece sunk deep into a larger one (a drawer front into a desk's front board): the
    larger is split into the convex pieces of it outside the smaller's oriented box, one per
    face of the box (each cut by that face's plane and the earlier faces' opposites)."""
    import trimesh

    big, intruder = (a, b) if a.volume >= b.volume else (b, a)
    if big.part not in mutable or len(intruder.world) < 4:  # no box to carve around
        return a.part, b.part, depth, "left", []
    try:
        to_box, extents = trimesh.bounds.oriented_bounds(intruder.world)
    except (TypeError, ValueError):  # no box found (NaN volumes, as in collision_boxes, or
        # a flat piece whose hull trimesh cannot take): axis-aligned
        low, high = intruder.world.min(axis=0), intruder.world.max(axis=0)
        to_box, extents = np.eye(4), high - low
        to_box[:3, 3] = -(low + high) / 2
    from_box = np.linalg.inv(to_box)
    carved = []
    for axis in range(3):
        for sign in (1.0, -1.0):
            normal = sign * from_box[:3, axis]
            center = from_box[:3, 3]
            offset = float(normal @ center) + extents[axis] / 2 + gap
            region = _clipped_all(big.world, big.mesh.faces,
                                  [(-normal, -offset), *_done(carved)], min_thickness)
            carved.append((normal, offset, region))
    pieces = [region for _, _, region in carved if region is not None]
    kept = sum(abs(float(m.to_trimesh().volume)) for m in pieces)
    if kept < (1.0 - MAX_CUT_FRACTION) * big.volume:
        return a.part, b.part, depth, "left", []
    pose = poses[big.part]
    new = []
    for k, mesh in enumerate(pieces):
        target = big if k == 0 else _Piece.of(big.part, mesh.transformed(np.linalg.inv(pose)))
        _set_mesh(target, mesh, pose)
        if k:
            new.append(target)
    if not pieces:
        big.volume = 0.0
    return big.part, intruder.part, depth, "carved", new


def _done(carved):
    """The half-spaces already given to earlier pieces, as (normal, offset) to stay below."""
    return [(normal, offset) for normal, offset, _ in carved]


def _clipped_all(vertices: np.ndarray, faces: np.ndarray, halfspaces, min_thickness: float
                 ) -> Mesh | None:
    """The convex piece cut by every (normal, offset) half-space in turn, or None."""
    mesh = Mesh(vertices, faces)
    for normal, offset in halfspaces:
        clipped = _clipped(mesh.vertices, mesh.faces, normal, offset, min_thickness)
        if clipped is None:
            return None
        mesh = clipped
    return mesh


def _set_mesh(piece: _Piece, world_mesh: Mesh, pose: np.ndarray) -> None:
    fresh = _Piece.of(piece.part, world_mesh.transformed(np.linalg.inv(pose)))
    piece.mesh, piece.local_planes, piece.volume = fresh.mesh, fresh.local_planes, fresh.volume
    piece.place(pose)


def _clipped(vertices: np.ndarray, faces: np.ndarray, normal: np.ndarray, offset: float,
             min_thickness: float) -> Mesh | None:
    """The convex piece cut to ``normal . x <= offset``, or None when less than
    ``min_thickness`` of it is left."""
    height = vertices @ normal - offset
    if height.min() > -min_thickness:
        return None
    kept = [vertices[height <= 0]]
    edges = np.unique(np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]],
                                              faces[:, [2, 0]]]), axis=1), axis=0)
    h0, h1 = height[edges[:, 0]], height[edges[:, 1]]
    crossing = (h0 < 0) != (h1 < 0)
    if crossing.any():
        e = edges[crossing]
        t = (h0[crossing] / (h0[crossing] - h1[crossing]))[:, None]
        kept.append(vertices[e[:, 0]] + t * (vertices[e[:, 1]] - vertices[e[:, 0]]))
    points = np.concatenate(kept)
    try:
        return convex_hull(Mesh(points, np.zeros((0, 3))), min_thickness=min_thickness)
    except InputError:
        return None
