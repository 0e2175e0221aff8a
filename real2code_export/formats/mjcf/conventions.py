"""What the MJCF writer and reader agree on: element names, custom-data names, and the
numbers that must survive MuJoCo's compiler bit for bit."""

from __future__ import annotations

import re

import numpy as np

KEYFRAME = "observed"  # qpos of every joint at capture time (Joint.state)
VISUAL_GROUP = 2  # MuJoCo shows groups 0-2 by default and hides 3-5
COLLISION_GROUP = 3
CUSTOM_PREFIX = "real2code"  # <custom> numeric/text names: "real2code:<element>:<field>"
METADATA = f"{CUSTOM_PREFIX}:metadata"
WORLD = "world"  # MuJoCo's world body: a root part of this name is it


def custom_name(element: str, field: str) -> str:
    return f"{CUSTOM_PREFIX}:{element}:{field}"


def parse_custom_name(name: str) -> tuple[str, str] | None:
    """``("door_hinge", "velocity")`` for ``real2code:door_hinge:velocity``, else None."""
    head, sep, rest = name.partition(":")
    if head != CUSTOM_PREFIX or not sep:
        return None
    element, sep, field = rest.rpartition(":")
    return (element, field) if sep and element else None


# -- MuJoCo's error text -> element and line -------------------------------------------------
_ELEMENT_NAME = re.compile(r"Element name '([^']*)'")
_ELEMENT_TAG = re.compile(r"Element '([^']*)'")
_LINE = re.compile(r"(?:line|Line number=)\s*(\d+)")
_XML_TAG = re.compile(r"XMLElement name=(\S+)")


def describe_mujoco_error(message: str) -> tuple[str, str | None, str | None, int | None]:
    """(what is wrong, the element's name, its tag, the line) from a MuJoCo error, one of
    ``Error: ...\\nElement name 'b', id 2, line 5``, ``XML Error: ...\\nElement 'inertial',
    line 7`` or tinyxml's ``XML parse error ...Line number=11: XMLElement name=mujoco``."""
    text = message.strip()
    lines = text.splitlines() or ["unknown error"]
    what = re.sub(r"^(XML )?Error:\s*", "", lines[0])
    if what.startswith("XML parse error") and len(lines) > 1:
        what = "malformed XML: " + re.sub(r"\s*Line number=.*", "", lines[1]).strip()
    name = m.group(1) if (m := _ELEMENT_NAME.search(text)) else None
    tag = m.group(1) if (m := _ELEMENT_TAG.search(text) or _XML_TAG.search(text)) else None
    line = (int(m.group(1)) or None) if (m := _LINE.search(text)) else None  # 0: no line
    return what, name, tag, line


# -- numbers that survive a round trip through MuJoCo -----------------------------------------
# MuJoCo normalises quaternions and joint axes when it compiles, and our own matrix <->
# quaternion conversions change the last bits, so export -> import -> export would not give
# the same text. Unit vectors are therefore snapped to a 1e-12 grid point g whose
# normalisation rounds back to g with a wide margin; the file holds g / |g|, which every later
# export reproduces exactly (the round trip moves it by ~1e-16, far inside the margin).
_GRID = 1e12
_MARGIN = 0.25  # in grid steps: round-trip noise is ~1e-4 steps


def _settled(k: np.ndarray) -> bool:
    unit = k / np.linalg.norm(k)
    return bool(np.all(np.abs(unit * _GRID - k) <= _MARGIN))


def snap_unit(vector, *, sign_free: bool = False) -> list[float]:
    """A unit vector that export -> import -> export reproduces bit for bit, within 1e-12 of
    ``vector / |vector|``. ``sign_free`` (quaternions): v and -v are the same thing, and the
    one whose first non-zero grid component is positive is returned."""
    v = np.asarray(vector, dtype=np.float64)
    k = np.round(v / np.linalg.norm(v) * _GRID) + 0.0  # + 0.0 turns -0.0 into 0.0
    if sign_free:
        k = _positive_first(k)
    if not _settled(k):
        k = _settle(k)
        if sign_free:
            k = _positive_first(k)
    return [float(x) + 0.0 for x in k / np.linalg.norm(k)]


def snap_position(vector) -> list[float]:
    """A position that export -> import -> export reproduces bit for bit, within 5e-13 of
    ``vector``: a point of the 1e-12 grid. For a mesh geom's pose, which the reader
    recovers from MuJoCo's compiled pose and the mesh's centring (a composition that moves
    the last bits, and a zero to 1e-35)."""
    return [float(x) + 0.0 for x in np.round(np.asarray(vector, dtype=np.float64) * _GRID)
            / _GRID]


def _settle(k: np.ndarray) -> np.ndarray:
    """A nearby grid point whose length is within ~0.25 steps of 1: the largest component is
    solved from the others, the second largest nudged until that solution rounds well (each
    try succeeds with probability >= 1/2)."""
    order = np.argsort(-np.abs(k), kind="stable")
    big, second = order[0], order[1]
    for step in range(64):
        nudge = (step + 1) // 2 * (1 if step % 2 else -1)
        trial = k.copy()
        trial[second] += nudge
        rest = float(np.sum(np.delete(trial, big) ** 2))
        trial[big] = np.copysign(np.round(np.sqrt(_GRID**2 - rest)), k[big])
        if _settled(trial):
            return trial
    return k  # not reached in practice; the value is still valid, only not idempotent


def _positive_first(k: np.ndarray) -> np.ndarray:
    nonzero = np.flatnonzero(k)
    return -k + 0.0 if len(nonzero) and k[nonzero[0]] < 0 else k


def float32(values) -> list[float]:
    """Colours: MuJoCo stores rgba as float32, so the file holds float32 values."""
    return [float(x) for x in np.asarray(values, dtype=np.float32)]
