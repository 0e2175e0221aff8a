"""Joint drives (``PhysicsDriveAPI:<instance>``: a simulator's actuator on a joint axis, its
target and gains) <-> the model's :class:`~real2code_export.model.Drive`.

A drive of ``physics:type`` force is the force ``stiffness * (targetPosition - q) +
damping * (targetVelocity - qdot)``, clamped to ``maxForce``; on an angular drive the
stiffness and damping are per degree and the targets in degrees (UsdPhysics; Newton 1.8's
importer multiplies the gains by 180 / pi and the targets by pi / 180, PhysX reads them so).
It is a model drive (:func:`drive_from_usd`, :func:`usd_from_drive`) when it is one of the
model's three laws: a stiffness (a position drive, no velocity target), a damping alone (a
velocity drive, no position target), or no gain at all and no target (an effort drive: what
Newton's importer makes of it, ``JointTargetMode.EFFORT``). What UsdPhysics has no place for
(an MJCF actuator's name, gear and command range, an effort drive's command) is in our
``real2code:drive:<instance>:*`` attributes on the joint.

Any other drive (an ``acceleration`` drive, which PhysX scales by the joint's inertia and
no other format has; both targets; a target without its gain) stays what it was before the
model had drives: the USD reader keeps it in the object's metadata under
:data:`DRIVES_KEY` (warned) and the USD writer writes it back on the joint it drives; the
other formats carry the metadata only. A generic joint's (D6) drive on
one of its free axes (``rotX``) drives the model joint of that axis (``<joint>_rotX``, or the
joint itself when it is the only free axis), as an ``angular`` or ``linear`` drive.

An entry: ``joint`` (the model joint's name), ``instance`` (``angular`` or ``linear``) and
``attributes`` (``type``: force or acceleration; ``stiffness``, ``damping``,
``targetPosition``, ``targetVelocity``, ``maxForce`` as UsdPhysics states them, angles in
degrees, lengths in metres, masses in kilograms).
"""

from __future__ import annotations

import math

from ...model import Drive, DriveKind

DRIVES_KEY = "usd_drives"
OURS = "real2code:drive"  # real2code:drive:<instance>:<field>: what UsdPhysics has no place for
_FLOATS = ("stiffness", "damping", "targetPosition", "targetVelocity", "maxForce")
# each value's length and mass dimensions (metres, kilograms) on a linear and an angular
# drive: stage units -> metres and kilograms
_DIMENSIONS = {
    "linear": {"stiffness": (0, 1), "damping": (0, 1), "targetPosition": (1, 0),
               "targetVelocity": (1, 0), "maxForce": (1, 1)},
    "angular": {"stiffness": (2, 1), "damping": (2, 1), "targetPosition": (0, 0),
                "targetVelocity": (0, 0), "maxForce": (2, 1)},
}


def read_drives(prim, joints: dict[str, tuple[str, str]], mpu: float,
                kpu: float) -> tuple[list[dict], list[str]]:
    """The drives on joint ``prim`` (``joints``: its drive instances -> (model joint,
    angular or linear)), and the instances that drive no model joint (a locked axis)."""
    applied = {s.split(":", 1)[1] for s in prim.GetAppliedSchemas()
               if s.startswith("PhysicsDriveAPI:")}
    idle = sorted(applied - set(joints))
    entries = []
    for instance in joints:  # (in the joints' order, whatever order the file applies them)
        if instance not in applied:
            continue
        joint, kind = joints[instance]
        prefix = f"drive:{instance}:physics:"
        attributes = {}
        kept = prim.GetAttribute(prefix + "type")
        if kept and kept.HasAuthoredValue():
            attributes["type"] = str(kept.Get())
        for name in _FLOATS:
            attr = prim.GetAttribute(prefix + name)
            # (an infinite maxForce is no limit: the schema's fallback, not written)
            if attr and attr.HasAuthoredValue() and attr.Get() is not None \
                    and math.isfinite(attr.Get()):
                metres, kilograms = _DIMENSIONS[kind][name]
                attributes[name] = float(attr.Get()) * mpu**metres * kpu**kilograms
        entries.append({"joint": joint, "instance": kind, "attributes": attributes})
    return entries, idle


def write_drives(layer, obj, joint_prim) -> None:
    """Each model joint's drive, and each kept drive (of a joint without one), on its
    joint's prim (``joint_prim(name)``: (the prim spec, the drive
    instance there, None for the entry's own: a generic joint's axis takes its axis's), or
    None where the joint has none: a drive of a joint the object no longer has is warned)."""
    from ...errors import ModelError, warn

    entries = obj.metadata.get(DRIVES_KEY, [])
    where = f"object {obj.name!r} metadata {DRIVES_KEY!r}"
    if not isinstance(entries, list):
        raise ModelError(where, "must be a list of drives")
    driven = {j.name for j in obj.joints if j.drive is not None}
    for k, e in enumerate(entries):
        if isinstance(e, dict) and e.get("joint") in driven:
            warn(f"USD: {where}[{k}]: joint {e.get('joint')!r} has a drive of the model, "
                 "written instead of this one")
            continue
        try:
            joint, instance, attributes = e["joint"], e["instance"], dict(e["attributes"])
            if instance not in _DIMENSIONS:
                raise ValueError(f"instance {instance!r}")
            values = {n: float(attributes[n]) for n in _FLOATS if n in attributes}
        except (KeyError, TypeError, ValueError) as err:
            raise ModelError(f"{where}[{k}]", f"not a drive as the USD reader keeps it "
                             f"(missing or wrong: {err})") from err
        found = joint_prim(joint)
        if found is None or not found[0]:
            warn(f"USD: {where}[{k}]: joint {joint!r} is not a joint prim of the object: its "
                 "drive is not written")
            continue
        prim, own = found
        write_drive(prim, own or instance, {**values, **({"type": str(attributes["type"])}
                                                 if "type" in attributes else {})})
    for j in obj.joints:
        found = joint_prim(j.name) if j.drive is not None else None
        if j.drive is not None and (found is None or not found[0]):
            warn(f"USD: object {obj.name!r}: joint {j.name!r} has no joint prim: its drive "
                 "is not written")
        elif j.drive is not None:
            kind = "angular" if j.type.angular else "linear"
            write_model_drive(found[0], found[1] or kind, j.drive, j.type.angular)


def write_drive(prim, instance: str, attributes: dict) -> None:
    """One drive (``attributes`` as :func:`read_drives` keeps them) on joint ``prim``."""
    from .layer import apply, attribute

    apply(prim, f"PhysicsDriveAPI:{instance}")
    if "type" in attributes:
        attribute(prim, f"drive:{instance}:physics:type", "Token", str(attributes["type"]),
                  uniform=True)
    for name in _FLOATS:
        if name in attributes:
            attribute(prim, f"drive:{instance}:physics:{name}", "Float",
                      float(attributes[name]))


def same(read: dict, kept: dict | None, tol: float = 1e-6) -> bool:
    """Whether a drive read from a file is ``kept`` (a metadata entry) to the file's float32
    precision (relative ``tol``)."""
    if not isinstance(kept, dict) or not isinstance(kept.get("attributes"), dict):
        return False
    a, b = read["attributes"], kept["attributes"]
    if set(a) != set(b) or a.get("type") != b.get("type"):
        return False
    try:
        return all(abs(float(a[n]) - float(b[n])) <= tol * max(1e-30, abs(float(b[n])))
                   for n in _FLOATS if n in a)
    except (TypeError, ValueError):
        return False


def drive_from_usd(attributes: dict, angular: bool,
                   ours: dict | None = None) -> tuple[Drive | None, str]:
    """The model drive a drive read by :func:`read_drives` is (``attributes`` as it keeps
    them: degrees, metres, kilograms; ``ours``: :func:`read_ours`), or (None, why not)."""
    if attributes.get("type", "force") != "force":
        return None, (f"a drive of type {attributes.get('type')!r} (PhysX scales it by the "
                      "joint's inertia: no other format has one)")
    per_degree = 180.0 / math.pi if angular else 1.0  # stiffness, damping: per degree
    degree = math.pi / 180.0 if angular else 1.0  # targets: degrees
    stiffness = _shortest(attributes.get("stiffness", 0.0), per_degree)
    damping = _shortest(attributes.get("damping", 0.0), per_degree)
    position = _shortest(attributes.get("targetPosition", 0.0), degree)
    velocity = _shortest(attributes.get("targetVelocity", 0.0), degree)
    ours = ours or {}
    if stiffness < 0 or damping < 0:
        return None, "a negative stiffness or damping"
    if stiffness > 0:
        if velocity:
            return None, "both a position and a velocity target"
        kind, target = DriveKind.POSITION, position
    elif damping > 0:
        if position:
            return None, "a position target without stiffness"
        kind, target = DriveKind.VELOCITY, velocity
    else:
        if position or velocity:
            return None, "a target without a gain"
        kind, target = DriveKind.EFFORT, ours.get("target", 0.0)
    force = attributes.get("maxForce")
    force = None if force is None else _shortest(force, 1.0)
    if force is not None and force <= 0:
        return None, "a maxForce of 0"
    drive = Drive(kind, stiffness, damping, target, force, ours.get("targetRange"),
                  ours.get("name"), ours.get("gear", 1.0))
    problem = drive.problem()
    return (None, problem) if problem else (drive, "")


def _shortest(stated: float, scale: float) -> float:
    """``stated * scale``, as the shortest decimal the file's float32 ``stated`` is the
    rounding of (an MJCF ``kp="50"`` written per degree comes back 50, not 50.00000025); the
    product itself where ``stated`` is no float32 (a stage in other units, scaled)."""
    import numpy as np

    value = stated * scale
    if float(np.float32(stated)) != stated:
        return value
    for digits in range(1, 18):
        candidate = float(f"{value:.{digits}g}")
        if np.float32(candidate / scale) == np.float32(stated):
            return candidate
    return value


def usd_from_drive(drive: Drive, angular: bool) -> tuple[dict, dict]:
    """(the drive's UsdPhysics attributes as :func:`read_drives` keeps them, what only our
    attributes hold): :func:`drive_from_usd` inverted."""
    per_degree = math.pi / 180.0 if angular else 1.0
    degree = 180.0 / math.pi if angular else 1.0
    attributes = {"type": "force", "stiffness": drive.stiffness * per_degree,
                  "damping": drive.damping * per_degree}
    if drive.kind is DriveKind.POSITION:
        attributes["targetPosition"] = drive.target * degree
    elif drive.kind is DriveKind.VELOCITY:
        attributes["targetVelocity"] = drive.target * degree
    if drive.force_limit is not None:
        attributes["maxForce"] = drive.force_limit
    ours = {}
    if drive.kind is DriveKind.EFFORT and drive.target:
        ours["target"] = drive.target
    if drive.target_range is not None:
        ours["targetRange"] = drive.target_range
    if drive.name is not None:
        ours["name"] = drive.name
    if drive.gear != 1.0:
        ours["gear"] = drive.gear
    return attributes, ours


def read_ours(prim, instance: str) -> dict:
    """Our attributes of the drive ``instance`` on joint ``prim`` (SI units, radians)."""
    out = {}
    for name in ("target", "gear", "targetRange", "name"):
        attr = prim.GetAttribute(f"{OURS}:{instance}:{name}")
        if attr and attr.HasAuthoredValue():
            value = attr.Get()
            out[name] = str(value) if name == "name" else \
                tuple(float(v) for v in value) if name == "targetRange" else float(value)
    return out


def write_model_drive(prim, instance: str, drive: Drive, angular: bool) -> None:
    """A model drive on joint ``prim`` as drive ``instance`` (and our attributes)."""
    from .layer import attribute

    attributes, ours = usd_from_drive(drive, angular)
    write_drive(prim, instance, attributes)
    for name, value in ours.items():
        kind = "String" if name == "name" else "Double2" if name == "targetRange" else "Double"
        attribute(prim, f"{OURS}:{instance}:{name}", kind, value, custom=True,
                  uniform=name == "name")
