"""Model-to-model simplifications."""

from __future__ import annotations

import dataclasses

import numpy as np

from .errors import warn
from .model import ArticulatedObject, Inertial, JointType, Mesh, Part


def merge_fixed_joints(obj: ArticulatedObject) -> ArticulatedObject:
    """The same object with every part on a fixed joint merged into its parent: one part
    per rigid body (meshes, collision pieces and inertials combined in the parent frame),
    joints below re-attached with their origins composed. Names of the kept parts stay."""
    from .inertia import combine_inertials

    keep_of: dict[str, str] = {}  # part -> the kept part it is merged into
    offset: dict[str, np.ndarray] = {}  # part frame in the kept part's frame
    parent = obj.tree().parent
    for part in obj.parts_in_tree_order():
        j = parent.get(part.name)
        if j is not None and j.type is JointType.FIXED:
            keep_of[part.name] = keep_of[j.parent]
            offset[part.name] = offset[j.parent] @ j.origin
        else:
            keep_of[part.name] = part.name
            offset[part.name] = np.eye(4)

    members_of: dict[str, list[Part]] = {}  # kept part -> the parts merged into it, in order
    for p in obj.parts:
        members_of.setdefault(keep_of[p.name], []).append(p)
    parts = []
    for kept in (p for p in obj.parts if keep_of[p.name] == p.name):
        members = members_of[kept.name]
        visuals = [p.visual.transformed(offset[p.name]) for p in members if p.visual is not None]
        collision = [m.transformed(offset[p.name]) for p in members for m in p.collision]
        inertials = [(p.inertial, offset[p.name]) for p in members if p.inertial is not None]
        inertial: Inertial | None = None
        if len(inertials) == 1 and np.allclose(inertials[0][1], np.eye(4)):
            inertial = inertials[0][0]
        elif inertials:
            inertial = combine_inertials(inertials)
        visual = None
        if len(visuals) == 1:
            visual = visuals[0]
        elif visuals:
            visual = Mesh.concatenate(visuals)
        textured = [p for p in members if p.texture is not None or p.maps]
        texture, maps = (textured[0].texture, textured[0].maps) if len(textured) == 1 \
            else (None, {})
        if textured and (len(textured) > 1 or visual is None or visual.uv is None):
            warn(f"part {kept.name!r}: merged with the parts fixed to it, whose meshes do not all "
                 "carry texture coordinates for one material: its images are not kept")
            texture, maps = None, {}
        parts.append(Part(kept.name, visual, collision, inertial, kept.color, texture, dict(maps)))

    joints = []
    for j in obj.joints:
        if j.type is JointType.FIXED:
            continue
        # replace, not a new Joint: every field the model grows (mimic, drive limits) is kept
        joints.append(dataclasses.replace(
            j, parent=keep_of[j.parent], origin=offset[j.parent] @ j.origin,
            axis=j.axis.copy(), limits=_copy(j.limits), dynamics=_copy(j.dynamics),
            mimic=_copy(j.mimic), drive_limits=_copy(j.drive_limits)))
    return ArticulatedObject(obj.name, parts, joints, dict(obj.metadata))


def _copy(value):
    return None if value is None else dataclasses.replace(value)
