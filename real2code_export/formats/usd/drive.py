"""Joint drives (``PhysicsDriveAPI:<instance>``: a simulator's actuator on a joint axis, its
target and gains). The model has no actuators, so the USD reader keeps each drive in the
object's metadata under :data:`DRIVES_KEY` (warned) and the USD writer writes it back on the
joint it drives; the other formats carry the metadata only. A generic joint's (D6) drive on
one of its free axes (``rotX``) drives the model joint of that axis (``<joint>_rotX``, or the
joint itself when it is the only free axis), as an ``angular`` or ``linear`` drive.

An entry: ``joint`` (the model joint's name), ``instance`` (``angular`` or ``linear``) and
``attributes`` (``type``: force or acceleration; ``stiffness``, ``damping``,
``targetPosition``, ``targetVelocity``, ``maxForce`` as UsdPhysics states them, angles in
degrees, lengths in metres, masses in kilograms).
"""

from __future__ import annotations

import math

DRIVES_KEY = "usd_drives"
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
    """Each kept drive on its joint's prim (``joint_prim(name)``: (the prim spec, the drive
    instance there, None for the entry's own: a generic joint's axis takes its axis's), or
    None where the joint has none: a drive of a joint the object no longer has is warned)."""
    from ...errors import ModelError, warn

    entries = obj.metadata.get(DRIVES_KEY, [])
    where = f"object {obj.name!r} metadata {DRIVES_KEY!r}"
    if not isinstance(entries, list):
        raise ModelError(where, "must be a list of drives")
    for k, e in enumerate(entries):
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
