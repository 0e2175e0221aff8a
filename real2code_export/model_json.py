"""The model's small pieces as JSON, in the one shape object.json and glTF's extras share (a
primitive shape, a joint's mimic), and the checked reading of JSON values both readers use:
each error names the file, the element and what is wrong. Neither format imports the other;
both import this."""

from __future__ import annotations

import math
from enum import StrEnum
from pathlib import Path
from typing import Any

import numpy as np

from .errors import FormatError
from .model import Drive, DriveKind, Mimic
from .primitives import Primitive, ShapeKind


def number(value, path: Path, element: str, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise FormatError(path, element, f"{what} must be a number, got {value!r}")
    if not math.isfinite(value):
        raise FormatError(path, element, f"{what} is not finite: {value!r}")
    return float(value)


def vector(value, n: int, path: Path, element: str, what: str) -> np.ndarray:
    arr = np.asarray(value, dtype=object)
    if arr.shape != (n,) and not (n == 9 and arr.shape == (3, 3)):
        raise FormatError(path, element, f"{what} must have {n} numbers, got {value!r}")
    return np.array([number(v, path, element, what) for v in arr.reshape(-1)])


def member(d: dict, key: str, path: Path, element: str):
    if not isinstance(d, dict):
        raise FormatError(path, element, f"expected an object, got {type(d).__name__}")
    if key not in d:
        raise FormatError(path, element, f"missing key {key!r}")
    return d[key]


def choice(d: Any, key: str, kinds: type[StrEnum], path: Path, el: str, what: str) -> str:
    """``d[key]``, which must be one of the enumeration's values."""
    value = member(d, key, path, el)
    if value not in {k.value for k in kinds}:
        raise FormatError(path, el, f"unknown {what} {value!r} (expected one of "
                          f"{[k.value for k in kinds]})")
    return value


def transform(d: Any, path: Path, el: str, what: str) -> np.ndarray:
    """A 4x4 transform from its ``translation`` (3) and row-major ``rotation`` (9)."""
    out = np.eye(4)
    out[:3, 3] = vector(member(d, "translation", path, el), 3, path, el, what + "translation")
    out[:3, :3] = vector(member(d, "rotation", path, el), 9, path, el,
                         what + "rotation").reshape(3, 3)
    return out


def shape_json(shape: Primitive) -> dict[str, Any]:
    return {"kind": shape.kind.value, "size": shape.size.tolist(),
            "translation": shape.pose[:3, 3].tolist(), "rotation": shape.pose[:3, :3].tolist()}


def shape_from_json(d: Any, path: Path, el: str) -> Primitive:
    if not isinstance(d, dict):
        raise FormatError(path, el, f"a shape must be an object, got {d!r}")
    kind = choice(d, "kind", ShapeKind, path, el, "shape kind")
    size = member(d, "size", path, el)
    pose = transform(d, path, el, "")
    shape = Primitive(kind, vector(size, len(size) if isinstance(size, list) else 1, path, el,
                                   "size"), pose)
    problem = shape.problem()
    if problem is not None:
        raise FormatError(path, el, problem)
    return shape


def drive_json(drive: Drive) -> dict:
    """A joint's drive as JSON (object.json and glTF extras), SI units, radians."""
    return {"kind": drive.kind.value, "stiffness": drive.stiffness, "damping": drive.damping,
            "target": drive.target, "force_limit": drive.force_limit,
            "target_range": None if drive.target_range is None else list(drive.target_range),
            "name": drive.name, "gear": drive.gear}


def drive_from_json(d, path, el: str) -> Drive:
    el = f"{el} drive"
    kind = choice(d, "kind", DriveKind, path, el, "drive kind")

    def optional(key: str, default: float | None) -> float | None:
        value = d.get(key, default)
        return None if value is None else number(value, path, el, key)

    rng = d.get("target_range")
    if rng is not None:
        rng = tuple(vector(rng, 2, path, el, "target_range"))
    name = d.get("name")
    if name is not None and not isinstance(name, str):
        raise FormatError(path, el, f"name must be a string, got {name!r}")
    drive = Drive(kind, optional("stiffness", 0.0), optional("damping", 0.0),
                  optional("target", 0.0), optional("force_limit", None), rng, name,
                  optional("gear", 1.0))
    problem = drive.problem()
    if problem is not None:
        raise FormatError(path, el, problem)
    return drive


def mimic_json(mimic: Mimic) -> dict:
    """A joint's mimic as JSON (object.json and glTF extras)."""
    return {"joint": mimic.joint, "multiplier": mimic.multiplier, "offset": mimic.offset}


def mimic_from_json(d, path, el: str) -> Mimic:
    leader = member(d, "joint", path, el)
    if not isinstance(leader, str):
        raise FormatError(path, el, f"mimic joint must be a name, got {leader!r}")
    return Mimic(leader, number(d.get("multiplier", 1.0), path, el, "mimic multiplier"),
                 number(d.get("offset", 0.0), path, el, "mimic offset"))
