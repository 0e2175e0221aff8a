"""A joint's base inertial parameters: what its motion depends on, as physics has them.

About a hinge axis a (through the child frame's origin, the other joints held where the
model puts them): the moving parts' inertia about the axis, and their first moment (mass
times centre-of-mass offset) in the two directions normal to the axis, where gravity acts on
it; along a slide, the moving mass. Computed from the model's parts (mass, centre of mass,
inertia tensor), so the nominal and the calibrated model are set side by side in the
report and any fitted change is one a physically valid inertial gives.
"""

from __future__ import annotations

import numpy as np

from ..model import ArticulatedObject, forward_kinematics
from .spec import subtree_bodies


def base_parameters(obj: ArticulatedObject, joint: str) -> dict:
    j = obj.joint(joint)
    config = {m.name: m.state for m in obj.movable_joints if m.name != joint}
    poses = forward_kinematics(obj, config)
    frame_inv = np.linalg.inv(poses[j.child])
    a = j.axis / np.linalg.norm(j.axis)
    mass = inertia = 0.0
    first = np.zeros(3)
    for name in subtree_bodies(obj, joint):
        part = obj.part(name)
        if part.inertial is None or part.inertial.mass <= 0:
            continue
        pose = frame_inv @ poses[name]
        rot = pose[:3, :3]
        c = pose[:3, :3] @ part.inertial.com + pose[:3, 3]
        m = part.inertial.mass
        about_com = rot @ part.inertial.inertia @ rot.T
        parallel = m * (float(c @ c) * np.eye(3) - np.outer(c, c))
        mass += m
        inertia += float(a @ (about_com + parallel) @ a)
        first += m * (c - a * float(a @ c))
    if not j.type.angular:
        return {"moving_mass": mass, "unit": {"moving_mass": "kg"}}
    # the two directions normal to the axis: along the nominal first moment and a x it
    n1 = first / np.linalg.norm(first) if np.linalg.norm(first) > 1e-12 else \
        np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
    n1 = n1 / np.linalg.norm(n1)
    n2 = np.cross(a, n1)
    return {"inertia_about_axis": inertia, "first_moment": [float(first @ n1),
                                                            float(first @ n2)],
            "first_moment_directions": [n1.tolist(), n2.tolist()],
            "unit": {"inertia_about_axis": "kg m^2", "first_moment": "kg m"}}


def compared(nominal: ArticulatedObject, calibrated: ArticulatedObject, joint: str) -> dict:
    """The base parameters of both models (the first moment of the calibrated one in the
    nominal one's directions)."""
    before = base_parameters(nominal, joint)
    after = base_parameters(calibrated, joint)
    if "first_moment_directions" in before:
        dirs = np.array(before["first_moment_directions"])
        cal = np.array(after["first_moment_directions"]).T @ np.array(after["first_moment"])
        after["first_moment"] = (dirs @ cal).tolist()
        after["first_moment_directions"] = before["first_moment_directions"]
    return {"nominal": before, "calibrated": after}
