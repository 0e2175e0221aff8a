"""Newton 1.8 (its MuJoCo solver, ``use_mujoco_cpu``): the USD, the MJCF or the URDF, each
through Newton's own importer, base fixed. Runs in the engines venv (venv.py): its
importers and solver pin usd-core < 26.9 and mujoco 3.17.

Newton reads joint damping, friction and armature from each file, and MuJoCo's constraint
softness (solreflimit, solimplimit, solreffriction) from the MJCF and, once the solver's
attributes are registered before import, from the USD's MjcJointAPI; a URDF has no place
for them, so they are set as MuJoCo (URDF) is told. Without them Newton makes a limit its
default spring (ke 1e4, kd 10), off which a door rebounds. Its USD importer reads the
observed state with PhysX's schema resolver (else it starts at q = 0) and counts limits
from the written pose when ``mjc:ref`` is authored (see ``_unshift_limits``); its MJCF
importer counts joint values from the written pose too (q - ref; our MJCF writes ref = the
state); the experiment sets the initial state by joint name and its gravity (a USD's PhysicsScene
would set its own).
An experiment's boxes are free bodies; ``self_contacts`` drops the importers' filtered
shape pairs between bodies and MuJoCo's parent/child filter. Newton turns MuJoCo's several
contact points per convex pair (multiccd) off unless the file asks for them, as our MJCF
and USD do; a URDF's run is told.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..engine_settings import MULTICCD
from ..formats import format_for_path
from . import Experiment, Recorder, Trajectory
from .venv import Outcome, run_in_venv, run_many_in_venv, serve


def simulate(path: Path, experiment: Experiment) -> Trajectory:
    return run_in_venv(__name__, "newton", path, experiment)


def simulate_many(cases: list[tuple[Path, Experiment]]) -> list[Outcome]:
    """Every case in one process (venv.py)."""
    return run_many_in_venv(__name__, "newton", cases)


def simulate_here(path: Path, experiment: Experiment, featherstone: bool = False
                  ) -> Trajectory:
    """With ``featherstone``, Newton's own reduced-coordinate solver instead of MuJoCo's
    (newton_featherstone.py says what it leaves out)."""
    import newton
    import warp as wp

    wp.config.quiet = True
    builder = newton.ModelBuilder(up_axis=newton.Axis.Z, gravity=tuple(experiment.gravity))
    # its importers read the mjc:* attributes (solreflimit, solreffriction, armature) only
    # into attributes the solver registered first
    newton.solvers.SolverMuJoCo.register_custom_attributes(builder)
    kind = format_for_path(path).name  # the registry knows the suffixes
    if kind == "usd":
        # with PhysX's resolver it reads the observed state (state:*:physics:position), as
        # Isaac Sim does; its default resolvers start every joint at 0
        from newton.usd import SchemaResolverNewton, SchemaResolverPhysx

        builder.add_usd(str(path),
                        schema_resolvers=[SchemaResolverNewton(), SchemaResolverPhysx()])
        _unshift_limits(builder)
    elif kind == "mjcf":
        builder.add_mjcf(str(path), floating=False)
    else:
        builder.add_urdf(str(path), floating=False)
        _mujoco_softness(builder)
    if experiment.self_contacts:
        body = builder.shape_body
        builder.shape_collision_filter_pairs = [
            (a, b) for a, b in builder.shape_collision_filter_pairs if body[a] == body[b]]
    boxes = _add_boxes(newton, wp, builder, experiment)
    model = builder.finalize(device="cpu")
    model.set_gravity(tuple(experiment.gravity))  # a USD's PhysicsScene sets its own
    names = [label.rsplit("/", 1)[-1] for label in model.joint_label]
    missing = [n for n in experiment.joints if n not in names]
    if missing:
        raise KeyError(f"{path}: Newton's model has no joint named {missing[0]!r}")
    q_start = model.joint_q_start.numpy()
    qd_start = model.joint_qd_start.numpy()
    q_idx = np.array([q_start[names.index(n)] for n in experiment.joints])
    qd_idx = np.array([qd_start[names.index(n)] for n in experiment.joints])
    # an MJCF's joints count from the written pose in Newton (q - ref, its limits moved
    # alike); its USD and URDF joints count as ours
    ref = _mjcf_refs(builder, qd_idx) if kind == "mjcf" else np.zeros(len(qd_idx))
    q = model.joint_q.numpy()
    qd = model.joint_qd.numpy()
    q[q_idx] = np.asarray(experiment.q0, dtype=np.float64) - ref
    qd[qd_idx] = experiment.v0
    if featherstone:
        if experiment.contacts:
            raise ValueError("Newton's Featherstone solver is run without contacts here")
        solver = newton.solvers.SolverFeatherstone(model, angular_damping=0.0)
    else:  # its MuJoCo solver, on MuJoCo's CPU library
        # its default turns MuJoCo's several contact points per convex pair off (a box then
        # rests 5 mm deep): our MJCF and USD say multiccd; a URDF has no place for it
        multiccd = MULTICCD if kind == "urdf" else None
        solver = newton.solvers.SolverMuJoCo(model, use_mujoco_cpu=True,
                                             disable_contacts=not experiment.contacts,
                                             enable_multiccd=multiccd)
    if experiment.self_contacts and not featherstone:
        import mujoco

        solver.mj_model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
    state_0, state_1, control = model.state(), model.state(), model.control()
    state_0.joint_q.assign(q)
    state_0.joint_qd.assign(qd)
    newton.eval_fk(model, state_0.joint_q, state_0.joint_qd, state_0)
    if featherstone:
        _featherstone_limits(newton, model, solver, q, experiment.dt)
        _narrow_limits(model)
    recorder = Recorder(experiment)
    for step in range(experiment.steps + 1):
        if recorder.due(step):
            recorder.add(step, state_0.joint_q.numpy()[q_idx] + ref,
                         state_0.body_q.numpy()[boxes, :3])
        if step < experiment.steps:
            state_0.clear_forces()
            solver.step(state_0, state_1, control, None, experiment.dt)
            state_0, state_1 = state_1, state_0
    return recorder.trajectory()


def _featherstone_limits(newton, model, solver, q: np.ndarray, dt: float) -> None:
    """Featherstone's limit is a spring and damper acting while a joint is past it (its
    default ke 1e4, kd 10 whatever the joint: a door rebounds 1.6 to 4 rad off). Told here,
    per joint, the stiffest its explicit step takes without overshoot: MuJoCo's shortest
    limit (solref: time constant 2 dt), critically damped, scaled by the joint's effective
    inertia at the start, 1 / (H^-1)_ii from the solver's own joint-space inertia H (armature
    added), as MuJoCo scales its constraint. They depend on the step, so no file authors them
    (docs/engines.md)."""
    scratch_in, scratch_out = model.state(), model.state()
    scratch_in.joint_q.assign(q)
    newton.eval_fk(model, scratch_in.joint_q, scratch_in.joint_qd, scratch_in)
    solver.step(scratch_in, scratch_out, model.control(), None, dt)  # evaluates H at q
    h = solver.H.numpy()
    armature = model.joint_armature.numpy()
    inertia = np.zeros(model.joint_dof_count)
    for start, n, first in zip(solver.articulation_H_start.numpy(),
                               solver.articulation_H_rows.numpy(),
                               solver.articulation_dof_start.numpy(), strict=True):
        if n:
            block = h[start:start + n * n].reshape(n, n).astype(float)
            block = np.triu(block) + np.triu(block, 1).T + np.diag(armature[first:first + n])
            inertia[first:first + n] = 1.0 / np.diag(np.linalg.inv(block))
    timeconst = 2.0 * dt
    model.joint_limit_kd.assign((inertia * 2.0 / timeconst).astype(np.float32))
    model.joint_limit_ke.assign((inertia / timeconst ** 2).astype(np.float32))


def _narrow_limits(model) -> None:
    """Featherstone's limit acts once a joint is past it and reads no MuJoCo margin: the
    ranges narrowed by the file's margin (what MuJoCo's margin amounts to; Genesis's alike).
    Without it a joint observed at its limit and pushed into it goes one step (v dt) in,
    and its limit damper, which also resists the way out, holds it there while gravity
    pulls: the demo's flaps left their open limits ~10 ms late, 9.2e-2 rad by their fall."""
    margin = getattr(getattr(model, "mujoco", None), "limit_margin", None)
    if margin is None:
        return
    margin = margin.numpy().astype(float)
    lower = model.joint_limit_lower.numpy().astype(float)
    upper = model.joint_limit_upper.numpy().astype(float)
    narrow = (margin > 0) & np.isfinite(lower) & np.isfinite(upper) & (upper - lower > 2 * margin)
    model.joint_limit_lower.assign(np.where(narrow, lower + margin, lower).astype(np.float32))
    model.joint_limit_upper.assign(np.where(narrow, upper - margin, upper).astype(np.float32))


def _mujoco_softness(builder) -> None:
    """A URDF has no place for MuJoCo's limit and friction softness and limit margin: the
    values our MJCF and USD author, set on every DOF as MuJoCo (URDF) is told
    (docs/engines.md). Without them Newton makes a limit its spring (ke 1e4, kd 10) and lets
    dry friction creep."""
    from newton._src.solvers.mujoco.solver_mujoco import SOLREF_MODE_RAW

    from ..engine_settings import FRICTION_SOLREF, LIMIT_MARGIN, LIMIT_SOLIMP, LIMIT_SOLREF

    attrs = builder.custom_attributes
    dtype = attrs["mujoco:solimplimit"].dtype
    for dof in range(len(builder.joint_limit_lower)):
        attrs["mujoco:solreflimit"].values[dof] = attrs["mujoco:solreflimit"].dtype(
            *LIMIT_SOLREF)
        attrs["mujoco:solreflimit_mode"].values[dof] = SOLREF_MODE_RAW
        attrs["mujoco:solimplimit"].values[dof] = dtype(*LIMIT_SOLIMP)
        attrs["mujoco:solreffriction"].values[dof] = attrs["mujoco:solreffriction"].dtype(
            *FRICTION_SOLREF)
        attrs["mujoco:limit_margin"].values[dof] = LIMIT_MARGIN


def _mjcf_refs(builder, dofs) -> np.ndarray:
    """Each of ``dofs``' MJCF ``ref`` as Newton's MJCF importer kept it (0 where none)."""
    ref = builder.custom_attributes.get("mujoco:dof_ref")
    values = ref.values if ref is not None and isinstance(ref.values, dict) else {}
    return np.array([float(values.get(int(d), 0.0)) for d in dofs])


def _unshift_limits(builder) -> None:
    """Undo the USD importer's limit shift by ``mjc:ref``. Our USD writes the bodies at the
    observed state and ``mjc:ref`` = that state (the joint value MuJoCo's own USD importer
    gives the written pose). Newton 1.8 counts q from the joint frames (UsdPhysics: our q)
    and hands MuJoCo qpos = q + ref, but moves the limits to [lower - ref, upper - ref] as
    if q counted from the written pose: every limit would sit ``state`` too low."""
    ref = builder.custom_attributes.get("mujoco:dof_ref")
    if ref is None or not isinstance(ref.values, dict):
        return
    for dof, value in ref.values.items():
        builder.joint_limit_lower[dof] += float(value)
        builder.joint_limit_upper[dof] += float(value)


def _add_boxes(newton, wp, builder, experiment: Experiment) -> list[int]:
    half, mass = experiment.box_size / 2, experiment.box_mass
    inertia = mass * experiment.box_size ** 2 / 6
    bodies = []
    for i, centre in enumerate(experiment.boxes):
        body = builder.add_body(xform=wp.transform(wp.vec3(*centre), wp.quat_identity()),
                                mass=mass, inertia=wp.mat33(np.eye(3) * inertia),
                                lock_inertia=True, label=f"real2code_box_{i}")
        builder.add_shape_box(body, hx=half, hy=half, hz=half,
                              cfg=newton.ModelBuilder.ShapeConfig(density=0.0))
        bodies.append(body)
    return bodies


if __name__ == "__main__":
    serve(simulate_here)
