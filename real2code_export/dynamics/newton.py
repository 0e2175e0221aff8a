"""Newton 1.8 (its MuJoCo solver, ``use_mujoco_cpu``): the USD, the MJCF or the URDF, each
through Newton's own importer, base fixed. Runs in the engines venv (venv.py): its
importers and solver pin usd-core < 26.9 and mujoco 3.17.

Newton reads joint damping, friction and armature from each file; the constraint softness
only from the MJCF (solreflimit, solreffriction): from the USD and the URDF it makes a limit
its default spring (ke 1e4, kd 10), off which a door rebounds (docs/engines.md). The
experiment sets the initial state by joint name (Newton's USD importer starts at q = 0).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..formats import format_for_path
from . import Experiment, Recorder, Trajectory
from .venv import run_in_venv, serve


def simulate(path: Path, experiment: Experiment) -> Trajectory:
    return run_in_venv(__name__, "newton", path, experiment)


def simulate_here(path: Path, experiment: Experiment) -> Trajectory:
    import newton
    import warp as wp

    wp.config.quiet = True
    builder = newton.ModelBuilder(up_axis=newton.Axis.Z, gravity=tuple(experiment.gravity))
    kind = format_for_path(path).name  # the registry knows the suffixes
    if kind == "usd":
        builder.add_usd(str(path))
    elif kind == "mjcf":
        builder.add_mjcf(str(path), floating=False)
    else:
        builder.add_urdf(str(path), floating=False)
    model = builder.finalize(device="cpu")
    names = [label.rsplit("/", 1)[-1] for label in model.joint_label]
    missing = [n for n in experiment.joints if n not in names]
    if missing:
        raise KeyError(f"{path}: Newton's model has no joint named {missing[0]!r}")
    q_start = model.joint_q_start.numpy()
    qd_start = model.joint_qd_start.numpy()
    q_idx = np.array([q_start[names.index(n)] for n in experiment.joints])
    qd_idx = np.array([qd_start[names.index(n)] for n in experiment.joints])
    q = model.joint_q.numpy()
    qd = model.joint_qd.numpy()
    q[q_idx] = experiment.q0
    qd[qd_idx] = experiment.v0
    # Its MuJoCo solver (on MuJoCo's CPU library): Featherstone applies no joint friction and
    # makes every limit a spring (docs/engines.md).
    solver = newton.solvers.SolverMuJoCo(model, use_mujoco_cpu=True, disable_contacts=True)
    state_0, state_1, control = model.state(), model.state(), model.control()
    state_0.joint_q.assign(q)
    state_0.joint_qd.assign(qd)
    newton.eval_fk(model, state_0.joint_q, state_0.joint_qd, state_0)
    recorder = Recorder(experiment)
    for step in range(experiment.steps + 1):
        if recorder.due(step):
            recorder.add(step, state_0.joint_q.numpy()[q_idx])
        if step < experiment.steps:
            state_0.clear_forces()
            solver.step(state_0, state_1, control, None, experiment.dt)
            state_0, state_1 = state_1, state_0
    return recorder.trajectory()


if __name__ == "__main__":
    serve(simulate_here)
