"""Where a model's parts and joints are in the world at a configuration: the model's forward
kinematics applied to its meshes and joint axes (for rendering, fitting and evaluation)."""

from __future__ import annotations

import numpy as np

from .model import ArticulatedObject, Mesh, forward_kinematics


def world_part_meshes(obj: ArticulatedObject, q: dict[str, float] | None = None,
                      base: np.ndarray | None = None) -> dict[str, Mesh]:
    """Every part's visual mesh in the world frame at ``q`` (default: the observed state)."""
    poses = forward_kinematics(obj, obj.observed_configuration() if q is None else q, base)
    return {p.name: p.visual.transformed(poses[p.name]) for p in obj.parts if p.visual is not None}


def world_joints(obj: ArticulatedObject, q: dict[str, float] | None = None,
                 base: np.ndarray | None = None) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each movable joint's world axis (unit) and a point on it at ``q``."""
    q = obj.observed_configuration() if q is None else q
    poses = forward_kinematics(obj, q, base)
    out = {}
    for j in obj.movable_joints:
        frame = poses[j.parent] @ j.origin
        out[j.name] = (frame[:3, :3] @ j.axis, frame[:3, 3].copy())
    return out
