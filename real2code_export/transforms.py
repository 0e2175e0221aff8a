"""Rigid transforms as 4x4 homogeneous matrices, and the conversions the formats need.

Quaternions are (w, x, y, z) everywhere in this project, as MuJoCo and USD store them.
Roll-pitch-yaw follows URDF: R = Rz(yaw) @ Ry(pitch) @ Rx(roll).
"""

from __future__ import annotations

import math

import numpy as np

IDENTITY = np.eye(4)


def make(rotation: np.ndarray | None = None, translation=None) -> np.ndarray:
    """A 4x4 transform from a 3x3 rotation and a translation."""
    t = np.eye(4)
    if rotation is not None:
        t[:3, :3] = rotation
    if translation is not None:
        t[:3, 3] = translation
    return t


def inverse(t: np.ndarray) -> np.ndarray:
    r = t[:3, :3]
    out = np.eye(4)
    out[:3, :3] = r.T
    out[:3, 3] = -r.T @ t[:3, 3]
    return out


def axis_angle_matrix(axis, angle: float) -> np.ndarray:
    """3x3 rotation of ``angle`` radians about the unit ``axis`` (Rodrigues)."""
    x, y, z = np.asarray(axis, dtype=float)
    c, s = np.cos(angle), np.sin(angle)
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + s * k + (1.0 - c) * (k @ k)


def rpy_to_matrix(rpy) -> np.ndarray:
    roll, pitch, yaw = (float(v) for v in rpy)
    cr, sr = np.cos(roll), np.sin(roll)
    cp, sp = np.cos(pitch), np.sin(pitch)
    cy, sy = np.cos(yaw), np.sin(yaw)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def quat_to_matrix(q) -> np.ndarray:
    """3x3 rotation of a (w, x, y, z) quaternion (normalised first)."""
    w, x, y, z = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix_to_quat(r: np.ndarray) -> np.ndarray:
    """(w, x, y, z) quaternion of a rotation matrix, with w >= 0 (a canonical sign). In
    Python floats (the same operations, the same numbers as on numpy's scalars, a third of
    the time: the USD writer places every prim by one)."""
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = np.asarray(r, dtype=float).tolist()
    tr = r00 + r11 + r22
    if tr > 0:
        s = 2.0 * math.sqrt(tr + 1.0)
        q = [0.25 * s, (r21 - r12) / s, (r02 - r20) / s, (r10 - r01) / s]
    elif r00 > r11 and r00 > r22:
        s = 2.0 * math.sqrt(1.0 + r00 - r11 - r22)
        q = [(r21 - r12) / s, 0.25 * s, (r01 + r10) / s, (r02 + r20) / s]
    elif r11 > r22:
        s = 2.0 * math.sqrt(1.0 + r11 - r00 - r22)
        q = [(r02 - r20) / s, (r01 + r10) / s, 0.25 * s, (r12 + r21) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + r22 - r00 - r11)
        q = [(r10 - r01) / s, (r02 + r20) / s, (r12 + r21) / s, 0.25 * s]
    q = np.array(q)
    q /= short_norm(q.tolist())
    return -q if q[0] < 0 else q


def short_norm(values: list[float]) -> float:
    """``np.linalg.norm`` of a short vector (a quaternion), the same float: the squares
    added in order, as BLAS's dot adds so few numbers (``tests/test_transforms.py`` holds
    them equal), in Python floats. Not numpy's dot: it calls BLAS with the GIL let go, and
    with the creased normals' thread busy beside a USD export's authoring, taking it back
    was most of this function's time there (sampled)."""
    total = 0.0
    for v in values:
        total += v * v
    return math.sqrt(total)


def orthonormalize(r: np.ndarray) -> np.ndarray:
    """The nearest rotation matrix (polar decomposition via SVD)."""
    u, _, vt = np.linalg.svd(np.asarray(r, dtype=float))
    out = u @ vt
    if np.linalg.det(out) < 0:
        u[:, -1] *= -1
        out = u @ vt
    return out


_EYE3 = np.eye(3)
_EYE3.flags.writeable = False


def allclose_to_finite(a, b, *, atol: float = 1e-8, rtol: float = 1e-5) -> bool:
    """``np.allclose(a, b, rtol, atol)`` where ``b`` is finite, the same answer: its test
    |a - b| <= atol + rtol |b| written out (a NaN or infinity in ``a`` fails it, as there),
    without its handling of infinities in ``b``: a quarter of its time on the small arrays
    every joint, placement and inertia is checked with."""
    a = np.asarray(a, dtype=float)
    return bool(np.all(np.abs(a - b) <= atol + rtol * np.abs(b)))


def is_rotation(r: np.ndarray, tol: float = 1e-6) -> bool:
    """Finite, orthonormal to ``tol`` (``np.allclose(r.T @ r, I, atol=tol)``) and proper
    (det > 0)."""
    r = np.asarray(r, dtype=float)
    return (
        r.shape == (3, 3)
        and bool(np.all(np.isfinite(r)))
        and allclose_to_finite(r.T @ r, _EYE3, atol=tol)
        and np.linalg.det(r) > 0
    )


def rotation_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Angle in radians of the rotation that takes ``a`` to ``b`` (3x3 matrices)."""
    c = (np.trace(a.T @ b) - 1.0) / 2.0
    return float(np.arccos(np.clip(c, -1.0, 1.0)))


def rotation_between(a, b) -> np.ndarray:
    """A rotation taking unit vector ``a`` onto unit vector ``b`` (the shortest one)."""
    a = np.asarray(a, float) / np.linalg.norm(a)
    b = np.asarray(b, float) / np.linalg.norm(b)
    v = np.cross(a, b)
    c = float(np.dot(a, b))
    if c < -1.0 + 1e-12:  # opposite: rotate pi about any axis orthogonal to a
        ortho = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        axis = np.cross(a, ortho)
        return axis_angle_matrix(axis / np.linalg.norm(axis), np.pi)
    k = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + k + k @ k / (1.0 + c)
