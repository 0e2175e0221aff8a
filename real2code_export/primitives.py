"""Primitive shapes (box, cylinder, sphere, capsule, ellipsoid) as the formats name them.

A primitive is kept with the mesh it is tessellated into (``Mesh.primitives``): everything
that wants triangles (inertia, collision, viewers, glTF) reads the mesh, and every writer
whose format has the shape writes the shape. The tessellation is fixed here, once, so every
reader that meets the same shape makes the very same triangles (round trips compare meshes).

Sizes are in metres, in the shape's own frame (``pose``: shape -> mesh frame), centred at its
origin, round shapes along z:

- box: full extents (x, y, z) (URDF ``size``; MJCF and USD hold half of it or a scale);
- sphere: (radius,);
- cylinder: (radius, length);
- capsule: (radius, length), the length of its cylinder between the caps' centres (USD's
  ``height``; MJCF holds half of it);
- ellipsoid: radii (x, y, z).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from functools import lru_cache

import numpy as np

from . import tessellation
from . import transforms as tf

ROUND_SECTIONS = 32  # around a cylinder's or capsule's axis
CAP_RINGS = 16  # along a capsule's caps
SPHERE_SUBDIVISIONS = 2  # icosphere (162 vertices)


class ShapeKind(StrEnum):
    BOX = "box"
    CYLINDER = "cylinder"
    SPHERE = "sphere"
    CAPSULE = "capsule"
    ELLIPSOID = "ellipsoid"


SIZE_COUNT = {ShapeKind.BOX: 3, ShapeKind.CYLINDER: 2, ShapeKind.SPHERE: 1,
              ShapeKind.CAPSULE: 2, ShapeKind.ELLIPSOID: 3}
SIZE_NAMES = {ShapeKind.BOX: "extents x y z", ShapeKind.CYLINDER: "radius length",
              ShapeKind.SPHERE: "radius", ShapeKind.CAPSULE: "radius length",
              ShapeKind.ELLIPSOID: "radii x y z"}


@dataclass(eq=False)
class Primitive:
    kind: ShapeKind
    size: np.ndarray
    pose: np.ndarray = field(default_factory=lambda: np.eye(4))

    def __post_init__(self) -> None:
        self.kind = ShapeKind(self.kind)
        self.size = np.asarray(self.size, dtype=np.float64).reshape(-1)
        self.pose = np.asarray(self.pose, dtype=np.float64).reshape(4, 4)

    def problem(self) -> str | None:
        """What makes the shape invalid (a size count, a non-positive size, a pose that is not
        rigid), or None."""
        if len(self.size) != SIZE_COUNT[self.kind]:
            return (f"{self.kind.value} takes {SIZE_COUNT[self.kind]} sizes "
                    f"({SIZE_NAMES[self.kind]}), got {len(self.size)}")
        if not np.all(np.isfinite(self.size)) or np.any(self.size <= 0):
            return f"{self.kind.value} sizes must be finite and > 0, got {self.size.tolist()}"
        if (not np.all(np.isfinite(self.pose))
                or not tf.allclose_to_finite(self.pose[3], (0.0, 0.0, 0.0, 1.0))
                or not tf.is_rotation(self.pose[:3, :3])):
            return f"{self.kind.value} pose is not a rigid transform"
        return None

    def transformed(self, transform: np.ndarray) -> Primitive:
        return Primitive(self.kind, self.size.copy(), np.asarray(transform) @ self.pose)

    def tessellation(self) -> tuple[np.ndarray, np.ndarray]:
        """Vertices (in the mesh frame, at ``pose``) and faces of the fixed tessellation."""
        vertices, faces = _unit(self.kind, tuple(self.size.tolist()))
        r, t = self.pose[:3, :3], self.pose[:3, 3]
        return vertices @ r.T + t, faces.copy()

    def counts(self) -> tuple[int, int]:
        """Vertex and face counts of the tessellation (fixed by the kind)."""
        vertices, faces = _unit(self.kind, tuple(self.size.tolist()))
        return len(vertices), len(faces)

    def differences(self, other: Primitive, tol: float) -> list[str]:
        out = []
        if self.kind != other.kind:
            return [f"{self.kind.value} != {other.kind.value}"]
        if self.size.shape != other.size.shape or not np.allclose(self.size, other.size,
                                                                  atol=tol, rtol=tol):
            out.append(f"{self.kind.value} size {self.size.tolist()} != {other.size.tolist()}")
        if not np.allclose(self.pose, other.pose, atol=tol, rtol=tol):
            out.append(f"{self.kind.value} pose differs")
        return out


@lru_cache(maxsize=256)
def _unit(kind: ShapeKind, size: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
    """The shape's triangles in its own frame (trimesh.creation's, at the fixed counts, made
    by ``tessellation`` so that a robot's export does not import trimesh)."""
    if kind is ShapeKind.BOX:
        return _frozen(*tessellation.box(size))
    if kind is ShapeKind.CYLINDER:
        return _frozen(*tessellation.cylinder(size[0], size[1], ROUND_SECTIONS))
    if kind is ShapeKind.CAPSULE:
        return _frozen(*tessellation.capsule(size[1], size[0], (ROUND_SECTIONS, CAP_RINGS)))
    radii = (size[0],) * 3 if kind is ShapeKind.SPHERE else size
    vertices, faces = tessellation.icosphere(SPHERE_SUBDIVISIONS, 1.0)
    return _frozen(vertices * np.asarray(radii), faces)


def _frozen(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    v = np.array(vertices, dtype=np.float64)
    f = np.array(faces, dtype=np.int64)
    v.flags.writeable = False
    f.flags.writeable = False
    return v, f
