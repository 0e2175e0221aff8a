"""Joint from a part seen at two or more states: its screw axis from the poses, exactly.

A 1-DoF joint moves its part by a screw with a fixed axis in the parent frame: a pure
rotation about a line (revolute) or a pure translation along a direction (prismatic). Given
the part's poses in the parent frame at K >= 2 states, the relative motions M_k = T_k T_0^-1
determine that screw; with exact poses the estimate is exact, with noisy ones it is the
least-squares fit over all states.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from real2code_export.errors import Real2CodeError
from real2code_export.transforms import axis_angle_matrix, inverse


@dataclass(frozen=True, eq=False)
class ScrewEstimate:
    type: str  # "revolute" or "prismatic"
    axis: np.ndarray  # unit, parent frame
    point: np.ndarray  # a point on the axis (revolute; the first pose's origin for prismatic)
    values: np.ndarray  # joint value at each state relative to the first (rad or m)
    residual: float  # RMS misfit of the poses (m, over the part's frame origin and axes)


def _rotation_vector(r: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(r).as_rotvec()


def estimate_screw(poses: list[np.ndarray], *, min_angle: float = 1e-3) -> ScrewEstimate:
    """The joint that moves a part through ``poses`` (4x4, parent frame, K >= 2).

    The part is taken as revolute when it turns by more than ``min_angle`` radians across
    the states, else prismatic. Values are signed so that the state farthest from the first
    is positive.
    """
    poses = [np.asarray(p, float) for p in poses]
    if len(poses) < 2:
        raise Real2CodeError(f"need the part at two or more states, got {len(poses)}")
    t0_inv = inverse(poses[0])
    motions = [p @ t0_inv for p in poses[1:]]
    rotvecs = np.array([_rotation_vector(m[:3, :3]) for m in motions])
    translations = np.array([m[:3, 3] for m in motions])
    angles = np.linalg.norm(rotvecs, axis=1)

    if angles.max() > min_angle:
        # Axis: principal direction of the rotation vectors (all parallel for one joint).
        _, _, vt = np.linalg.svd(rotvecs)
        axis = vt[0]
        far = int(np.argmax(angles))
        if rotvecs[far] @ axis < 0:
            axis = -axis
        values = rotvecs @ axis
        # Point: least squares over (I - R_k) p = t_k, made unique by the point nearest the
        # part's first origin.
        a = np.concatenate([np.eye(3) - axis_angle_matrix(axis, v) for v in values])
        b = translations.reshape(-1)
        p, *_ = np.linalg.lstsq(a, b, rcond=None)
        origin = poses[0][:3, 3]
        point = p + axis * np.dot(origin - p, axis)
        predicted = [_revolute(axis, point, v) for v in values]
        kind = "revolute"
    else:
        _, _, vt = np.linalg.svd(translations)
        axis = vt[0]
        far = int(np.argmax(np.linalg.norm(translations, axis=1)))
        if translations[far] @ axis < 0:
            axis = -axis
        values = translations @ axis
        point = poses[0][:3, 3].copy()
        predicted = [_prismatic(axis, v) for v in values]
        kind = "prismatic"
    residual = _pose_residual(motions, predicted, poses[0])
    return ScrewEstimate(kind, axis, point, np.concatenate([[0.0], values]), residual)


def _revolute(axis, point, angle) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = axis_angle_matrix(axis, angle)
    m[:3, 3] = point - m[:3, :3] @ point
    return m


def _prismatic(axis, distance) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = axis * distance
    return m


def _pose_residual(measured, predicted, first_pose) -> float:
    """RMS distance between where the part's origin and unit axis tips go, measured vs fit."""
    origin, rot = first_pose[:3, 3], first_pose[:3, :3]
    pts = np.column_stack([origin, origin[:, None] + rot])  # origin and the three axis tips
    pts_h = np.vstack([pts, np.ones(pts.shape[1])])
    err = [np.linalg.norm((m @ pts_h - p @ pts_h)[:3], axis=0) for m, p in
           zip(measured, predicted, strict=True)]
    return float(np.sqrt(np.mean(np.square(err))))
