"""``real2code check``: load every file in its own tool, pose all of them at the same joint
values (by joint name), and compare the world pose of every part against a reference.

Configuration 0 is q = 0; configuration 1 is the observed state when an object.json is
among the files; the rest are drawn uniformly within the limits the probes agree on.
Joints and parts missing from a probe, differing joint kinds or limits, and poses further
apart than the tolerance are mismatches; ``report.ok`` is False when there is any.

With the user's source file as the reference, the exports' dynamics are compared with the
source's too, each built in a tool of the source (``probes.dynamics.against_source``):
masses, inertias and centres of mass, joints' damping, friction, armature, stiffness and
limits; a difference is a mismatch unless a repair warning of our reader names its element
and says what of it changed (``probes.dynamics.explaining``).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .dynamics.overlap import TOLERANCE, FileOverlaps, file_overlaps
from .errors import CheckError, Real2CodeWarning
from .formats import format_for_path
from .jsonsafe import finite_or_null
from .model import UNBOUNDED_LIMIT, UNBOUNDED_SLIDE_SPAN
from .probes import JointInfo, Probe, open_probes
from .probes.model import LABEL as MODEL_LABEL
from .probes.source import SOURCE_LABEL, open_source_probes
from .validators import Validation, start_validation

WORLD = "world"  # the world frame, as a part where a tool names it (URDF link, MuJoCo body 0)


@dataclass(frozen=True)
class Mismatch:
    # missing_joint | joint_kind | joint_limits | missing_part | extra_part | pose | drive
    kind: str
    probe: str  # the probe's display name
    name: str  # the joint or part concerned
    message: str


@dataclass
class ProbeResult:
    label: str
    path: str
    name: str  # label and file, unique in the report
    parts: list[str]
    joints: list[JointInfo]
    is_reference: bool
    max_position_error: float = 0.0
    max_rotation_error: float = 0.0
    worst_part: str | None = None
    ok: bool = True


@dataclass
class PartResult:
    """The worst disagreement of one part (of the reference) over all probes and configurations."""

    part: str
    position_error: float = 0.0
    position_probe: str | None = None
    position_configuration: int | None = None
    rotation_error: float = 0.0
    rotation_probe: str | None = None
    rotation_configuration: int | None = None
    missing_in: list[str] = field(default_factory=list)


@dataclass
class DynamicsResult:
    """One export's dynamics against the source's, both built in one tool."""

    file: str
    tool: str
    compared: bool
    differences: int = 0  # beyond the tolerance, repaired ones included
    repaired: list[str] = field(default_factory=list)  # those a repair warning explains
    note: str = ""  # why not compared

    def to_json(self) -> dict[str, Any]:
        return {"file": self.file, "tool": self.tool, "compared": self.compared,
                "differences": self.differences, "repaired": self.repaired, "note": self.note}


@dataclass
class CheckReport:
    files: list[str]
    reference: str
    probes: list[ProbeResult]
    joints: list[JointInfo]  # the union, with the ranges sampled
    configurations: list[dict[str, float]]
    tol_position: float
    tol_rotation: float
    parts: list[PartResult]
    mismatches: list[Mismatch]
    validations: list[Validation] = field(default_factory=list)
    # parts' collision pieces overlapping at q = 0 (reported, not part of ``ok``: a robot's
    # links overlap at their joints by design; docs/engines.md)
    overlaps: FileOverlaps | None = None
    dynamics: list[DynamicsResult] = field(default_factory=list)  # against the source
    tol_dynamics: float = 1e-6

    @property
    def ok(self) -> bool:
        return not self.mismatches

    @property
    def max_position_error(self) -> float:
        return max((p.max_position_error for p in self.probes), default=0.0)

    @property
    def max_rotation_error(self) -> float:
        return max((p.max_rotation_error for p in self.probes), default=0.0)

    def to_json(self) -> dict[str, Any]:
        return {
            "files": self.files,
            "reference": self.reference,
            "probes": [
                {
                    "label": p.label, "path": p.path, "name": p.name,
                    "reference": p.is_reference, "parts": p.parts,
                    "joints": [_joint_json(j) for j in p.joints],
                    "max_position_error": finite_or_null(p.max_position_error),
                    "max_rotation_error": finite_or_null(p.max_rotation_error),
                    "worst_part": p.worst_part, "ok": p.ok,
                }
                for p in self.probes
            ],
            "joints": [_joint_json(j) for j in self.joints],
            "configurations": self.configurations,
            "tolerance": {"position": self.tol_position, "rotation": self.tol_rotation},
            "max_position_error": finite_or_null(self.max_position_error),
            "max_rotation_error": finite_or_null(self.max_rotation_error),
            "parts": [
                {
                    "part": r.part,
                    "position_error": finite_or_null(r.position_error), "position_probe": r.position_probe,
                    "position_configuration": r.position_configuration,
                    "rotation_error": finite_or_null(r.rotation_error), "rotation_probe": r.rotation_probe,
                    "rotation_configuration": r.rotation_configuration,
                    "missing_in": r.missing_in,
                }
                for r in self.parts
            ],
            "mismatches": [
                {"kind": m.kind, "probe": m.probe, "name": m.name, "message": m.message}
                for m in self.mismatches
            ],
            "validations": [v.to_json() for v in self.validations],
            "overlaps_at_zero": self.overlaps.to_json() if self.overlaps else None,
            "dynamics_against_source": [d.to_json() for d in self.dynamics],
            "tolerance_dynamics": self.tol_dynamics,
            "ok": self.ok,
        }


def _joint_json(j: JointInfo) -> dict[str, Any]:
    return {"name": j.name, "kind": j.kind, "lower": j.lower, "upper": j.upper}


# -- the check -------------------------------------------------------------------------------
def check_files(
    paths: Sequence[str | Path],
    *,
    n_configurations: int = 100,
    seed: int = 0,
    tol_position: float = 1e-6,
    tol_rotation: float = 1e-6,
    reference: str | Path | None = None,
    validate: bool = True,
    source: str | Path | None = None,
    tol_dynamics: float = 1e-6,
    warned: Sequence[str] | None = None,
    source_required: bool = True,
) -> CheckReport:
    """Load every file in its own tool(s) and compare part poses at shared configurations.

    ``reference`` picks the probe the others are compared against: a file among ``paths``
    (its first probe) or a probe label such as ``"MuJoCo (MJCF)"``; by default the model
    (object.json) if present, else the first file's first probe. With ``validate`` the
    formats' own validators run too (glTF, USD); any error they report is a mismatch.
    ``source``: the user's input file (URDF or MJCF), loaded in its own tools
    (``probes.source.open_source_probes``), is the reference every file is compared with,
    and the exports' dynamics are compared with its (``tol_dynamics``, absolute and
    relative, the model's tolerance). ``warned``: our reader's warnings on the source (its
    repairs); None reads the source again to learn them when some dynamics differ.
    A USD source is loaded in Newton (``probes.newton``): the exports' dynamics are compared
    with Newton's model's (``probes.dynamics.against_newton``). Without
    ``source_required`` a source its tool cannot load (Newton absent, or refusing the file)
    is left out with a warning, the files compared with each other (``export --check``).
    """
    if not paths:
        raise CheckError("no files to check")
    if n_configurations < 1:
        raise CheckError(f"n_configurations must be >= 1, got {n_configurations}")
    # The glTF validator (a Node.js process) runs while the probes load and pose.
    finish = start_validation(list(paths)) if validate else list
    source_probes: list[Probe] = []
    if source is not None:
        try:
            source_probes = open_source_probes(source)
        except CheckError as e:
            if source_required:
                raise
            warnings.warn(f"{e}: the files are compared with each other only",
                          Real2CodeWarning, stacklevel=2)
            source = None
    report, probes = _compare(paths, n_configurations, seed, tol_position, tol_rotation,
                              reference, source, source_probes)
    compiled = _compiled_mjcf(probes, [*paths, *([source] if source is not None else [])])
    opened = _opened(probes, paths)
    _compare_drives(report, probes, [*([source] if source is not None else []), *paths],
                    tol_dynamics, compiled, opened)
    # (a USD source's dynamics: Newton's model's, ``probes.newton``)
    newton = next((p.dynamics for p in source_probes
                   if getattr(p, "dynamics", None) is not None), None)
    if source is not None and (newton is not None or format_for_path(source).name != "usd"):
        _compare_dynamics(report, source, tol_dynamics, warned, compiled, opened, newton)
    validations = finish()  # the probes still open: USD's validator reuses their parsed layers
    del probes
    for v in validations:
        if v.errors:
            report.mismatches.append(Mismatch("validation", v.tool, Path(v.path).name,
                                              f"{v.tool}: {v.errors} error(s) in {v.path}: "
                                              + "; ".join(v.messages[:3])))
    report.validations = validations
    return report


def _compare(paths, n_configurations, seed, tol_position, tol_rotation, reference,
             source, source_probes) -> tuple[CheckReport, list[Probe]]:
    """The kinematic comparison of :func:`check_files` (without the validators), and the
    probes it opened (``source_probes``: the source's, opened already)."""
    probes: list[Probe] = list(source_probes)
    for path in paths:
        probes.extend(open_probes(path))
    if not probes:
        raise CheckError("no probe could load any of the files")
    names = _display_names(probes)
    ref = 0 if source is not None and reference is None else \
        _pick_reference(probes, names, reference)
    mismatches: list[Mismatch] = []

    joints = _union_joints(probes, names, ref, tol_position, tol_rotation, mismatches)
    values = _configurations(probes, joints, n_configurations, seed)
    column = {j.name: k for k, j in enumerate(joints)}
    poses = [_pose_array(p, values[:, [column[j.name] for j in p.joints]]) for p in probes]

    results = [
        ProbeResult(p.label, str(p.path), names[i], list(p.parts), list(p.joints), i == ref)
        for i, p in enumerate(probes)
    ]
    parts = _compare_poses(probes, poses, names, ref, results, tol_position, tol_rotation,
                           mismatches)
    bad = {m.probe for m in mismatches}
    for r in results:
        r.ok = r.name not in bad
    configurations = [
        {j.name: float(v) for j, v in zip(joints, row, strict=True)} for row in values
    ]
    return CheckReport(
        files=[str(p) for p in paths], reference=names[ref], probes=results, joints=joints,
        configurations=configurations, tol_position=tol_position, tol_rotation=tol_rotation,
        parts=parts, mismatches=mismatches,
        overlaps=file_overlaps(paths, compiled=_compiled_mjcf(probes, paths)),
    ), probes


def _compare_dynamics(report: CheckReport, source: str | Path, tol: float,
                      warned: Sequence[str] | None, compiled: dict[Path, object],
                      opened: dict[Path, Probe], newton: dict | None = None) -> None:
    """The exports' dynamics against the source's (module docstring), into ``report``;
    ``compiled``: the MJCF models the probes compiled (:func:`_compiled_mjcf`); ``opened``:
    the USD and glTF probes (:func:`_opened`); ``newton``: a USD source's dynamics in
    Newton's model (``probes.newton``)."""
    from .probes import dynamics

    report.tol_dynamics = tol
    comparisons = dynamics.against_source(source, report.files, tol, compiled, opened, newton)
    if warned is None and any(c.differences for c in comparisons):
        warned = _repair_warnings(source)
    for c in comparisons:
        of_file = [r for r in report.probes if not r.is_reference and Path(r.path) == c.export]
        # (the probe of that tool; a USD or glTF file's one probe, its schema's reading)
        probe = next((r for r in of_file if r.label.startswith(c.tool)),
                     of_file[0] if len(of_file) == 1 else None)
        if c.differences is None:
            report.dynamics.append(DynamicsResult(str(c.export), c.tool, False, note=c.note))
            continue
        left = dynamics.unexplained(c.differences, list(warned or ()))
        report.dynamics.append(DynamicsResult(
            str(c.export), c.tool, True, len(c.differences),
            [str(d) for d in c.differences if d not in left]))
        name = probe.name if probe is not None else f"{c.tool} {c.export.name}"
        report.mismatches += [Mismatch("dynamics", name, d.names[0] if d.names else "",
                                       f"{c.tool}: {d} (the source's, then the export's)")
                              for d in left]
        if left and probe is not None:
            probe.ok = False


def _compare_drives(report: CheckReport, probes: list[Probe], paths: list, tol: float,
                    compiled: dict[Path, object], opened: dict[Path, Probe]) -> None:
    """Every file's joint drives, as its tool reads them (``probes.drives``: MJCF and USD),
    against the first such file's (the source, when given), into ``report``: a drive in
    one and not the other of a joint both have, or one that differs beyond ``tol`` (the
    model's tolerance equality), is a mismatch."""
    from .probes.drives import file_drives

    read = [(Path(p), d) for p in paths
            if (d := file_drives(Path(p), compiled, opened)) is not None]
    if len(read) < 2:
        return
    joints = {Path(p.path): set() for p in probes}
    for p in probes:
        joints[Path(p.path)] |= {j.name for j in p.joints}
    names = dict(zip((id(p) for p in probes), _display_names(probes), strict=True))
    (ref_path, reference), others = read[0], read[1:]
    for path, drives in others:
        probe = next((p for p in probes if Path(p.path) == path), None)
        label = names[id(probe)] if probe is not None else path.name
        for joint in sorted(joints.get(ref_path, set()) & joints.get(path, set())):
            a, b = reference.get(joint), drives.get(joint)
            if a is None and b is None:
                continue
            problem = "drive in only one" if a is None or b is None else \
                "; ".join(a.differences(b, tol))
            if problem:
                report.mismatches.append(Mismatch(
                    "drive", label, joint, f"joint {joint!r}: drive of {ref_path.name}, then "
                    f"of {path.name}: {problem}"))
                for r in report.probes:
                    if r.name == label:
                        r.ok = False


def _repair_warnings(source: str | Path) -> list[str]:
    """Our reader's warnings on ``source``: what it repaired (masses, tensors, limits)."""
    import warnings

    from .errors import Real2CodeError
    from .formats import load

    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        try:
            load(source, hull_collision=False)
        except Real2CodeError:
            return []
    return [str(w.message) for w in said]


def _compiled_mjcf(probes: list[Probe], paths) -> dict[Path, object]:
    """The MuJoCo models the probes compiled of MJCF files among ``paths`` (without contact
    exclusions: ``probes.mujoco``), which the overlap measure and the dynamics against the
    source use instead of compiling the file again."""
    files = {Path(p) for p in paths}
    return {Path(p.path): p.model for p in probes
            if Path(p.path) in files and format_for_path(p.path).name == "mjcf"
            and getattr(p, "model", None) is not None}


def _opened(probes: list[Probe], paths) -> dict[Path, Probe]:
    """The probes of USD and glTF files among ``paths`` that read them as their schema does
    (``probes.usd``, ``probes.gltf``: a stage, a document), which the dynamics against the
    source read instead of opening the files again."""
    files = {Path(p) for p in paths}
    return {Path(p.path): p for p in probes if Path(p.path) in files
            and (hasattr(p, "stage") or hasattr(p, "document"))}


def _display_names(probes: list[Probe]) -> list[str]:
    short = [f"{p.label} {Path(p.path).name}" for p in probes]
    if len(set(short)) == len(short):
        return short
    return [f"{p.label} {p.path}" for p in probes]


def _pick_reference(probes: list[Probe], names: list[str], reference: str | Path | None) -> int:
    if reference is None:
        for i, p in enumerate(probes):
            if p.label == MODEL_LABEL:
                return i
        return 0
    for i, p in enumerate(probes):
        if Path(p.path) == Path(reference) or Path(p.path).resolve() == Path(reference).resolve():
            return i
    for i, p in enumerate(probes):
        if str(reference) in (p.label, names[i]):
            return i
    raise CheckError(f"reference {str(reference)!r} is neither one of the files nor a probe "
                     f"(probes: {', '.join(names)})")


def _union_joints(probes, names, ref, tol_position, tol_rotation, mismatches) -> list[JointInfo]:
    """The movable joints of all probes by name (the reference's first), each with the range
    every probe admits; records missing joints and differing kinds or limits."""
    by_probe = [{j.name: j for j in p.joints} for p in probes]
    # The source's other tools may read its joints differently from the reference tool
    # (MuJoCo loads an empty revolute range unlimited, Pinocchio keeps it): their poses are
    # compared, their joint kinds and ranges are the tools' business, not the export's.
    tools_of_source = {i for i, p in enumerate(probes)
                       if i != ref and p.label.startswith(SOURCE_LABEL)}
    order = list(dict.fromkeys(j.name for i in [ref] + [k for k in range(len(probes)) if k != ref]
                               for j in probes[i].joints))  # (a dict: no list search per joint)

    union = []
    for name in order:
        having = [i for i, d in enumerate(by_probe) if name in d]
        base_i = ref if ref in having else having[0]
        base = by_probe[base_i][name]
        for i in range(len(probes)):
            if i not in having:
                mismatches.append(Mismatch(
                    "missing_joint", names[i], name,
                    f"joint {name!r} is missing (found in {names[base_i]})"))
                continue
            if i == base_i or i in tools_of_source:
                continue
            info = by_probe[i][name]
            if info.kind != base.kind:
                mismatches.append(Mismatch(
                    "joint_kind", names[i], name,
                    f"joint {name!r} is {info.kind}, {base.kind} in {names[base_i]}"))
                continue
            tol = tol_position if info.kind == "prismatic" else tol_rotation
            if not (_limit_close(info.lower, base.lower, tol)
                    and _limit_close(info.upper, base.upper, tol)):
                mismatches.append(Mismatch(
                    "joint_limits", names[i], name,
                    f"joint {name!r} limits [{info.lower}, {info.upper}] differ from "
                    f"[{base.lower}, {base.upper}] in {names[base_i]}"))
        union.append(_agreed_range(name, base, [by_probe[i][name] for i in having
                                                if i not in tools_of_source]))
    return union


def _limit_close(a: float | None, b: float | None, tol: float) -> bool:
    """Within ``tol``, relative beyond 1 (rad or m): formats store limits as float32 (USD in
    degrees), so +-1800 degrees or a +-1e16 rotor limit is not exact to 1e-6 absolute."""
    a, b = _bound(a), _bound(b)
    if a is None or b is None:
        return a is None and b is None
    return abs(a - b) <= tol * max(1.0, abs(a), abs(b))


def _bound(value: float | None) -> float | None:
    """None for no bound: absent, or at SDF's "no limit" (+-1e16, which the URDF writer
    gives a slide without limits; float32 formats round it by 1e-7)."""
    if value is None or abs(value) >= UNBOUNDED_LIMIT * (1.0 - 1e-6):
        return None
    return value


def _agreed_range(name: str, base: JointInfo, infos: list[JointInfo]) -> JointInfo:
    span = UNBOUNDED_SLIDE_SPAN if base.kind == "prismatic" else math.pi
    lowers = [_bound(j.lower) for j in infos if _bound(j.lower) is not None]
    uppers = [_bound(j.upper) for j in infos if _bound(j.upper) is not None]
    lower = max(lowers) if lowers else -span
    upper = min(uppers) if uppers else span
    if lower > upper:  # the probes disagree (already a mismatch): sample the reference's range
        lower = _bound(base.lower) if _bound(base.lower) is not None else -span
        upper = _bound(base.upper) if _bound(base.upper) is not None else span
    return JointInfo(name, base.kind, lower, upper)


def _configurations(probes, joints: list[JointInfo], n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    lower = np.array([j.lower for j in joints], dtype=np.float64)
    upper = np.array([j.upper for j in joints], dtype=np.float64)
    values = rng.uniform(lower, upper, size=(n, len(joints)))
    values[0] = 0.0
    observed = next((p.observed for p in probes if getattr(p, "observed", None) is not None),
                    None)
    if observed is not None and n > 1:
        values[1] = [observed.get(j.name, 0.0) for j in joints]
    return values


def _pose_array(probe: Probe, values: np.ndarray) -> np.ndarray:
    """(N, parts, 4, 4): the probe's batch method if it has one, else one call per row."""
    if hasattr(probe, "pose_array"):
        return probe.pose_array(values)
    out = np.empty((len(values), len(probe.parts), 4, 4))
    for i, row in enumerate(values):
        poses = probe.poses({j.name: float(v) for j, v in zip(probe.joints, row, strict=True)})
        out[i] = [poses[name] for name in probe.parts]
    return out


def rotation_angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle (rad) of R_a^T R_b for stacks of 3x3 rotations, from the Frobenius distance
    (||R_a - R_b|| = 2 sqrt(2) sin(theta / 2)): exact near 0, where acos of the trace loses
    half the digits."""
    dist = np.linalg.norm((a - b).reshape(*a.shape[:-2], 9), axis=-1)
    return 2.0 * np.arcsin(np.minimum(dist / (2.0 * math.sqrt(2.0)), 1.0))


def _implicit_world(ref_poses, ref_index, probe_poses, index) -> str | None:
    """WORLD when one side has the world frame as a part (a URDF ``world`` link, our MJCF's
    world body) and the other leaves it implicit: at the identity it is the same frame."""
    for poses_, names, other in ((ref_poses, ref_index, index), (probe_poses, index, ref_index)):
        if WORLD in names and WORLD not in other:
            world = poses_[:, names[WORLD]]
            if np.allclose(world, np.eye(4), atol=1e-12, rtol=0):
                return WORLD
    return None


def _intermediate(name: str, parts, joints: set[str]) -> bool:
    """Whether part ``name`` is a massless intermediate part ``<part>_<joint>`` of a body
    with several joints (the MJCF reader's, a USD generic joint's or stacked joints') that
    the other side holds as one body with those joints (an MJCF export merges them back):
    its joints and the body's pose are compared, the frame between them has no body there."""
    return any(name.startswith(f"{part}_") and name[len(part) + 1:] in joints
               for part in parts)


def _compare_poses(probes, poses, names, ref, results, tol_position, tol_rotation,
                   mismatches) -> list[PartResult]:
    ref_parts = list(probes[ref].parts)
    ref_index = {name: k for k, name in reversed(list(enumerate(ref_parts)))}
    ref_joints = {j.name for j in probes[ref].joints}
    part_results = {name: PartResult(name) for name in ref_index}
    for i, probe in enumerate(probes):
        if i == ref:
            continue
        index = {name: k for k, name in reversed(list(enumerate(probe.parts)))}
        implicit = _implicit_world(poses[ref], ref_index, poses[i], index)
        # Against a user's source file, an export may hold frames the source has not (the
        # world, the intermediate parts of a body with several joints): every part of the
        # source must be where the source puts it.
        extra_allowed = probes[ref].label.startswith(SOURCE_LABEL)
        joints = {j.name for j in probe.joints}
        for name in ref_index:
            if name not in index and name != implicit \
                    and not _intermediate(name, index, joints):
                part_results[name].missing_in.append(names[i])
                mismatches.append(Mismatch("missing_part", names[i], name,
                                           f"part {name!r} is missing (found in {names[ref]})"))
        for name in index:
            if name not in ref_index and name != implicit and not extra_allowed \
                    and not _intermediate(name, ref_index, ref_joints):
                mismatches.append(Mismatch("extra_part", names[i], name,
                                           f"part {name!r} is not in the reference {names[ref]}"))
        common = [name for name in ref_index if name in index]
        if not common:
            continue
        a = poses[ref][:, [ref_index[n] for n in common]]
        b = poses[i][:, [index[n] for n in common]]
        pos = np.linalg.norm(a[..., :3, 3] - b[..., :3, 3], axis=-1)  # (N, parts)
        rot = rotation_angles(a[..., :3, :3], b[..., :3, :3])
        pos = np.where(np.isfinite(pos), pos, np.inf)  # a NaN pose is a failure, not a pass
        rot = np.where(np.isfinite(rot), rot, np.inf)
        result = results[i]
        worst_pos, worst_rot = pos.max(axis=0), rot.max(axis=0)
        result.max_position_error = float(worst_pos.max())
        result.max_rotation_error = float(worst_rot.max())
        score = np.maximum(worst_pos / tol_position, worst_rot / tol_rotation)
        result.worst_part = common[int(np.argmax(score))]
        for k, name in enumerate(common):
            pr = part_results[name]
            cp, cr = int(np.argmax(pos[:, k])), int(np.argmax(rot[:, k]))
            if pos[cp, k] > pr.position_error or pr.position_probe is None:
                pr.position_error, pr.position_probe = float(pos[cp, k]), names[i]
                pr.position_configuration = cp
            if rot[cr, k] > pr.rotation_error or pr.rotation_probe is None:
                pr.rotation_error, pr.rotation_probe = float(rot[cr, k]), names[i]
                pr.rotation_configuration = cr
            if worst_pos[k] > tol_position or worst_rot[k] > tol_rotation:
                mismatches.append(Mismatch(
                    "pose", names[i], name,
                    f"part {name!r} is {worst_pos[k]:.3g} m / {worst_rot[k]:.3g} rad away from "
                    f"{names[ref]} (worst at configurations {cp} / {cr})"))
    return list(part_results.values())


# -- on screen -------------------------------------------------------------------------------
def format_table(report: CheckReport, worst: int = 5) -> str:
    """The report as text: one row per probe, then the worst parts and every mismatch."""
    lines = [
        f"{len(report.files)} file(s), {len(report.probes)} probe(s), "
        f"{len(report.configurations)} configuration(s), tolerance "
        f"{report.tol_position:g} m / {report.tol_rotation:g} rad, reference: {report.reference}",
        "",
    ]
    rows = [("probe", "file", "parts", "joints", "max pos (m)", "max rot (rad)", "verdict")]
    for p in report.probes:
        verdict = ("reference" if p.ok else "reference, MISMATCH") if p.is_reference \
            else ("ok" if p.ok else "MISMATCH")
        errors = ("-", "-") if p.is_reference else \
            (f"{p.max_position_error:.2e}", f"{p.max_rotation_error:.2e}")
        rows.append((p.label, Path(p.path).name, str(len(p.parts)), str(len(p.joints)),
                     *errors, verdict))
    lines += _columns(rows)
    if len(report.probes) == 1:
        lines.append("(one probe only: nothing to compare it with)")

    tp, tr = report.tol_position, report.tol_rotation
    compared = [r for r in report.parts if r.position_probe is not None]
    compared.sort(key=lambda r: -max(r.position_error / tp, r.rotation_error / tr))
    if compared:
        lines += ["", "worst parts:"]
        rows = [("part", "pos (m)", "rot (rad)", "worst in", "config")]
        for r in compared[:worst]:
            by_position = r.position_error / tp >= r.rotation_error / tr
            probe = r.position_probe if by_position else r.rotation_probe
            config = r.position_configuration if by_position else r.rotation_configuration
            rows.append((r.part, f"{r.position_error:.2e}", f"{r.rotation_error:.2e}",
                         probe or "-", str(config)))
        lines += _columns(rows)
    if report.validations:
        lines += ["", "validators:"]
        rows = [("file", "validator", "errors", "warnings")]
        rows += [(Path(v.path).name, v.tool, str(v.errors), str(v.warnings))
                 for v in report.validations]
        lines += _columns(rows)
        for v in report.validations:
            lines += [f"  {Path(v.path).name}: {m}" for m in v.messages[:5]]
    if report.overlaps is not None:
        o = report.overlaps
        lines += ["", f"collision pieces of two parts overlapping at q = 0 (deeper than "
                  f"{TOLERANCE * 1000:g} mm, {Path(o.file).name if o.file else '-'}): "
                  + (o.message or str(len(o.overlaps)))]
        lines += [f"  {x.part_a} / {x.part_b}: {x.depth * 1000:.1f} mm" for x in o.overlaps]
    if report.dynamics:
        lines += ["", "dynamics against the source (masses, inertias, centres of mass; joints' "
                  "damping, friction, armature, stiffness, limits; tolerance "
                  f"{report.tol_dynamics:g}):"]
        rows = [("file", "tool", "verdict")]
        for d in report.dynamics:
            left = d.differences - len(d.repaired)
            verdict = (f"not compared: {d.note}" if not d.compared else
                       "equal" if not d.differences else
                       f"{d.differences} differ, {len(d.repaired)} repaired by the reader"
                       + (f", {left} not" if left else ""))
            rows.append((Path(d.file).name, d.tool, verdict))
        lines += _columns(rows)
        for d in report.dynamics:
            lines += [f"  repaired ({Path(d.file).name}, {d.tool}): {r}" for r in d.repaired[:5]]
    if report.mismatches:
        lines += ["", f"mismatches ({len(report.mismatches)}):"]
        lines += [f"  {m.probe}: {m.message}" for m in report.mismatches]
    lines += ["", "AGREE" if report.ok else "DISAGREE"]
    return "\n".join(lines)


def _columns(rows: list[tuple[str, ...]]) -> list[str]:
    widths = [max(len(r[c]) for r in rows) for c in range(len(rows[0]))]
    return ["  ".join(cell.ljust(w) for cell, w in zip(r, widths, strict=True)).rstrip()
            for r in rows]
