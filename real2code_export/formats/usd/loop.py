"""Joints that close kinematic loops (a four-bar's fourth hinge): the model is a tree, so the
USD reader keeps each such joint aside, in the object's metadata under :data:`LOOPS_KEY`, as
the file states it, and the USD writer writes it back, excluded from the articulation
(``physics:excludeFromArticulation``: PhysX and Newton solve it as a constraint beside the
tree, as the source had it). MuJoCo gets an equality ``connect`` (the reader puts it in the
kept MJCF elements); URDF and glTF carry the metadata only.

An entry: ``name``, ``type`` (revolute, continuous, prismatic, fixed, ball or generic),
``body0``/``body1`` (part names), ``frame0``/``frame1`` (the joint frame in each part's
frame: ``translation`` in metres, ``rotation`` a w, x, y, z quaternion), ``axis`` (X, Y or
Z; a revolute or prismatic joint), ``limits`` ([lower, upper] in degrees or metres, or
None), ``cone`` (a spherical joint's two cone angles in degrees, or None) and, for a
generic joint (D6), ``dofs``: its free axes, each ``[name, lower, upper]`` (degrees or
metres, None for no limit); ``drives``: its drives, each ``instance`` (``angular``,
``linear``, or a generic joint's axis) and ``attributes`` (:mod:`.drive`).
"""

from __future__ import annotations

import math

import numpy as np

from ... import transforms as tf
from ...errors import ModelError, warn
from ...model import JointType

LOOPS_KEY = "loop_joints"
_PRIMS = {"revolute": "PhysicsRevoluteJoint", "continuous": "PhysicsRevoluteJoint",
          "prismatic": "PhysicsPrismaticJoint", "fixed": "PhysicsFixedJoint",
          "ball": "PhysicsSphericalJoint", "generic": "PhysicsJoint"}


def described(name: str, edge, frames: list[np.ndarray], parts: list[str], prim,
              mpu: float, kpu: float) -> dict:
    """The metadata entry of a loop-closing joint (``edge``: the parsed joint,
    ``articulation.Edge``, at ``prim``; ``frames``: its frame in each part's frame, metres;
    ``mpu``, ``kpu``: the stage's metres and kilograms per unit). Its drives too
    (:mod:`.drive`), each on its own instance."""
    from .drive import read_drives

    desc, kind = edge.desc, edge.kind
    entry = {"name": name, "type": "generic" if edge.dofs is not None else kind.value,
             "body0": parts[0], "body1": parts[1]}
    for side, frame in enumerate(frames):
        entry[f"frame{side}"] = {"translation": [float(v) for v in frame[:3, 3]],
                                 "rotation": [float(v) for v in tf.matrix_to_quat(frame[:3, :3])]}
    if edge.dofs is not None:
        entry["dofs"] = [[d.name] + ([None, None] if d.lower is None else
                                     [v * (1.0 if d.angular else mpu) for v in (d.lower, d.upper)])
                         for d in edge.dofs]
    elif kind.movable:
        entry["axis"] = str(desc.axis)
        lim = desc.limit
        finite = lim.enabled and math.isfinite(lim.lower) and math.isfinite(lim.upper)
        scale = 1.0 if kind.angular else mpu
        entry["limits"] = [float(lim.lower) * scale, float(lim.upper) * scale] if finite \
            else None
    elif kind is JointType.BALL:
        lim = desc.limit
        cones = [float(lim.lower), float(lim.upper)]
        entry["cone"] = cones if lim.enabled and all(
            math.isfinite(a) and a >= 0.0 for a in cones) else None
    if edge.dofs is not None:
        axes = {d.name: (d.name, "angular" if d.angular else "linear") for d in edge.dofs}
    else:
        axes = {k: (k, k) for k in ("angular", "linear")
                if kind.movable and (k == "angular") == kind.angular}
    drives = read_drives(prim, axes, mpu, kpu)[0]
    if drives:
        entry["drives"] = [{"instance": d["joint"], "attributes": d["attributes"]}
                           for d in drives]
    return entry


def write_loops(layer, obj, joint_path, body_path) -> None:
    """Each loop-closing joint of ``obj``'s metadata as a joint prim excluded from the
    articulation (``joint_path(name)``: where its prim goes; ``body_path(part)``: a part's
    prim). Entries that are not what :func:`described` makes are an error naming them."""
    from pxr import Gf

    from .drive import write_drive
    from .layer import apply, attribute, define, relationship

    entries = obj.metadata.get(LOOPS_KEY, [])
    where = f"object {obj.name!r} metadata {LOOPS_KEY!r}"
    if not isinstance(entries, list):
        raise ModelError(where, "must be a list of joints")
    parts = {p.name for p in obj.parts}
    for k, e in enumerate(entries):
        try:
            kind = _PRIMS[e["type"]]
            ends = [e["body0"], e["body1"]]
            frames = [(Gf.Vec3f(*map(float, e[f"frame{s}"]["translation"])),
                       Gf.Quatf(*map(float, e[f"frame{s}"]["rotation"]))) for s in (0, 1)]
        except (KeyError, TypeError, ValueError) as err:
            raise ModelError(f"{where}[{k}]", f"not a joint as the USD reader keeps it "
                             f"(missing or wrong: {err})") from err
        if not all(p in parts for p in ends):  # (the object changed since it was read)
            warn(f"USD: {where}[{k}] ({e['name']!r}): part(s) "
                 f"{[p for p in ends if p not in parts]} are not the object's: not written")
            continue
        prim = define(layer, joint_path(e["name"]), kind)
        for side, (part, (pos, rot)) in enumerate(zip(ends, frames, strict=True)):
            relationship(prim, f"physics:body{side}", body_path(part))
            attribute(prim, f"physics:localPos{side}", "Point3f", pos)
            attribute(prim, f"physics:localRot{side}", "Quatf", rot)
        attribute(prim, "physics:excludeFromArticulation", "Bool", True, uniform=True)
        if e.get("axis") is not None:
            attribute(prim, "physics:axis", "Token", str(e["axis"]), uniform=True)
        if e.get("limits") is not None:
            attribute(prim, "physics:lowerLimit", "Float", float(e["limits"][0]))
            attribute(prim, "physics:upperLimit", "Float", float(e["limits"][1]))
        if e.get("cone") is not None:
            for side, angle in enumerate(e["cone"]):
                attribute(prim, f"physics:coneAngle{side}Limit", "Float", float(angle))
        for kept in e.get("drives") or []:
            write_drive(prim, str(kept["instance"]), dict(kept["attributes"]))
        if e["type"] == "generic":
            free = {name: (low, high) for name, low, high in e.get("dofs") or []}
            for axis in ("transX", "transY", "transZ", "rotX", "rotY", "rotZ"):
                low, high = free.get(axis, (1.0, -1.0))  # locked: low above high
                if axis in free and low is None:
                    continue  # free, no limit
                apply(prim, f"PhysicsLimitAPI:{axis}")
                attribute(prim, f"limit:{axis}:physics:low", "Float", float(low))
                attribute(prim, f"limit:{axis}:physics:high", "Float", float(high))


def same(read, kept, tol: float = 1e-6) -> bool:
    """Whether an entry read from a file is ``kept`` (the metadata's) to the file's float32
    precision: the same structure, numbers within ``tol`` (relative, or absolute near 0)."""
    if isinstance(read, dict) and isinstance(kept, dict):
        return set(read) == set(kept) and all(same(read[k], kept[k], tol) for k in read)
    if isinstance(read, list) and isinstance(kept, list):
        return len(read) == len(kept) and all(
            same(a, b, tol) for a, b in zip(read, kept, strict=True))
    if isinstance(read, float | int) and isinstance(kept, float | int) \
            and not isinstance(read, bool) and not isinstance(kept, bool):
        return abs(read - kept) <= tol * max(1.0, abs(kept))
    return read == kept
