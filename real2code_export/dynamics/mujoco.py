"""MuJoCo: the MJCF (the reference) and the URDF, each compiled by MjSpec and stepped with
the file's own integrator and joint laws; the experiment sets time step, gravity, contacts
and the initial state by joint name. For a URDF, MuJoCo's limit and friction softness and
its limit margin are set as our MJCF authors them (URDF has no place for them). An
experiment's boxes are added as free bodies; with ``self_contacts`` the file's
``<exclude>`` pairs are removed and parent/child filtering is off."""

from __future__ import annotations

from pathlib import Path

from ..formats import is_format
from ..mujoco_files import spec_from_file
from . import EngineUnavailable, Experiment, Recorder, Trajectory


def load(path: Path):
    mujoco, spec = load_spec(path)
    return mujoco, spec.compile()


def load_spec(path: Path):
    try:
        import mujoco
    except ImportError as e:
        raise EngineUnavailable("MuJoCo is not installed (pip install 'real2code-export[sim]')") \
            from e
    spec = spec_from_file(path)
    spec.compiler.discardvisual = True
    if is_format(path, "urdf"):
        # URDF has no place for MuJoCo's constraint softness: the settings our MJCF authors
        # are what a user must set (docs/engines.md).
        from ..engine_settings import FRICTION_SOLREF, LIMIT_MARGIN, LIMIT_SOLIMP, LIMIT_SOLREF

        for joint in spec.joints:
            joint.solref_limit = list(LIMIT_SOLREF)
            joint.solimp_limit = list(LIMIT_SOLIMP)
            joint.solref_friction = list(FRICTION_SOLREF)
            joint.margin = LIMIT_MARGIN
    return mujoco, spec


def _add_boxes(mujoco, spec, experiment: Experiment) -> list[str]:
    names = []
    half = experiment.box_size / 2
    for i, centre in enumerate(experiment.boxes):
        # explicit inertia: our MJCF compiles with inertiafromgeom off
        inertia = experiment.box_mass * experiment.box_size ** 2 / 6
        body = spec.worldbody.add_body(name=f"real2code_box_{i}", pos=list(centre),
                                       mass=experiment.box_mass, inertia=[inertia] * 3,
                                       ipos=[0.0, 0.0, 0.0],
                                       explicitinertial=True)
        body.add_freejoint()
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[half] * 3)
        names.append(body.name)
    return names


def simulate(path: Path, experiment: Experiment) -> Trajectory:
    return _simulate(path, experiment, *load_spec(path))


def simulate_converged(path: Path, experiment: Experiment, refine: int) -> Trajectory:
    """The experiment at 1/``refine`` of its step, sampled at the same times, each limit
    whose time constant is below two of the experiment's steps (one that asks for the
    stiffest stop a step takes: MuJoCo raises it to two steps) at two of these steps: the
    motion the file describes, nearer its continuous limit than any engine at the
    experiment's step (docs/engines.md, "Which motion is right")."""
    import dataclasses

    mujoco, spec = load_spec(path)
    fine = dataclasses.replace(experiment, dt=experiment.dt / refine,
                               sample_every=experiment.sample_every * refine)
    for joint in spec.joints:
        timeconst, ratio = joint.solref_limit
        if 0 < timeconst < 2 * experiment.dt:
            joint.solref_limit = [2 * fine.dt, ratio]
    return _simulate(path, fine, mujoco, spec)


def _simulate(path: Path, experiment: Experiment, mujoco, spec) -> Trajectory:
    if experiment.self_contacts:
        for exclude in list(spec.excludes):
            spec.delete(exclude)
    boxes = _add_boxes(mujoco, spec, experiment)
    model = spec.compile()
    model.opt.timestep = experiment.dt
    model.opt.gravity[:] = experiment.gravity
    if not experiment.contacts:
        model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    if experiment.self_contacts:
        model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
    data = mujoco.MjData(model)
    box_ids = [model.body(n).id for n in boxes]
    qadr, dadr = [], []
    for name in experiment.joints:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if jid < 0:
            raise KeyError(f"{path}: MuJoCo's model has no joint named {name!r}")
        qadr.append(int(model.jnt_qposadr[jid]))
        dadr.append(int(model.jnt_dofadr[jid]))
    data.qpos[qadr] = experiment.q0
    data.qvel[dadr] = experiment.v0
    mujoco.mj_forward(model, data)
    recorder = Recorder(experiment)
    for step in range(experiment.steps + 1):
        if recorder.due(step):
            recorder.add(step, data.qpos[qadr], data.xpos[box_ids])
        if step < experiment.steps:
            mujoco.mj_step(model, data)
    return recorder.trajectory()


def joint_ranges(path: Path) -> dict[str, tuple[float, float] | None]:
    """Each hinge/slide joint's range as MuJoCo compiled it (None: unlimited)."""
    mujoco, model = load(path)
    out: dict[str, tuple[float, float] | None] = {}
    for i in range(model.njnt):
        if int(model.jnt_type[i]) in (int(mujoco.mjtJoint.mjJNT_HINGE),
                                      int(mujoco.mjtJoint.mjJNT_SLIDE)):
            out[model.joint(i).name] = (tuple(float(v) for v in model.jnt_range[i])
                                        if model.jnt_limited[i] else None)
    return out
