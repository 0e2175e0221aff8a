"""The room around a rendered object: a floor it stands on, a wall and clutter nearby.

A real capture holds more than the object; ``render --room`` puts it there so that the
pipeline's search for the object (:mod:`pipeline.isolate`) is tried on what it will meet.
The scenery knows the camera poses (drawn first, so a capture with and without the room
shares its cameras) and nothing of the joints:

- the floor: a wide slab whose top is the object's lowest point (the object stands on it);
- a wall: vertical, on the side away from the cameras; right behind the object when the
  cameras stand on one side of it (a cabinet against a wall), beyond the farthest camera
  when they walk all round it;
- clutter: a few boxes and cylinders on the floor beside the object, clear of it (10 cm at
  least) and of the cameras (some of them hide part of the object in some views, as things
  nearby do).

Seeded: the same generator state gives the same room. Scenery is never a part: its pixels
have depth and colour, and mask 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from real2code_export.model import Mesh

FLOOR_THICKNESS = 0.05
WALL_HEIGHT = 2.6  # metres above the floor
CLUTTER_COUNT = (2, 6)  # pieces, drawn in [low, high)


@dataclass(frozen=True)
class Scenery:
    name: str  # floor, wall, clutter_<k>
    mesh: Mesh  # world frame
    color: tuple[float, float, float]  # linear RGB


def _box(lo: np.ndarray, hi: np.ndarray) -> Mesh:
    import trimesh

    box = trimesh.creation.box(extents=hi - lo)
    box.apply_translation((lo + hi) / 2)
    return Mesh.from_trimesh(box)


def _turned_box(extents: np.ndarray, centre: np.ndarray, yaw: float) -> Mesh:
    import trimesh

    box = trimesh.creation.box(extents=extents)
    box.apply_transform(trimesh.transformations.rotation_matrix(yaw, [0, 0, 1]))
    box.apply_translation(centre)
    return Mesh.from_trimesh(box)


def _cylinder(radius: float, height: float, centre: np.ndarray) -> Mesh:
    import trimesh

    cyl = trimesh.creation.cylinder(radius=radius, height=height, sections=24)
    cyl.apply_translation(centre)
    return Mesh.from_trimesh(cyl)


def _muted(rng: np.random.Generator) -> tuple[float, float, float]:
    """A room's colour: greyish, now and then saturated."""
    grey = rng.uniform(0.15, 0.7)
    tint = rng.uniform(-0.1, 0.1, 3) * (3.0 if rng.random() < 0.3 else 1.0)
    return tuple(float(c) for c in np.clip(grey + tint, 0.02, 0.95))


def room_scenery(lo: np.ndarray, hi: np.ndarray, camera_positions: np.ndarray,
                 rng: np.random.Generator, up: int = 2) -> list[Scenery]:
    """Floor, wall and clutter around an object whose world box is ``lo`` .. ``hi``, seen
    from ``camera_positions`` (N, 3); ``up`` is the world's vertical axis (z)."""
    if up != 2:
        raise ValueError("the room is built with z up")
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    centre = (lo + hi) / 2
    half = (hi - lo) / 2
    reach = float(np.max(np.linalg.norm((camera_positions - centre)[:, :2], axis=1)))
    span = 2.0 * reach + 4.0  # the floor and the wall run well out of every view
    out = [Scenery("floor", _box(np.array([centre[0] - span, centre[1] - span,
                                           lo[2] - FLOOR_THICKNESS]),
                                 np.array([centre[0] + span, centre[1] + span, lo[2] - 1e-4])),
                   _muted(rng))]

    # the wall: on the side the cameras are not, or (cameras all round) beyond them all
    towards = (camera_positions - centre)[:, :2]
    towards /= np.maximum(np.linalg.norm(towards, axis=1, keepdims=True), 1e-9)
    mean = towards.mean(0)
    away = -mean / np.linalg.norm(mean) if np.linalg.norm(mean) > 0.3 else \
        np.array([np.cos(a := rng.uniform(0, 2 * np.pi)), np.sin(a)])
    behind_object = float(np.abs(half[:2]) @ np.abs(away)) + rng.uniform(0.02, 0.3)
    behind_cameras = float(np.max((camera_positions - centre)[:, :2] @ away)) + \
        rng.uniform(0.3, 1.0)
    offset = max(behind_object, behind_cameras)
    mid = centre + (offset + 0.05) * np.array([*away, 0.0])  # its face at ``offset``
    mid[2] = lo[2] + (WALL_HEIGHT - FLOOR_THICKNESS) / 2
    wall = _turned_box(np.array([0.1, 2 * span, WALL_HEIGHT + FLOOR_THICKNESS]), mid,
                       float(np.arctan2(away[1], away[0])))
    out.append(Scenery("wall", wall, _muted(rng)))

    # clutter: on the floor, beside the object, clear of it, the wall and the cameras
    size = float(np.linalg.norm(half))
    footprint = float(np.linalg.norm(half[:2]))
    cams = camera_positions[:, :2]
    placed = 0
    for _ in range(60):
        if placed >= rng.integers(*CLUTTER_COUNT):
            break
        extent = rng.uniform(0.12, 0.4, 3) * size
        extent[2] = rng.uniform(0.15, 0.6) * (hi[2] - lo[2])
        radius_xy = float(np.linalg.norm(extent[:2])) / 2
        angle = rng.uniform(0, 2 * np.pi)
        dist = footprint + radius_xy + 0.1 + rng.uniform(0.0, 0.6) * max(size, 0.3)
        where = centre[:2] + dist * np.array([np.cos(angle), np.sin(angle)])
        if np.min(np.linalg.norm(cams - where, axis=1)) < radius_xy + 0.3:
            continue  # a camera would stand in it
        if (where - centre[:2]) @ away + radius_xy > offset - 0.02:
            continue  # in the wall
        base = np.array([*where, lo[2] + extent[2] / 2])
        if rng.random() < 0.6:
            mesh = _turned_box(extent, base, rng.uniform(0, np.pi))
        else:
            mesh = _cylinder(min(extent[:2]) / 2, extent[2], base)
        out.append(Scenery(f"clutter_{placed}", mesh, _muted(rng)))
        placed += 1
    return out
