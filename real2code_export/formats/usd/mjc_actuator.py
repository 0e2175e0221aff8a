"""MuJoCo's actuators in USD: ``MjcActuator`` prims of MuJoCo's MjcPhysics schema, which
mujoco-usd-converter writes for an MJCF file's ``<actuator>`` elements (and Newton's
importer reads) -> the model's joint drives.

A prim holds the actuator's spec values as MJCF states them, uncompiled: gain, bias and
activation types and parameters, gear, the ranges with their ``auto`` limits,
``inheritrange``, a ``dampratio`` stored as a positive ``biasPrm[2]``. What force they make
is MuJoCo's compiler's to say (a dampratio's damping depends on the joint's inertia,
``inheritrange`` on its range), so each one on a hinge or slide joint is added to the
model's tree as MuJoCo takes it (``mujoco_actuators.kinematic_spec``), compiled, and read by
the MJCF reader's own rule (``mujoco_actuators.drive_of``). One that is no drive of the
model (a site, tendon or body transmission, activation dynamics, a second actuator on a
joint ...) is kept as an MJCF ``<general>`` element in the metadata the MJCF writer writes
back (its ``kept_elements``), warned. Only the attributes a prim authors are set: the schema's fallbacks
are MuJoCo's defaults (usd-core does not know the schema, so they are not read from it).
"""

from __future__ import annotations

import numpy as np

from ...errors import warn
from ...model import ArticulatedObject, JointType, sanitize_name
from .conventions import source_name

TYPE_NAME = "MjcActuator"
PREFIX = "mjc:"
# MjcPhysics attribute -> the MJCF attribute (the MjSpec actuator field of the same name)
VALUES = {"gainPrm": "gainprm", "biasPrm": "biasprm", "dynPrm": "dynprm", "gear": "gear",
          "actDim": "actdim", "actEarly": "actearly", "group": "group",
          "inheritRange": "inheritrange", "crankLength": "cranklength"}
TYPES = {"gainType": ("gaintype", "mjtGain", "mjGAIN_"),
         "biasType": ("biastype", "mjtBias", "mjBIAS_"),
         "dynType": ("dyntype", "mjtDyn", "mjDYN_")}
LIMITED = {"ctrlLimited": "ctrllimited", "forceLimited": "forcelimited",
           "actLimited": "actlimited"}
RANGES = {"ctrlRange": "ctrlrange", "forceRange": "forcerange", "actRange": "actrange",
          "lengthRange": "lengthrange"}


def mjcf_attributes(prim) -> dict[str, object]:
    """The MJCF attributes a prim authors (values as numbers, lists and tokens)."""
    out: dict[str, object] = {}

    def authored(name: str):
        attr = prim.GetAttribute(PREFIX + name)
        return attr.Get() if attr and attr.HasAuthoredValue() else None

    for usd_name, mjcf in VALUES.items():
        value = authored(usd_name)
        if value is not None:
            out[mjcf] = [float(v) for v in value] if hasattr(value, "__len__") else value
    for usd_name, (mjcf, _, _) in TYPES.items():
        value = authored(usd_name)
        if value is not None:
            out[mjcf] = str(value)
    for usd_name, mjcf in LIMITED.items():
        value = authored(usd_name)
        if value is not None:
            out[mjcf] = str(value)
    for usd_name, mjcf in RANGES.items():
        low, high = authored(f"{usd_name}:min"), authored(f"{usd_name}:max")
        if low is not None or high is not None:
            out[mjcf] = [float(low or 0.0), float(high or 0.0)]
    return out


def read_actuators(path, stage, obj: ArticulatedObject, prims: list,
                   joint_at: dict[str, str]) -> ArticulatedObject:
    """``obj`` with the stage's MjcActuator prims (``prims``, in stage order: the reader's
    traversal found them) as its joints' drives where MuJoCo compiles them to one (module
    docstring), the others kept as MJCF ``<general>`` elements in its metadata;
    ``joint_at``: joint prim path -> model joint name."""
    if not prims:
        return obj
    from .. import FORMATS

    kept_key = FORMATS["mjcf"].kept_elements
    joints = {j.name: j for j in obj.joints}
    on_joint, kept, why = [], [], []  # (prim, joint, attributes); (prim, element); notes
    for prim in prims:
        attributes = mjcf_attributes(prim)
        targets = prim.GetRelationship(PREFIX + "target").GetTargets() \
            if prim.GetRelationship(PREFIX + "target") else []
        target = str(targets[0]) if targets else None
        joint = joints.get(joint_at.get(target, ""))
        if joint is not None and joint.type in (JointType.REVOLUTE, JointType.CONTINUOUS,
                                                JointType.PRISMATIC):
            on_joint.append((prim, joint.name, attributes))
        else:
            kept.append((prim, _element(prim, attributes, _target(stage, target, joint_at))))
            why.append(f"<{prim.GetPath()}> (its target <{target}> is no hinge or slide "
                       "joint)" if target else f"<{prim.GetPath()}> (no target)")
    drives = _compiled_drives(obj, on_joint) if on_joint else []
    taken = set()
    for (prim, joint, attributes), (drive, reason) in zip(on_joint, drives, strict=True):
        if drive is not None and joints[joint].drive is None and joint not in taken:
            joints[joint].drive = drive
            taken.add(joint)
            continue
        reason = reason or "a second actuator on the joint"
        kept.append((prim, _element(prim, attributes, ("joint", joint))))
        why.append(f"<{prim.GetPath()}> ({reason})")
    if taken:
        warn(f"{path}: MuJoCo actuators (MjcActuator) read as the drives of joint(s) "
             f"{', '.join(sorted(taken))}, as MuJoCo compiles them")
    if kept:
        from lxml import etree

        sections = dict(obj.metadata.get(kept_key, {}))
        section = etree.fromstring(sections["actuator"]) if "actuator" in sections \
            else etree.Element("actuator")  # (after the file's own, as MuJoCo numbers them)
        section.extend(element for _, element in kept)
        sections["actuator"] = etree.tostring(section, encoding="unicode")
        obj.metadata[kept_key] = sections
        warn(f"{path}: MuJoCo actuators (MjcActuator) that are no drive of the model: "
             f"{', '.join(why)}; kept as MJCF <general> elements in the metadata "
             f"{kept_key!r}, which the MJCF export writes back")
    return obj


def _target(stage, target: str | None, joint_at: dict[str, str]) -> tuple[str, str] | None:
    """The MJCF transmission a target prim is (joint, body or site), by the model's names
    where it has one, else the prim's name."""
    from pxr import UsdPhysics


    if target is None:
        return None
    if target in joint_at:
        return "joint", joint_at[target]
    prim = stage.GetPrimAtPath(target)
    if not prim:
        return None
    kind = "body" if prim.HasAPI(UsdPhysics.RigidBodyAPI) else \
        "tendon" if "Tendon" in prim.GetTypeName() else "site"
    return kind, sanitize_name(source_name(prim))


def _element(prim, attributes: dict[str, object], target: tuple[str, str] | None):
    """The MJCF ``<general>`` element an MjcActuator prim states."""
    from lxml import etree


    el = etree.Element("general", name=sanitize_name(source_name(prim)))
    if target is not None:
        el.set(*target)
    for key, value in attributes.items():
        el.set(key, " ".join(_number(v) for v in value) if isinstance(value, list)
               else str(value).lower() if isinstance(value, (bool, str))
               else str(value) if isinstance(value, int) else _number(value))
    return el


def _number(value: float) -> str:
    return repr(float(value) + 0.0)


def _compiled_drives(obj: ArticulatedObject, on_joint: list) -> list:
    """(drive or None, why not) of each (prim, joint, attributes), as MuJoCo compiles the
    actuator on the model (in memory: no file is written)."""
    import mujoco

    from ...mujoco_actuators import drive_of, kinematic_spec

    spec = kinematic_spec(obj)
    for prim, joint, attributes in on_joint:
        act = spec.add_actuator(name=sanitize_name(source_name(prim)), target=joint,
                                trntype=mujoco.mjtTrn.mjTRN_JOINT)
        for key, value in attributes.items():
            if key in ("ctrllimited", "forcelimited", "actlimited"):
                value = getattr(mujoco.mjtLimited, f"mjLIMITED_{str(value).upper()}")
            else:
                kind = next((t for t in TYPES.values() if t[0] == key), None)
                if kind is not None:
                    value = getattr(getattr(mujoco, kind[1]), f"{kind[2]}{str(value).upper()}")
                elif isinstance(value, list):  # (the field's length: MuJoCo's zeros after)
                    field = np.zeros_like(np.asarray(getattr(act, key), dtype=np.float64))
                    field[:len(value)] = value[:len(field)]
                    value = field
            setattr(act, key, value)
    try:
        m = spec.compile()
    except (ValueError, AttributeError) as e:  # MuJoCo refuses them: kept, with its reason
        return [(None, f"MuJoCo refuses the actuators: {e}")] * len(on_joint)
    return [drive_of(m, k) for k in range(len(on_joint))]
