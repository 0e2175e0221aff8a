"""Mass properties of parts from their meshes.

A closed, consistently wound mesh is a solid of uniform ``density`` (integrated exactly over
its faces).
Anything else (open PartNet pieces, single-sided panels, scans with holes) is a thin shell of
surface density ``density * shell_thickness``, integrated exactly over its triangles.
A part made of several pieces sums them (solid where closed, shell where open) about the
total centre of mass.

The integrals and the topology they need (``meshtopology``: merged vertices, closed
components, outward winding) are numpy, not trimesh: importing trimesh imports scipy, which
costs more than a whole URDF -> USD export of a PartNet object otherwise takes. Results are
also cached on disk by the meshes' content (``meshcache``).

Every result passes :func:`model.validate_inertial`: principal moments that come out tiny or
zero (a flat panel has one moment equal to the sum of the other two; a stick has a zero
moment) are raised to what a body ``shell_thickness`` thick would have, so simulators get a
positive-definite tensor that satisfies the triangle inequality.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from . import meshcache, meshtopology
from .errors import InputError, warn
from .model import Inertial, JointType, Mesh, Tree
from .primitives import Primitive, ShapeKind
from .repairs import TRIANGLE_MARGIN

# Furniture (the main category here) is wood, plywood, particleboard or MDF: roughly
# 400-800 kg/m^3. 500 is a middle value that also allows for hollow/cored panels.
DEFAULT_DENSITY = 500.0
DEFAULT_SHELL_THICKNESS = 0.005  # 5 mm: a thin panel / sheet-metal wall

# Relative floor on principal moments (of the largest one): keeps the tensor well
# conditioned for simulators even when shell_thickness is tiny.
_RELATIVE_MOMENT_FLOOR = 1e-6


# -- raw moments: (mass, first moment m*c, second moment  integral x x^T dm about origin) ---
_Moments = tuple[float, np.ndarray, np.ndarray]


def _zero_moments() -> _Moments:
    return 0.0, np.zeros(3), np.zeros((3, 3))


def _add(a: _Moments, b: _Moments) -> _Moments:
    return a[0] + b[0], a[1] + b[1], a[2] + b[2]


def _shell_moments(vertices: np.ndarray, faces: np.ndarray, surface_density: float) -> _Moments:
    """Exact moments of a thin shell. For a triangle with vertices v_i, area A and
    s = sum v_i: integral x dA = A s / 3 and integral x x^T dA = A/12 (sum v_i v_i^T + s s^T).
    (Hand-written: trimesh only integrates closed volumes.)"""
    if len(faces) == 0:
        return _zero_moments()
    tri = vertices[faces]  # (M, 3, 3)
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    s = tri.sum(axis=1)
    mass = surface_density * float(area.sum())
    first = surface_density * (area[:, None] * s).sum(axis=0) / 3.0
    outer = np.einsum("mij,mik->mjk", tri, tri) + np.einsum("mj,mk->mjk", s, s)
    second = surface_density * np.einsum("m,mjk->jk", area, outer) / 12.0
    return mass, first, second


def _solid_moments(vertices: np.ndarray, faces: np.ndarray, density: float) -> _Moments:
    """Exact moments of a closed, outward-wound volume: the sum over its faces of the signed
    tetrahedra (face, apex c), each with volume V = det(v0, v1, v2) / 6, integral x dV =
    V s / 4 and integral x x^T dV = V/20 (sum v_i v_i^T + s s^T), s = v0 + v1 + v2, the
    vertices taken relative to c (the polyhedral integration trimesh does; c the vertices'
    mean, which keeps round-off small far from the origin), then moved back to the origin."""
    c = vertices[faces].reshape(-1, 3).mean(axis=0)
    tri = vertices[faces] - c  # (M, 3, 3)
    volume = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])) / 6.0
    s = tri.sum(axis=1)
    outer = np.einsum("mij,mik->mjk", tri, tri) + np.einsum("mj,mk->mjk", s, s)
    mass = density * float(volume.sum())
    first = density * (volume[:, None] * s).sum(axis=0) / 4.0
    second = density * np.einsum("m,mjk->jk", volume, outer) / 20.0
    shifted = second + np.outer(first, c) + np.outer(c, first) + mass * np.outer(c, c)
    return mass, first + mass * c, shifted


def _as_volume(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray | None:
    """``faces`` as a closed volume wound outward, or None when they do not close one."""
    edges = meshtopology.Edges(faces)
    if not edges.watertight():
        return None
    if edges.winding_consistent() and meshtopology.encloses_volume(vertices, faces):
        return faces
    faces = meshtopology.wound_outward(vertices, faces)
    if meshtopology.Edges(faces).winding_consistent() \
            and meshtopology.encloses_volume(vertices, faces):
        return faces
    return None


def _mesh_moments(mesh: Mesh, density: float, shell_thickness: float) -> _Moments:
    """Solid when the whole mesh is a closed volume (this handles hollows and nesting right);
    otherwise each closed connected component is a solid and every other face a shell. A
    round shape the mesh keeps (sphere, ellipsoid, cylinder, capsule) is its exact solid, as
    MuJoCo and PhysX compute it: its tessellation holds up to 3 % less volume (a humanoid's
    capsules and spheres read from USD colliders weighed 2.7 to 3.4 % light)."""
    round_shapes = [p for p in mesh.primitives if p.kind in _ROUND]
    if round_shapes:
        total = _zero_moments()
        for shape in round_shapes:
            total = _add(total, _shape_moments(shape, density))
        rest = _without(mesh, round_shapes)
        return total if rest is None else _add(total, _mesh_moments(rest, density,
                                                                    shell_thickness))
    if len(mesh.faces) == 0:
        return _zero_moments()
    # Coincident vertices merged: OBJ files split them at seams, and no PartNet piece would
    # ever count as closed otherwise.
    vertices, faces = meshtopology.merged(mesh.vertices, mesh.faces)
    solid = _as_volume(vertices, faces)
    if solid is not None:
        return _solid_moments(vertices, solid, density)
    total = _zero_moments()
    open_faces = np.ones(len(faces), dtype=bool)
    for component in _closed_components(faces):
        solid = _as_volume(vertices, faces[component])
        if solid is not None:
            total = _add(total, _solid_moments(vertices, solid, density))
            open_faces[component] = False
    shell = _shell_moments(vertices, faces[open_faces], density * shell_thickness)
    return _add(total, shell)


_ROUND = frozenset({ShapeKind.SPHERE, ShapeKind.ELLIPSOID, ShapeKind.CYLINDER,
                    ShapeKind.CAPSULE})


def _shape_moments(shape: Primitive, density: float) -> _Moments:
    """Exact moments of a solid round shape of uniform ``density`` at its pose."""
    size = shape.size
    if shape.kind is ShapeKind.CAPSULE:  # a cylinder and two hemispheres
        r, h = size
        tube, ball = density * math.pi * r * r * h, density * 4.0 / 3.0 * math.pi * r ** 3
        mass = tube + ball
        axial = tube * r * r / 2.0 + ball * 2.0 * r * r / 5.0
        across = tube * (3.0 * r * r + h * h) / 12.0 + ball * (
            2.0 * r * r / 5.0 + h * h / 4.0 + 3.0 * h * r / 8.0)
        moments = np.array([across, across, axial])
    elif shape.kind is ShapeKind.CYLINDER:
        r, h = size
        mass = density * math.pi * r * r * h
        across = mass * (3.0 * r * r + h * h) / 12.0
        moments = np.array([across, across, mass * r * r / 2.0])
    else:  # a sphere, an ellipsoid
        a, b, c = (size[0],) * 3 if shape.kind is ShapeKind.SPHERE else size
        mass = density * 4.0 / 3.0 * math.pi * a * b * c
        moments = mass / 5.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    rot, centre = shape.pose[:3, :3], shape.pose[:3, 3]
    inertia = rot @ np.diag(moments) @ rot.T
    second = 0.5 * np.trace(inertia) * np.eye(3) - inertia  # about the centre
    return mass, mass * centre, second + mass * np.outer(centre, centre)


def _without(mesh: Mesh, shapes: list[Primitive]) -> Mesh | None:
    """``mesh`` without the tessellations of ``shapes`` (some of its primitives), the
    others kept (None when no face is left)."""
    rest = mesh.remainder()
    others = [p for p in mesh.primitives if p not in shapes]
    pieces = ([rest] if rest is not None else []) + [Mesh.of_primitive(p) for p in others]
    return Mesh.concatenate(pieces) if pieces else None


def _closed_components(faces: np.ndarray) -> list[np.ndarray]:
    """Face indices of each connected component whose every edge has exactly two faces.
    (Vectorised: PartNet pieces are often soups of thousands of loose triangles.)"""
    edges = meshtopology.Edges(faces)
    labels = meshtopology.component_labels(len(faces), edges.face_adjacency())
    face_open = (edges.counts().reshape(-1, 3) != 2).any(axis=1)
    open_component = np.bincount(labels, weights=face_open, minlength=labels.max() + 1) > 0
    # components of fewer than four faces can never close; skip them cheaply
    sizes = np.bincount(labels)
    closed = np.flatnonzero(~open_component & (sizes >= 4))
    if len(closed) == 0:  # (a soup has thousands of components: split none of them)
        return []
    order = np.argsort(labels, kind="stable")
    starts = np.cumsum(sizes) - sizes
    return [order[starts[c]:starts[c] + sizes[c]] for c in closed]


def _physical_inertia(inertia: np.ndarray, mass: float, min_size: float) -> np.ndarray:
    """Symmetric positive-definite tensor satisfying the triangle inequality.

    Principal moments are raised to at least mass * min_size^2 / 12 (what a slab
    ``min_size`` thick has about its normal-plane axes) and to a small fraction of the
    largest; then the largest is capped at the sum of the other two (equality is a flat
    panel, so this only removes round-off). A flat panel's two smaller moments are then
    raised by ``repairs.TRIANGLE_MARGIN`` of the largest: at equality, a tensor with
    products of inertia written as text and diagonalised again (MuJoCo's URDF import) can
    come back 1e-16 short of A + B = C and be refused."""
    inertia = 0.5 * (inertia + inertia.T)
    moments, axes = np.linalg.eigh(inertia)
    floor = max(mass * min_size**2 / 12.0, _RELATIVE_MOMENT_FLOOR * max(moments[2], 0.0), 1e-30)
    moments = np.maximum(moments, floor)
    moments = np.sort(moments)
    moments[2] = min(moments[2], moments[0] + moments[1])
    deficit = moments[2] * (1 + TRIANGLE_MARGIN) - moments[0] - moments[1]
    if deficit > 0:
        moments[:2] += deficit / 2
    out = (axes * moments) @ axes.T
    return 0.5 * (out + out.T)


def _inertial_from_moments(m: _Moments, min_size: float) -> Inertial:
    mass, first, second = m
    com = first / mass
    second_c = second - mass * np.outer(com, com)
    inertia = np.trace(second_c) * np.eye(3) - second_c
    return Inertial(mass, com, _physical_inertia(inertia, mass, min_size))


def _degenerate_fallback(meshes: Sequence[Mesh], density: float, min_size: float) -> Inertial:
    """No area and no volume (points, lines): a box around the vertices, at least
    ``min_size`` thick in every direction, so the part still has mass."""
    verts = np.concatenate([m.vertices for m in meshes if len(m.vertices)] or [np.zeros((1, 3))])
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    warn(f"mesh has no area or volume; mass from its bounding box ({(hi - lo).tolist()} m, "
         f"at least {min_size} m thick)")
    return box_inertial(np.maximum(hi - lo, min_size), density=density, center=0.5 * (lo + hi))


def inertial_from_mesh(mesh: Mesh, density: float = DEFAULT_DENSITY, *,
                       shell_thickness: float = DEFAULT_SHELL_THICKNESS) -> Inertial:
    """Mass properties of one mesh (part frame): a uniform solid of ``density`` (kg/m^3)
    when the mesh is closed, else a shell ``shell_thickness`` (m) thick, per connected
    component."""
    return inertial_from_meshes([mesh], density, shell_thickness=shell_thickness)


def inertial_from_meshes(meshes: Sequence[Mesh], density: float = DEFAULT_DENSITY, *,
                         shell_thickness: float = DEFAULT_SHELL_THICKNESS) -> Inertial:
    """Mass properties of a part made of several pieces (all in the part frame), each solid
    where closed and a shell where open, combined about the total centre of mass.

    Overlapping pieces count twice (PartNet pieces rarely overlap much; a boolean union of
    many open pieces is neither possible nor worth it)."""
    if density <= 0 or shell_thickness <= 0:
        raise InputError(f"density and shell_thickness must be > 0, got {density}, {shell_thickness}")
    return meshcache.cached(
        "inertial", meshes, {"density": density, "shell_thickness": shell_thickness},
        lambda: _inertial_of_pieces(meshes, density, shell_thickness),
        lambda i: {"mass": np.array(i.mass), "com": i.com, "inertia": i.inertia},
        lambda a: Inertial(float(a["mass"]), a["com"], a["inertia"]), sources=(__file__,))


def _inertial_of_pieces(meshes: Sequence[Mesh], density: float,
                        shell_thickness: float) -> Inertial:
    total = _zero_moments()
    for mesh in meshes:
        total = _add(total, _mesh_moments(mesh, density, shell_thickness))
    if not total[0] > 0:
        return _degenerate_fallback(meshes, density, shell_thickness)
    return _inertial_from_moments(total, shell_thickness)


def combine_inertials(items: Sequence[tuple[Inertial, np.ndarray]]) -> Inertial:
    """One inertial from several, each given with the 4x4 transform of its frame into the
    common frame (rotation applied to the tensor, then the parallel axis theorem)."""
    total = _zero_moments()
    for inertial, transform in items:
        transform = np.asarray(transform, dtype=float)
        rot, trans = transform[:3, :3], transform[:3, 3]
        com = rot @ inertial.com + trans
        inertia = rot @ inertial.inertia @ rot.T
        second_c = 0.5 * np.trace(inertia) * np.eye(3) - inertia
        m = inertial.mass
        total = _add(total, (m, m * com, second_c + m * np.outer(com, com)))
    if not total[0] > 0:
        raise InputError("combine_inertials needs at least one positive mass")
    mass, first, second = total
    com = first / mass
    second_c = second - mass * np.outer(com, com)
    inertia = np.trace(second_c) * np.eye(3) - second_c
    # Sums of valid tensors stay valid; only symmetrise the round-off.
    return Inertial(mass, com, 0.5 * (inertia + inertia.T))


def carrier(tree: Tree, name: str) -> str | None:
    """The moving part with no mass of its own that part ``name`` is welded under (fixed
    joints all the way up to its joint), or None: not welded (``name`` moves itself or is the
    root), welded to the root, or under a part with mass. Such a part carries the mass of
    the parts welded below it (a free body whose mass lies in a body welded under it, as
    MJCF writes one): formats that can state no "no mass" (UsdPhysics, KHR_physics_rigid_
    bodies: zero means "compute it", none "a default") write the group as one body with
    their summed mass properties (:func:`welded_below`), else the simulator gives the moving
    part a mass of its own."""
    joint = tree.parent.get(name)
    if joint is None or joint.type is not JointType.FIXED:
        return None
    while joint is not None and joint.type is JointType.FIXED:
        joint = tree.parent.get(joint.parent)
    return joint.child if joint is not None and tree.parts[joint.child].inertial is None \
        else None


def welded_below(tree: Tree, name: str) -> list[tuple[str, np.ndarray]]:
    """The parts fixed below part ``name`` (through fixed joints only), each with its frame
    in ``name``'s part frame."""
    out, stack = [], [(name, np.eye(4))]
    while stack:
        parent, pose = stack.pop()
        for j in tree.children[parent]:
            if j.type is JointType.FIXED:
                child_pose = pose @ j.origin
                out.append((j.child, child_pose))
                stack.append((j.child, child_pose))
    return out


def box_inertial(extents: Sequence[float] | np.ndarray, *, mass: float | None = None,
                 density: float = DEFAULT_DENSITY,
                 center: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
                 rotation: np.ndarray | None = None) -> Inertial:
    """A uniform solid box with full side lengths ``extents`` (m), centred at ``center``,
    its axes ``rotation`` (3x3) in the part frame; ``mass`` given, or from ``density``."""
    ext = np.asarray(extents, dtype=float).reshape(3)
    if np.any(ext <= 0):
        raise InputError(f"box extents must be > 0, got {ext.tolist()}")
    m = float(mass) if mass is not None else density * float(np.prod(ext))
    if not m > 0:
        raise InputError(f"box mass must be > 0, got {m}")
    x2, y2, z2 = ext**2
    inertia = m / 12.0 * np.diag([y2 + z2, x2 + z2, x2 + y2])
    if rotation is not None:
        rot = np.asarray(rotation, dtype=float).reshape(3, 3)
        inertia = rot @ inertia @ rot.T
    return Inertial(m, np.asarray(center, dtype=float), 0.5 * (inertia + inertia.T))
