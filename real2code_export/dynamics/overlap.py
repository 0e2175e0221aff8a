"""How deep the collision pieces of two parts overlap at given joint values, as MuJoCo's
collision detection sees them (each piece is a convex hull, as in every engine).

Every pair of parts counts, parent and child included: a format without contact exclusions
(URDF) leaves those pairs to collide too. The MJCF is loaded with its ``<exclude>`` pairs
removed and parent filtering off; MuJoCo's collision detection at the joint values
(``mj_kinematics``, ``mj_flex`` and ``mj_collision``, not ``mj_forward``: a scene of thousands of
contacts would fill MuJoCo's arena with a constraint problem nobody reads) gives the
contacts, and a negative distance is an overlap. Along a joint's range only its child and its parent
count: a drawer that meets a closed door beside it is a real collision, not an overlap.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..formats import is_format
from ..model import ArticulatedObject
from ..mujoco_files import spec_from_file

TOLERANCE = 1e-4  # m: shallower is touching


@dataclass(frozen=True)
class Overlap:
    part_a: str
    part_b: str
    depth: float  # m, the deepest penetration between any two of their pieces


@dataclass(frozen=True)
class RangeOverlap:
    joint: str
    value: float  # rad or m, where the deepest overlap was found
    part_a: str
    part_b: str
    depth: float  # m


def overlaps(mjcf: Path, q: dict[str, float] | None = None,
             tolerance: float = TOLERANCE) -> list[Overlap]:
    """Part pairs whose pieces overlap by more than ``tolerance`` (m) at joint values ``q``
    (by joint name; the other hinges and slides at 0, free bodies and balls where the file
    puts them), deepest first."""
    model, data = _compiled(mjcf)
    return _overlaps(model, data, q or {}, tolerance)


@dataclass
class FileOverlaps:
    """What ``check`` reports: the file measured and its overlapping part pairs at q = 0, or
    why none could be measured."""

    file: str | None
    overlaps: list[Overlap]
    message: str = ""

    def to_json(self) -> dict:
        return {"file": self.file, "tolerance": TOLERANCE, "message": self.message,
                "pairs": [{"parts": [o.part_a, o.part_b], "depth": o.depth}
                          for o in self.overlaps]}


def file_overlaps(paths, tolerance: float = TOLERANCE, compiled=None) -> FileOverlaps:
    """Overlapping collision pieces at q = 0 in the first MJCF among ``paths``, else the
    first URDF (both compiled by MuJoCo; the other formats hold the same pieces when they
    are exports of one object). ``compiled``: MuJoCo models of MJCF files among ``paths``
    already compiled without contact exclusions (check's probes), by path, used instead of
    compiling the file again."""
    chosen = [Path(p) for p in paths if is_format(p, "mjcf")] or \
        [Path(p) for p in paths if is_format(p, "urdf")]
    if not chosen:
        return FileOverlaps(None, [], "no MJCF or URDF to measure")
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return FileOverlaps(None, [], "MuJoCo is not installed")
    model = (compiled or {}).get(chosen[0])
    if model is not None and is_format(chosen[0], "mjcf") and \
            not (model.exclude_signature >= 0).any():
        return FileOverlaps(str(chosen[0]), _overlaps_in(model, tolerance))
    try:
        return FileOverlaps(str(chosen[0]), overlaps(chosen[0], tolerance=tolerance))
    except ValueError as e:  # MuJoCo refused the file: the probes report it
        return FileOverlaps(str(chosen[0]), [], f"not measured: {e}")


def overlaps_along_ranges(mjcf: Path, obj: ArticulatedObject,
                          tolerance: float = TOLERANCE) -> list[RangeOverlap]:
    """For each movable joint moved alone along its range, the deepest overlap of its
    child's pieces with its parent's: a door against its frame, a drawer against its
    carcass. Measured at the values separation sweeps (``sweep_values``) and halfway
    between each two, where a coarse separation would leave them overlapping. Joints with
    none are left out."""
    from ..collision_separation import sweep_values

    model, data = _compiled(mjcf)
    found = []
    for joint in obj.movable_joints:
        swept = sweep_values(obj, joint)
        values = np.sort(np.concatenate([swept, (swept[1:] + swept[:-1]) / 2]))
        worst = None
        for value in values:
            for o in _overlaps(model, data, {joint.name: float(value)}, tolerance):
                if {o.part_a, o.part_b} == {joint.parent, joint.child} and \
                        (worst is None or o.depth > worst.depth):
                    worst = RangeOverlap(joint.name, float(value), o.part_a, o.part_b, o.depth)
        if worst is not None:
            found.append(worst)
    return found


def _overlaps_in(model, tolerance: float) -> list[Overlap]:
    """Overlaps at q = 0 in a model compiled already (exclusions removed), parent filtering
    off while measuring as :func:`_compiled` sets it."""
    import mujoco

    flags = model.opt.disableflags
    model.opt.disableflags = flags | int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
    try:
        return _overlaps(model, mujoco.MjData(model), {}, tolerance)
    finally:
        model.opt.disableflags = flags


def drop_exclusions(model) -> None:
    """A compiled model's contact exclusions turned off: each pair's signature set to -1
    matches no pair of bodies (``mj_collision`` looks pairs up in them). Deleting them from
    the spec instead costs ~20 ms each (a flex's 1153 exclusions: 108 s)."""
    model.exclude_signature[:] = -1


def _compiled(mjcf: Path):
    import mujoco

    spec = spec_from_file(mjcf)
    spec.compiler.discardvisual = True
    model = spec.compile()
    drop_exclusions(model)
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
    return model, mujoco.MjData(model)


def _overlaps(model, data, q: dict[str, float], tolerance: float) -> list[Overlap]:
    import mujoco

    data.qpos[:] = 0.0
    # a free body where the file puts it, a ball at its rest (their qpos0; a zero
    # quaternion would put a free body at the world's origin)
    free, ball = int(mujoco.mjtJoint.mjJNT_FREE), int(mujoco.mjtJoint.mjJNT_BALL)
    for j in np.flatnonzero(np.isin(model.jnt_type, (free, ball))):
        start = model.jnt_qposadr[j]
        end = start + (7 if model.jnt_type[j] == free else 4)
        data.qpos[start:end] = model.qpos0[start:end]
    for name, value in q.items():
        data.qpos[model.joint(name).qposadr[0]] = value
    mujoco.mj_kinematics(model, data)
    mujoco.mj_flex(model, data)  # a flex's vertices, where a source has one
    mujoco.mj_collision(model, data)
    deepest: dict[tuple[str, str], float] = {}
    for c in data.contact[:data.ncon]:
        if c.dist >= -tolerance:
            continue
        a = model.body(model.geom_bodyid[c.geom[0]]).name
        b = model.body(model.geom_bodyid[c.geom[1]]).name
        if a == b:
            continue
        key = tuple(sorted((a, b)))
        deepest[key] = max(deepest.get(key, 0.0), -float(c.dist))
    found = [Overlap(a, b, d) for (a, b), d in deepest.items()]
    return sorted(found, key=lambda o: -o.depth)
