"""Fitted dynamics the model's ``Dynamics`` has no field for, kept in the object's metadata
under one namespaced key so that every format that carries free data keeps them, and every
replay of the object (calibrated or not) applies them:

    metadata["real2code:dynamics"] = {
        "<joint>": {
            "offset": {"effort": c},                         # constant generalized force
            "asymmetric_friction": {"friction_pos": c+, "friction_neg": c-,
                                    "damping_pos": b+, "damping_neg": b-},
            "limit": {"timeconst": tc, "dampratio": z},       # MJCF solreflimit
            "friction": {"timeconst": tc, "dampratio": 1.0},  # MJCF solreffriction
            "encoder_offset": {"position": d},                # the sensor reads q + d
            "effort_delay": {"seconds": s},                   # position read s late (open loop)
        }, ...}

The force law for a simulator without these attributes (MuJoCo: ``qfrc_applied``):
f(v) = c - (c+ - c-)/2 - (b+ - b-)/2 * |v|, on top of the symmetric friction (c+ + c-)/2 and
damping (b+ + b-)/2 stored in ``Dynamics`` (see ``simulate.AppliedLaw``).
"""

from __future__ import annotations

from typing import Any

from ..model import ArticulatedObject
from .simulate import AppliedLaw, set_direction_dependent_damping

METADATA_KEY = "real2code:dynamics"
LAW = ("f(v) = offset - (friction_pos - friction_neg)/2 - (damping_pos - damping_neg)/2 * |v|"
       " on top of Dynamics.friction = (friction_pos + friction_neg)/2 and Dynamics.damping ="
       " (damping_pos + damping_neg)/2")


def joint_extras(obj: ArticulatedObject, joint: str) -> dict[str, Any]:
    data = obj.metadata.get(METADATA_KEY)
    if not isinstance(data, dict):
        return {}
    entry = data.get(joint)
    return entry if isinstance(entry, dict) else {}


def base_law(obj: ArticulatedObject, joint: str) -> AppliedLaw:
    """The applied-force law the object's metadata gives ``joint`` (zero if none)."""
    x = joint_extras(obj, joint)
    offset = float(x.get("offset", {}).get("effort", 0.0))
    asym = x.get("asymmetric_friction", {})
    if asym:
        return AppliedLaw(offset, 0.5 * (asym["friction_pos"] - asym["friction_neg"]),
                          0.5 * (asym["damping_pos"] - asym["damping_neg"]))
    return AppliedLaw(offset)


def write_spec_extras(obj: ArticulatedObject, spec, joints) -> None:
    """Soft-constraint settings and the direction-dependent damping from the metadata into
    a replay spec (the constant forces are applied by the replay)."""
    for name in joints:
        x = joint_extras(obj, name)
        j = spec.joint(name)
        asym = x.get("asymmetric_friction")
        if asym:
            set_direction_dependent_damping(spec, name, asym["damping_pos"],
                                            asym["damping_neg"])
        if "limit" in x:
            j.solref_limit = [x["limit"]["timeconst"], x["limit"]["dampratio"]]
        if "friction" in x:
            j.solref_friction = [x["friction"]["timeconst"], x["friction"]["dampratio"]]


def set_joint_extras(obj: ArticulatedObject, joint: str, extras: dict[str, Any]) -> None:
    data = dict(obj.metadata.get(METADATA_KEY) or {})
    if extras:
        data[joint] = {k: extras[k] for k in sorted(extras)}
    else:
        data.pop(joint, None)
    if data:
        obj.metadata[METADATA_KEY] = {k: data[k] for k in sorted(data)}
    else:
        obj.metadata.pop(METADATA_KEY, None)
