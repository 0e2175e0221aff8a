"""A USD source as Newton reads it (``check --reference``, ``export --check``): Newton 1.8's
own USD importer (``ModelBuilder.add_usd``) builds its model, whose joints' frames, axes,
types, tree, limits and rest coordinates pose every body by Newton's joint law (``eval_fk``'s)
in float64; Newton's ``eval_fk`` itself (float32: ~1e-6 m off over a humanoid's chain) must
agree to 1e-4, else the file is refused. It runs in the engines venv (``dynamics.venv``:
Newton pins usd-core < 26.9), one process per check: the probe starts it when it opens the
file, sends it every configuration at once and reads the poses back (JSON lines on stdin
and stdout).

What of Newton's model becomes the probe's parts and joints (docs/formats.md, "check
--reference"):

- a body is the part named as our USD reader names its prim (``conventions.source_name``,
  made unique in the stage's order); its pose is its frame moved to its parent joint's
  anchor on its side, the model's "part frame = joint frame"; a body the file welds to the
  world at the world's frame with its only joint to the world is the root part, at the
  world's frame;
- a revolute or prismatic joint is the joint named as its prim; a D6 of several degrees of
  freedom gives ``<joint>_<axis>`` (``hip_rotX``) as our reader splits it; joints stacked
  between two bodies, which Newton merges into one D6, each their prim's name. Free, ball
  and fixed joints have no joint value: held where Newton starts them;
- joints of no articulation (a stage without an articulation root), which ``eval_fk`` does
  not pose, are walked from the world as our reader walks them;
- Newton keeps the stage's units (metersPerUnit is "not supported": warned, not applied):
  positions and prismatic values are scaled to metres here.

Where Newton's model is not the file's (an axis it locks, a stack it reorders or merges at
one anchor, two rotations at a skew) the file is refused with the reason.

The first answer carries Newton's model's dynamics too (:func:`_dynamics`: masses, inertias,
centres of mass, groups of welded bodies, joint damping, friction, armature, ranges, in SI),
which ``probes.dynamics.against_newton`` compares with the exports'."""

from __future__ import annotations

import collections
import json
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from ..errors import CheckError
from . import JointInfo

LABEL = "Newton (USD)"
# Newton's "no limit": +-1e10 (JOINT_LIMIT_UNLIMITED), or the USD importer's +-inf degrees
# clamped to +-1e10 degrees and turned to radians (1.7e8)
_UNLIMITED = 1e7


class NewtonProbe:
    label = LABEL

    def __init__(self, path: Path):
        from ..dynamics import EngineUnavailable
        from ..dynamics.venv import ENGINES_VENV, REPO

        self.path = path
        python = ENGINES_VENV.python()
        if python is None:
            raise EngineUnavailable(
                f"{path}: Newton, the USD source's own tool, is not installed: there is no "
                f"venv at {ENGINES_VENV.default_python.parents[1]} (run {ENGINES_VENV.setup}, "
                f"or name its Python in {ENGINES_VENV.override})")
        env = {**os.environ, "PYTHONPATH": str(REPO)}
        # (what warp and USD print, to a file: a pipe nobody reads would fill and stall it)
        self._stderr = tempfile.TemporaryFile(mode="w+")  # noqa: SIM115 - closed with the probe
        self._process = subprocess.Popen(
            [str(python), "-m", __name__], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=self._stderr, text=True, env=env)
        head = self._ask({"path": str(path)})
        self.parts: list[str] = head["parts"]
        self.joints = [JointInfo(j["name"], j["kind"], j["lower"], j["upper"])
                       for j in head["joints"]]
        # Newton's model's masses, inertias and joint dynamics (:func:`_dynamics`)
        self.dynamics: dict = head["dynamics"]

    def _ask(self, request: dict) -> dict:
        assert self._process.stdin is not None and self._process.stdout is not None
        try:
            self._process.stdin.write(json.dumps(request) + "\n")
            self._process.stdin.flush()
        except BrokenPipeError:
            pass
        line = self._process.stdout.readline()
        if not line:
            self._process.wait()
            raise CheckError(f"{self.path}: Newton could not load it: {self._last_line()}")
        answer = json.loads(line)
        if "error" in answer:
            self.close()
            raise CheckError(f"{self.path}: Newton refuses it: {answer['error']}")
        return answer

    def _last_line(self) -> str:
        self._stderr.seek(0)
        lines = [line for line in self._stderr.read().splitlines() if line.strip()]
        return lines[-1] if lines else f"exit status {self._process.returncode}"

    def close(self) -> None:
        if self._process.poll() is None:
            self._process.stdin.close()
            self._process.wait()
        self._stderr.close()

    def __del__(self):  # (the process ends with the probe)
        process = getattr(self, "_process", None)
        if process is not None and process.poll() is None:
            process.kill()
            process.wait()
        if hasattr(self, "_stderr"):
            self._stderr.close()

    def poses(self, q: dict[str, float]) -> dict[str, np.ndarray]:
        values = [float(q.get(j.name, 0.0)) for j in self.joints]
        return dict(zip(self.parts, self.pose_array([values])[0], strict=True))

    def pose_array(self, values) -> np.ndarray:
        """(N, len(joints)) joint values -> (N, len(parts), 4, 4), in one request."""
        values = np.atleast_2d(np.asarray(values, dtype=float))
        answer = self._ask({"values": values.tolist()})
        return np.asarray(answer["poses"], dtype=float).reshape(len(values), len(self.parts),
                                                                4, 4)


def open_probes(path: str | Path) -> list[NewtonProbe]:
    return [NewtonProbe(Path(path))]


# -- the server side, in the engines venv --------------------------------------------------------
def _build(path: str):
    """Newton's model of ``path`` and what the probe is told of it."""
    import warnings

    import newton
    import warp as wp
    from pxr import Usd

    from ..dynamics.newton import _unshift_limits
    from ..formats.usd.conventions import source_name

    wp.config.quiet = True
    builder = newton.ModelBuilder(up_axis=newton.Axis.Z)
    # MuJoCo's attributes registered: the importer then records each degree of freedom's
    # prim (``mujoco:joint_dof_label``) and shifts limits by ``mjc:ref`` (undone)
    newton.solvers.SolverMuJoCo.register_custom_attributes(builder)
    with warnings.catch_warnings(record=True) as said:  # (its notes on what it does not
        warnings.simplefilter("always")  # import, ours say; one of them is a refusal here)
        result = builder.add_usd(path, collapse_fixed_joints=False, load_visual_shapes=False,
                                 skip_mesh_approximation=True)
    # joints stacked between two bodies at different anchors: Newton merges them into one D6
    # at the first one's anchor, so it turns the body otherwise than the file
    moved = [str(w.message) for w in said if "different anchor positions" in str(w.message)]
    if moved:
        raise ValueError(moved[0])
    _unshift_limits(builder)
    # a stage without an articulation root: Newton keeps its joints for its maximal-
    # coordinate solvers, outside any articulation (finalize's joint validation refuses them;
    # eval_fk poses none of them: _JointLaw does)
    model = builder.finalize(device="cpu", skip_validation_joints=True)
    mpu = float(result.get("linear_unit") or 1.0)
    stage = Usd.Stage.Open(path)
    _refuse_locked_axes(stage)

    def prim_of(label: str):
        """The prim Newton's label names; None for what Newton added (a free joint)."""
        prim = stage.GetPrimAtPath(label) if label.startswith("/") else None
        return prim if prim else None

    places = stage_order(stage)

    def name_of(prim_path: str) -> str:
        prim = prim_of(prim_path)
        return source_name(prim) if prim else prim_path.rsplit("/", 1)[-1]

    jtype = newton.JointType
    types = model.joint_type.numpy()
    child = model.joint_child.numpy()
    q_start = model.joint_q_start.numpy()
    qd_start = model.joint_qd_start.numpy()
    dof_dim = model.joint_dof_dim.numpy()
    lower = model.joint_limit_lower.numpy().astype(float)
    upper = model.joint_limit_upper.numpy().astype(float)
    # each degree of freedom's prim, as Newton records it for MuJoCo's actuators: a joint's
    # own path; a D6 prim's "<path>:rotX"; each prim of a merged stack its own path
    dof_label = builder.custom_attributes["mujoco:joint_dof_label"].values
    _refuse_reordered_stacks(places, [
        [str(dof_label.get(int(qd_start[j]) + k, label)).partition(":")[0]
         for k in range(int(dof_dim[j].sum()))] for j, label in enumerate(model.joint_label)])
    _refuse_skew_axes(model, jtype.D6, [name_of(label) for label in model.joint_label])
    law = _JointLaw(newton, model, {
        j for j, label in enumerate(model.joint_label)
        if (prim := prim_of(label)) is not None
        and (attr := prim.GetAttribute("physics:excludeFromArticulation")) and attr.Get()})
    parts = _unique([name_of(label) for label in model.body_label],
                    [places.get(label, -1) for label in model.body_label])
    setters = []  # (joint name, kind, lower, upper, index into joint_q, scale to Newton's)
    setter_order = []  # each one's prim's place in the stage
    setter_dofs = []  # each one's degree of freedom (index into the joint_dof arrays)
    setter_unread = []  # each one's quantities the file states where Newton does not read
    held = []  # (index into joint_q, value): a degree of freedom whose limits are equal
    held_dofs: dict[int, int] = {}  # joint -> how many of its degrees of freedom are held
    for j, label in enumerate(model.joint_label):
        kind = int(types[j])
        if kind not in (jtype.REVOLUTE, jtype.PRISMATIC, jtype.D6) or j not in law.posed_joints:
            continue  # free, ball, fixed, distance: held where Newton starts them
        n_lin, n_ang = (int(n) for n in dof_dim[j])
        labels = [str(dof_label.get(int(qd_start[j]) + k, label)) for k in range(n_lin + n_ang)]
        for k, dof_path in enumerate(labels):
            dof = int(qd_start[j]) + k
            prim_path, _, axis = dof_path.partition(":")
            name = name_of(prim_path)
            if axis and len(labels) > 1:  # a D6 prim's axis, split as our reader splits it
                name = f"{name}_{axis}"
            angular = kind == jtype.REVOLUTE or (kind == jtype.D6 and k >= n_lin)
            lo, hi = (_authored_limit(prim_of(prim_path), axis, side, angular)
                      if abs(value) >= _UNLIMITED else value
                      for side, value in (("low", lower[dof]), ("high", upper[dof])))
            limited = lo is not None and hi is not None
            scale = 1.0 if angular else mpu
            if limited and lo == hi:  # held there (PhysX and Newton): no joint, as our
                held.append((int(q_start[j]) + k, lo))  # reader reads it (a fixed joint)
                held_dofs[j] = held_dofs.get(j, 0) + 1
                continue
            dof_kind = ("revolute" if limited else "continuous") if angular else "prismatic"
            setters.append((name, dof_kind, lo * scale if limited else None,
                            hi * scale if limited else None, int(q_start[j]) + k, scale))
            setter_order.append(places.get(prim_path, -1))
            setter_dofs.append(dof)
            setter_unread.append(_unread(prim_of(prim_path)))
    for k, name in enumerate(_unique([x[0] for x in setters], setter_order)):
        setters[k] = (name, *setters[k][1:])
    head = {"parts": parts,
            "joints": [{"name": n, "kind": k, "lower": lo, "upper": hi}
                       for n, k, lo, hi, _, _ in setters]}
    # The file's one joint to the world, fixed, holding its body at the world's frame: the
    # body is the model's root part, whose frame is the world's (our USD reader's; the MJCF
    # writer makes it the world body), where Newton's part frame would be the joint's. (Held
    # elsewhere, the body keeps its frame, from a part 'world', and is posed as any body.)
    to_world = [j for j, label in enumerate(model.joint_label)
                if model.joint_parent.numpy()[j] < 0 and prim_of(label) is not None]
    x_p, x_c = model.joint_X_p.numpy().astype(float), model.joint_X_c.numpy().astype(float)
    law.at_world = [int(child[j]) for j in to_world
                    if len(to_world) == 1 and int(types[j]) == jtype.FIXED
                    and np.allclose(_transform(x_p[j]) @ np.linalg.inv(_transform(x_c[j])),
                                    np.eye(4), rtol=0.0, atol=1e-6)]
    rest = model.joint_q.numpy()
    for index, value in held:
        rest[index] = value
    model.joint_q.assign(rest)
    # Newton's eval_fk and the law read here agree, or the file is refused when it opens
    # (not midway through a check): a few configurations within the ranges (and within a
    # turn or a metre, as the check samples an unbounded joint)
    low = [max(lo, -math.pi) if lo is not None else -1.0 for _, _, lo, _, _, _ in setters]
    high = [min(hi, math.pi) if hi is not None else 1.0 for _, _, _, hi, _, _ in setters]
    _poses(newton, model, law, setters, mpu, np.random.default_rng(0).uniform(
        low, high, size=(_SELF_CHECKS, len(setters))))
    welded = [j for j in range(len(types)) if int(types[j]) == jtype.FIXED
              or held_dofs.get(j, -1) == int(dof_dim[j].sum())]  # (all its degrees held)
    head["dynamics"] = _dynamics(model, law, parts, lambda label: _mass_authored(prim_of(label)),
                                 setters, setter_dofs, setter_unread, welded,
                                 mpu, _stage_kilograms_per_unit(stage))
    return newton, model, law, setters, mpu, head


# Newton's default importer (its SchemaResolverNewton alone) reads a joint's damping,
# friction and armature from NewtonJointAPI; MjcJointAPI's (SchemaResolverMjc) and
# PhysxJointAPI's armature (SchemaResolverPhysx) only when asked. Our reader reads
# NewtonJointAPI's and MjcJointAPI's (formats/usd/joint.read_dynamics).
NEWTON_READS = {"damping": ("newton:damping", "mjc:damping"),
                "frictionloss": ("newton:friction", "mjc:frictionloss"),
                "armature": ("newton:armature", "mjc:armature")}


def _unread(prim) -> list[str]:
    """The quantities a joint prim states in MjcJointAPI only, which Newton's default
    importer does not read and our reader does (each ``"<quantity> (<attribute>)"``)."""
    def authored(name: str) -> bool:
        attr = prim.GetAttribute(name) if prim is not None else None
        return bool(attr and attr.HasAuthoredValue())

    return [f"{q} ({mjc})" for q, (newton, mjc) in NEWTON_READS.items()
            if authored(mjc) and not authored(newton)]


def _mass_authored(prim) -> bool:
    """Whether a body prim states its mass or its density (PhysicsMassAPI's, > 0), both in
    stage units, which Newton reads as they are, rather than weighing its colliders at its
    default density."""
    from pxr import UsdPhysics

    if prim is None or not prim.HasAPI(UsdPhysics.MassAPI):
        return False
    api = UsdPhysics.MassAPI(prim)
    return any(float(a.Get() or 0.0) > 0.0 for a in (api.GetMassAttr(), api.GetDensityAttr()))


def _stage_kilograms_per_unit(stage) -> float:
    """The stage's kilogramsPerUnit where authored, else 1: what Newton's importer reads
    (and warns it does not apply)."""
    from pxr import UsdPhysics

    return float(UsdPhysics.GetStageKilogramsPerUnit(stage)) \
        if UsdPhysics.StageHasAuthoredKilogramsPerUnit(stage) else 1.0


def _dynamics(model, law, parts, mass_authored, setters, setter_dofs, setter_unread,
              welded, mpu: float, kpu: float) -> dict:
    """Newton's model's dynamics, in SI (Newton keeps the stage's units; the mass and the
    lengths scaled here by kilogramsPerUnit and metersPerUnit): per part its mass, its
    inertia about its centre of mass in world axes and its centre of mass in the world, at
    the probe's configuration 0 (its joints at 0, the others where Newton starts them) and in
    the probe's frames (a root part at the world's); the parts' groups (welded by Newton's
    fixed joints, and by a degree of freedom held at equal limits, as our reader reads it);
    per joint of the probe its damping, friction and armature (Newton's ``joint_damping``,
    ``joint_friction``, ``joint_armature``: per radian for a rotation), its range, and what
    the file states of them where Newton's importer does not read (:func:`_unread`); the
    parts Newton weighs at its default density on a stage not in metres
    (``unit_bound``: those whose label ``mass_authored`` says states no mass nor density)."""
    zero = np.zeros((1, len(setters)))
    import newton

    reported = np.asarray(_poses(newton, model, law, setters, mpu, zero)[0], dtype=float)
    mass = model.body_mass.numpy().astype(float)
    com = model.body_com.numpy().astype(float)
    inertia = model.body_inertia.numpy().astype(float)
    bodies = {}
    for b, name in enumerate(parts):
        turn, at = reported[b][:3, :3], reported[b][:3, 3]
        bodies[name] = {
            "mass": mass[b] * kpu,
            "inertia": (turn @ inertia[b] @ turn.T * kpu * mpu * mpu).tolist(),
            "com": (at + turn @ (com[b] - law.offset[b]) * mpu).tolist()}
    parent, child = model.joint_parent.numpy(), model.joint_child.numpy()
    # a kinematic body (physics:kinematicEnabled) is moved by the user, not by its mass:
    # the world's, as our reader fixes it
    kinematic = int(newton.BodyFlags.KINEMATIC)
    held = [(-1, b) for b, flags in enumerate(model.body_flags.numpy()) if int(flags) & kinematic]
    # (a ball of the tree: one closing a loop, which no URDF holds either, joins nothing)
    balls = [j for j, t in enumerate(model.joint_type.numpy())
             if int(t) == newton.JointType.BALL and j in law.posed_joints]

    def groups(joints: list[int]) -> dict[str, str]:
        """Each part's group: its bodies joined by ``joints`` (and the kinematic ones to the
        world), named by the first in Newton's order ("": the world's)."""
        group = {b: b for b in range(-1, len(parts))}  # -1: the world

        def root(b):
            while group[b] != b:
                b = group[b]
            return b

        for a, c in [(int(parent[j]), int(child[j])) for j in joints] + held:
            a, c = root(a), root(c)
            if a != c:
                group[max(a, c)] = min(a, c)  # (the world, -1, stays a root)
        return {name: (parts[root(b)] if root(b) >= 0 else "") for b, name in enumerate(parts)}
    damping, friction, armature = (getattr(model, f"joint_{q}").numpy().astype(float)
                                   for q in ("damping", "friction", "armature"))
    joints = {}
    for (name, kind, lo, hi, _, _), dof, unread in zip(setters, setter_dofs, setter_unread,
                                                       strict=True):
        angular = kind != "prismatic"
        # stage units -> SI (as our reader converts them): kg m^2/s, kg m^2/s^2, kg m^2 for
        # a rotation; kg/s, kg m/s^2, kg for a slide
        scale = (kpu * mpu * mpu,) * 3 if angular else (kpu, kpu * mpu, kpu)
        joints[name] = {"damping": damping[dof] * scale[0],
                        "frictionloss": friction[dof] * scale[1],
                        "armature": armature[dof] * scale[2],
                        "limited": lo is not None, "unread": unread,
                        **({"range": [lo, hi]} if lo is not None else {})}
    # Newton's stand-in where its mass computation leaves a body with mass and no inertia
    # (import_usd: "assume a uniform density sphere with the given mass", at its default
    # density, about the body's origin): not the colliders' tensor, which OpenUSD's own
    # ComputeMassProperties gives (and our reader)
    default_density = float(newton.ModelBuilder.ShapeConfig().density)
    # (a body weighed from a sphere at that density has that very tensor: not a stand-in)
    round_ = {int(b) for b, kind in zip(model.shape_body.numpy(), model.shape_type.numpy(),
                                       strict=True) if int(kind) == int(newton.GeoType.SPHERE)}
    sphered = []
    for b, name in enumerate(parts):
        if mass[b] <= 0.0 or b in round_:
            continue
        radius = (3.0 * mass[b] / default_density / (4.0 * math.pi)) ** (1.0 / 3.0)
        stand_in = (0.4 * mass[b] * radius ** 2 + mass[b] * float(com[b] @ com[b])) * np.eye(3)
        if np.allclose(inertia[b], stand_in, rtol=1e-5, atol=0.0):
            sphered.append(name)
    # Newton applies no metersPerUnit: where the file states neither mass nor density it
    # weighs the colliders at its default density per cubic stage unit (1000), not per
    # cubic metre (a stated density is per cubic stage unit: right as it is)
    computed = [name for name, label in zip(parts, model.body_label, strict=True)
                if not mass_authored(label)] if not math.isclose(mpu, 1.0) else []
    return {"bodies": bodies,
            "paths": {name: str(label) for name, label in zip(parts, model.body_label,
                                                                strict=True)},
            "unit_bound": computed,
            "default_inertia": sphered,
            "group": groups(welded),
            # as a URDF holds them: a ball joint fixed at its rest (no URDF joint is one)
            "group_as_urdf": groups(welded + balls),
            "joints": joints}


def _authored_limit(prim, axis: str, side: str, angular: bool) -> float | None:
    """A limit Newton clamps to +-1e10 (degrees for a rotation) as the file authors it, in
    Newton's units (radians, stage units): +-inf, or none, is no limit; a finite one (the
    +-1e16 rad of URDF's "no limit", in degrees, as urdf-usd-converter writes it) is kept,
    as our reader keeps it."""
    name = f"limit:{axis}:physics:{side}" if axis else \
        f"physics:{'lowerLimit' if side == 'low' else 'upperLimit'}"
    attr = prim.GetAttribute(name) if prim is not None else None
    value = attr.Get() if attr else None
    if value is None or not math.isfinite(value):
        return None
    return math.radians(value) if angular else float(value)


def _unique(names: list[str], places: list[int]) -> list[str]:
    """``names`` made identifiers and unique as our reader makes them: in the stage's order
    (``places``: each one's prim's place in it), a repeated name suffixed ``_1``, ``_2``."""
    from ..model import sanitize_name

    taken: set[str] = set()
    unique = [""] * len(names)
    for k in sorted(range(len(names)), key=lambda k: places[k]):  # (stable: a D6's axes)
        unique[k] = sanitize_name(names[k], taken)
    return unique


def _refuse_locked_axes(stage) -> None:
    """A generic joint (D6) leaves an axis without a PhysicsLimitAPI free (the schema);
    Newton 1.8's importer makes a degree of freedom of the limited axes only, the others
    locked: its model is then not the file's, and no reference for it."""
    from pxr import Usd

    for prim in Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies()):
        if prim.GetTypeName() != "PhysicsJoint":
            continue
        applied = set(prim.GetAppliedSchemas())
        locked = [axis for axis in ("transX", "transY", "transZ", "rotX", "rotY", "rotZ")
                  if f"PhysicsLimitAPI:{axis}" not in applied]
        if locked:
            raise ValueError(f"generic joint <{prim.GetPath()}> leaves {', '.join(locked)} "
                             "free (no PhysicsLimitAPI), which Newton's importer locks")


def _refuse_skew_axes(model, d6: int, names: list[str]) -> None:
    """Newton's law for a D6 of two rotations orthonormalises its axes (``articulation.
    transform_2d_rotational_axes``: a frame from the axes' matrix), of three takes them as
    given: two hinges of one MJCF body at an angle other than 90 degrees, which MuJoCo turns
    about the axes as they are, turn otherwise in Newton, whose model is then not the file's."""
    types, dims = model.joint_type.numpy(), model.joint_dof_dim.numpy()
    starts, axes = model.joint_qd_start.numpy(), model.joint_axis.numpy().astype(float)
    for j, name in enumerate(names):
        n_lin, n_ang = (int(n) for n in dims[j])
        if int(types[j]) != d6 or n_ang != 2:
            continue
        a0, a1 = axes[int(starts[j]) + n_lin], axes[int(starts[j]) + n_lin + 1]
        cosine = float(a0 @ a1 / (np.linalg.norm(a0) * np.linalg.norm(a1)))
        if abs(cosine) > 1e-6:
            raise ValueError(
                f"joint {name!r}: two rotations about axes {math.degrees(math.acos(cosine)):.4g} "
                "degrees apart, which Newton's D6 joint law makes orthogonal")


def stage_order(stage) -> dict[str, int]:
    """Each prim path's place in the stage's traversal (instance proxies too)."""
    from pxr import Usd

    return {str(p.GetPath()): k for k, p in enumerate(
        Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies()))}


def _refuse_reordered_stacks(order: dict[str, int], dof_prims: list[list[str]]) -> None:
    """Joints stacked between the same two bodies (mujoco-usd-converter's MJCF body of
    several joints) turn one after the other in the stage's order, as MuJoCo applies a
    body's joints and our reader chains them; Newton 1.8 merges them into one D6 in
    UsdPhysics' parse order, its linear axes first (``dof_prims``: per Newton joint, each
    degree of freedom's prim). Where the orders differ, its model turns the body otherwise
    than the file does, and is no reference for it (``order``: :func:`stage_order`)."""
    for prims in dof_prims:
        stack = list(dict.fromkeys(prims))
        if len(stack) > 1 and all(p in order for p in stack):
            in_stage = sorted(stack, key=order.__getitem__)
            if stack != in_stage:
                raise ValueError(
                    f"joints {', '.join(f'<{p}>' for p in in_stage)}, stacked between the same "
                    f"two bodies, turn in that order in the stage; Newton merges them as "
                    f"{', '.join(p.rsplit('/', 1)[-1] for p in stack)}")


def _poses(newton, model, law, setters, mpu, values) -> list:
    """Every configuration's part poses (4x4, metres): Newton's joint law (``eval_fk``'s,
    ``articulation.eval_joint_motion``) on Newton's reading of the file (its joints' frames,
    axes, types, tree and rest coordinates) in float64; Newton's own ``eval_fk``, in float32,
    must give the same poses to its precision, or the probe refuses to answer."""
    import warp as wp

    rest = model.joint_q.numpy().astype(float)
    index = np.array([s[4] for s in setters], dtype=int)
    scale = np.array([s[5] for s in setters], dtype=float)
    state = model.state()
    out = []
    for row in values:
        q = rest.copy()
        if len(index):
            q[index] = np.asarray(row, dtype=float) / scale
        poses = law.body_poses(q)
        newton.eval_fk(model, wp.array(q, dtype=wp.float32, device="cpu"), model.joint_qd,
                       state)
        fk = np.array([_transform(x) for x in state.body_q.numpy().astype(float)])
        mine, theirs = poses[law.by_eval_fk], fk[law.by_eval_fk]
        reach = 1.0 + np.abs(mine[:, :3, 3]).max(initial=0.0)
        worst = max(np.abs(theirs[:, :3, 3] - mine[:, :3, 3]).max(initial=0.0) / reach,
                    np.abs(theirs[:, :3, :3] - mine[:, :3, :3]).max(initial=0.0))
        if worst > _FLOAT32_AGREEMENT:
            raise RuntimeError(f"Newton's eval_fk and its joint law read here differ by "
                               f"{worst:.1e} at q = {row}")
        poses[:, :3, 3] += np.einsum("bij,bj->bi", poses[:, :3, :3], law.offset)
        poses[:, :3, 3] *= mpu
        poses[law.at_world] = np.eye(4)
        out.append(poses.tolist())
    return out


_SELF_CHECKS = 4  # configurations posed both ways when the file opens
# float32 kinematics against float64 over a chain of a few dozen joints: a few 1e-6 relative
_FLOAT32_AGREEMENT = 1e-4


class _JointLaw:
    """Newton's forward kinematics in float64: X_wc = X_wp X_pj X_j(q) X_cj^-1 over the
    joints of its articulations in Newton's order (a joint outside them, closing a loop, is
    not posed: its child stands as the articulation puts it, as in ``eval_fk``)."""

    def __init__(self, newton, model, excluded: set[int]):
        jt = newton.JointType
        self.kinds = {"prismatic": int(jt.PRISMATIC), "revolute": int(jt.REVOLUTE),
                      "ball": int(jt.BALL), "d6": int(jt.D6),
                      "free": {int(jt.FREE), int(jt.DISTANCE)}}
        self.type = model.joint_type.numpy()
        self.parent = model.joint_parent.numpy()
        self.child = model.joint_child.numpy()
        self.articulation = model.joint_articulation.numpy()
        self.q_start = model.joint_q_start.numpy()
        self.qd_start = model.joint_qd_start.numpy()
        self.dof_dim = model.joint_dof_dim.numpy()
        self.axis = model.joint_axis.numpy().astype(float)
        self.x_p = [_transform(x) for x in model.joint_X_p.numpy().astype(float)]
        self.x_c_inv = [np.linalg.inv(_transform(x)) for x in model.joint_X_c.numpy()
                        .astype(float)]
        self.rest = np.array([_transform(x) for x in model.body_q.numpy().astype(float)])
        # Newton orders each articulation's joints from its root; the joints of no
        # articulation follow, walked from what is posed
        self.order = [j for j in range(len(self.type)) if self.articulation[j] >= 0]
        self.by_eval_fk = np.ones(len(self.rest), dtype=bool)  # the bodies eval_fk poses
        # breadth first from the world and what is posed, each body's joints in Newton's
        # order (the stage's), either way (a joint walked from its body1 runs backwards), as
        # our USD reader walks them: a joint reaching a body posed already closes a loop and
        # is not posed (nor a joint of the probe); one the file excludes from the
        # articulation (physics:excludeFromArticulation) walked last; a body no walk
        # reaches (the first in Newton's order) stands where the file puts it, a root
        self.forward = {j: True for j in self.order}
        posed = [-1, *(int(b) for b in self.child[self.order])]
        posed += [b for b in range(len(self.rest)) if b not in set(self.child)]
        reached = set(posed)
        while True:
            for walked_too in (set(), excluded):
                frontier = collections.deque(posed)
                while frontier:
                    body = frontier.popleft()
                    for j in range(len(self.type)):
                        if j in self.forward or self.articulation[j] >= 0 \
                                or (j in excluded and j not in walked_too):
                            continue
                        if self.parent[j] == body and self.child[j] not in reached:
                            self.forward[j], new = True, int(self.child[j])
                        elif self.child[j] == body and self.parent[j] >= 0 \
                                and self.parent[j] not in reached:
                            self.forward[j], new = False, int(self.parent[j])
                        else:
                            continue
                        self.order.append(j)
                        self.by_eval_fk[new] = False
                        reached.add(new)
                        posed.append(new)
                        frontier.append(new)
            root = next((b for b in range(len(self.rest)) if b not in reached), None)
            if root is None:
                break
            reached.add(root)
            posed.append(root)
        # each body's frame -> its part frame: to its joint's anchor on its side
        self.offset = np.zeros((len(self.rest), 3))
        for j in self.order:
            if self.forward[j]:
                self.offset[self.child[j]] = np.linalg.inv(self.x_c_inv[j])[:3, 3]
            else:
                self.offset[self.parent[j]] = self.x_p[j][:3, 3]
        self.posed_joints = set(self.order)
        self.at_world: list[int] = []  # bodies whose part frame is the world's (_build)

    def body_poses(self, q: np.ndarray) -> np.ndarray:
        world = self.rest.copy()
        for j in self.order:
            if self.forward[j]:
                parent = world[self.parent[j]] if self.parent[j] >= 0 else np.eye(4)
                world[self.child[j]] = parent @ self.x_p[j] @ self._motion(j, q) \
                    @ self.x_c_inv[j]
            else:
                world[self.parent[j]] = world[self.child[j]] @ np.linalg.inv(
                    self.x_p[j] @ self._motion(j, q) @ self.x_c_inv[j])
        return world

    def _motion(self, j: int, q: np.ndarray) -> np.ndarray:
        kind, qs, ds = int(self.type[j]), int(self.q_start[j]), int(self.qd_start[j])
        m = np.eye(4)
        if kind == self.kinds["prismatic"]:
            m[:3, 3] = self.axis[ds] * q[qs]
        elif kind == self.kinds["revolute"]:
            m[:3, :3] = _rotation(self.axis[ds], q[qs])
        elif kind == self.kinds["ball"]:
            m[:3, :3] = _transform([0, 0, 0, *q[qs:qs + 4]])[:3, :3]
        elif kind in self.kinds["free"]:
            m = _transform(q[qs:qs + 7])
        elif kind == self.kinds["d6"]:
            n_lin, n_ang = (int(n) for n in self.dof_dim[j])
            for k in range(n_lin):
                m[:3, 3] += self.axis[ds + k] * q[qs + k]
            for k in range(n_lin, n_lin + n_ang):  # each about its axis as the ones before
                m[:3, :3] = m[:3, :3] @ _rotation(self.axis[ds + k], q[qs + k])  # turned it
        return m


def _transform(x) -> np.ndarray:
    """Warp's transform (x, y, z, qx, qy, qz, qw) as a 4x4 matrix."""
    px, py, pz, qx, qy, qz, qw = (float(v) for v in x)
    m = np.eye(4)
    m[:3, :3] = _quat_matrix(qw, qx, qy, qz)
    m[:3, 3] = (px, py, pz)
    return m


def _quat_matrix(w, x, y, z) -> np.ndarray:
    """(normalised: warp stores its quaternions in float32)"""
    s = 2.0 / (w * w + x * x + y * y + z * z)
    return np.array([
        [1 - s * (y * y + z * z), s * (x * y - z * w), s * (x * z + y * w)],
        [s * (x * y + z * w), 1 - s * (x * x + z * z), s * (y * z - x * w)],
        [s * (x * z - y * w), s * (y * z + x * w), 1 - s * (x * x + y * y)]])


def _rotation(axis, angle: float) -> np.ndarray:
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    x, y, z = axis
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def serve() -> None:
    """Read the file's request, answer what Newton makes of it; then each request of joint
    values, answer the poses; until stdin closes."""
    # the answers on a descriptor of their own: what warp and USD print goes to stderr
    answers = os.fdopen(os.dup(1), "w")
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    built = None
    for line in sys.stdin:
        request = json.loads(line)
        try:
            if "path" in request:
                built = _build(request["path"])
                answer = built[-1]
            else:
                answer = {"poses": _poses(*built[:-1], request["values"])}
        except (KeyError, ValueError, RuntimeError) as e:
            answer = {"error": f"{type(e).__name__}: {e}"}
        answers.write(json.dumps(answer) + "\n")
        answers.flush()


if __name__ == "__main__":
    serve()
