"""MJCF actuators <-> the model's joint drives: the reader takes a compiled actuator that
is one (:func:`~real2code_export.mujoco_actuators.drive_of`, shared with USD's
``MjcActuator``); the writer writes a drive back as the shortcut of its kind with every value
explicit (:func:`actuator_element`), so no default class of the file changes it. Actuators
that are no drive stay kept as XML (:mod:`.kept`).
"""

from __future__ import annotations

from ...model import Drive, DriveKind
from ...mujoco_actuators import drive_of

__all__ = ["actuator_element", "drive_of"]


def actuator_element(drive: Drive, joint: str):
    """The drive as an MJCF actuator element on ``joint`` (lxml), its gear and ctrl scale
    kept: the shortcut of its kind, every value that shapes the force written."""
    from lxml import etree

    g = drive.gear
    tag = {DriveKind.POSITION: "position", DriveKind.VELOCITY: "velocity",
           DriveKind.EFFORT: "motor"}[drive.kind]
    el = etree.Element(tag)
    if drive.name is not None:
        el.set("name", drive.name)
    el.set("joint", joint)
    # an effort drive's gain is 1: its scale is the gear
    attributes = {} if drive.kind is DriveKind.EFFORT else \
        {"kp": drive.stiffness / (g * g), "kv": drive.damping / (g * g)} \
        if drive.kind is DriveKind.POSITION else {"kv": drive.damping / (g * g)}
    for key, value in attributes.items():
        el.set(key, _number(value))
    el.set("gear", _number(g))
    if drive.target_range is None:
        el.set("ctrllimited", "false")
    else:
        low, high = sorted((drive.target_range[0] * g, drive.target_range[1] * g))
        el.set("ctrllimited", "true")
        el.set("ctrlrange", f"{_number(low)} {_number(high)}")
    if drive.force_limit is None:
        el.set("forcelimited", "false")
    else:
        limit = drive.force_limit / abs(g)
        el.set("forcelimited", "true")
        el.set("forcerange", f"{_number(-limit)} {_number(limit)}")
    if drive.kind is DriveKind.POSITION:
        # no activation filter nor a range from the joint's, whatever a default class says
        el.set("timeconst", "0")
        el.set("inheritrange", "0")
    return el


def _number(value: float) -> str:
    return repr(float(value) + 0.0)
