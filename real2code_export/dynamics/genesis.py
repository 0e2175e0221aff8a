"""Genesis (its rigid solver on the CPU, double precision): the URDF or the MJCF, base
fixed. Runs in ``.venv-genesis`` (scripts/setup_genesis.sh; venv.py): it needs torch and
pins mujoco 4.0, which Newton's 3.17 in ``.venv-engines`` clashes with.

What a user must set (docs/engines.md): ``default_armature=None`` on the morph (Genesis
takes an armature of exactly 0 as unset and adds 0.1); MuJoCo's Euler integrator (Genesis
defaults to its own approximation of implicitfast); the joint values from ``get_qpos``:
``get_dofs_position`` holds the values before the last step's position update (the
trajectory would lag one step). From a URDF, which has no place for them, the laws Genesis
does not read are set from our ``real2code:`` attributes: armature, springs; and MuJoCo's
limit softness and margin as our MJCF authors them (a margin, which Genesis reads from no
file, as the range narrowed by it) (Genesis keeps one set of constraint parameters per
joint, for its limit and its dry friction alike). Genesis's spring pulls toward the joint's
reference pose (``qpos0``), not MuJoCo's ``springref``: the difference is a constant joint
force. In the contact experiments every pair of parts collides (Genesis filters a joint's
parent and child, and pieces touching at q = 0, unless told; it reads no MJCF ``<exclude>``)
and the boxes are free cubes of the experiment's mass.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..formats import format_for_path
from ..mujoco_files import mujoco_path
from . import Experiment, Recorder, Trajectory, urdf_laws
from .venv import GENESIS_VENV, Outcome, run_in_venv, run_many_in_venv, serve


def simulate(path: Path, experiment: Experiment) -> Trajectory:
    return run_in_venv(__name__, "genesis", path, experiment, GENESIS_VENV)


def simulate_many(cases: list[tuple[Path, Experiment]]) -> list[Outcome]:
    """Every case in one process (venv.py)."""
    return run_many_in_venv(__name__, "genesis", cases, GENESIS_VENV)


def _mjcf_joints(path: Path) -> dict[str, tuple[float, float, float, float]]:
    """Each MJCF joint's (stiffness, springref, qpos0, limit margin) as MuJoCo compiles
    them."""
    import mujoco

    m = mujoco.MjModel.from_xml_path(mujoco_path(path))
    out = {}
    for j in range(m.njnt):
        adr = int(m.jnt_qposadr[j])
        out[m.joint(j).name] = (float(m.jnt_stiffness[j]), float(m.qpos_spring[adr]),
                                float(m.qpos0[adr]), float(m.jnt_margin[j]))
    return out


def simulate_here(path: Path, experiment: Experiment) -> Trajectory:
    import genesis as gs

    from ..engine_settings import LIMIT_MARGIN, LIMIT_SOLIMP, LIMIT_SOLREF

    if not gs._initialized:
        gs.init(backend=gs.cpu, precision="64", logging_level="warning")
    scene = gs.Scene(
        sim_options=gs.options.SimOptions(dt=experiment.dt, gravity=tuple(experiment.gravity)),
        rigid_options=gs.options.RigidOptions(
            enable_collision=experiment.contacts, integrator=gs.integrator.Euler,
            # every pair of parts collides, a joint's parent and child and pieces that touch
            # at q = 0 included (Genesis filters both by default)
            enable_self_collision=experiment.self_contacts,
            enable_adjacent_collision=experiment.self_contacts,
            enable_neutral_collision=experiment.self_contacts),
        show_viewer=False)
    urdf = format_for_path(path).name == "urdf"
    morph = gs.morphs.URDF(file=str(path), fixed=True, default_armature=None) if urdf else \
        gs.morphs.MJCF(file=str(path), default_armature=None)
    entity = scene.add_entity(morph)
    boxes = _add_boxes(gs, scene, experiment)
    scene.build()
    joints = {j.name: j for j in entity.joints}
    missing = [n for n in experiment.joints if n not in joints]
    if missing:
        raise KeyError(f"{path}: Genesis's entity has no joint named {missing[0]!r}")
    movable = [j for j in entity.joints if j.n_dofs == 1]
    dofs = [j.dofs_idx_local[0] for j in movable]
    if urdf:
        laws = urdf_laws(path)
        for joint in movable:
            joint.set_sol_params(np.array([*LIMIT_SOLREF, *LIMIT_SOLIMP]))
        law = [laws.get(j.name, {}) for j in movable]
        entity.set_dofs_armature(np.array([x.get("armature", 0.0) for x in law]), dofs)
        stiffness = np.array([x.get("stiffness", 0.0) for x in law])
        spring_ref = np.array([x.get("springref", 0.0) for x in law])
        qpos0 = np.zeros(len(movable))  # Genesis's reference pose of a URDF joint
        entity.set_dofs_stiffness(stiffness, dofs)
        margin = np.full(len(movable), LIMIT_MARGIN)
    else:
        springs = _mjcf_joints(path)
        stiffness, spring_ref, qpos0, margin = (np.array([springs[j.name][i] for j in movable])
                                                for i in range(4))
    _narrow_limits(entity, dofs, margin)
    # the spring toward springref, not qpos0: a constant force makes up the difference
    offset = stiffness * (spring_ref - qpos0)
    if np.any(offset):
        entity.set_dofs_force_range(np.full(len(dofs), -np.inf), np.full(len(dofs), np.inf),
                                    dofs)
        entity.control_dofs_force(offset, dofs)
    q_idx = [joints[n].qs_idx_local[0] for n in experiment.joints]
    v_idx = [joints[n].dofs_idx_local[0] for n in experiment.joints]
    # the joint values themselves: a dof's "position" is its deflection from qpos0, which an
    # MJCF's ref (our MJCF writes ref = the state) moves away from the joint value
    entity.set_qpos(np.array(experiment.q0), q_idx, zero_velocity=False)
    entity.set_dofs_velocity(np.array(experiment.v0), v_idx)
    recorder = Recorder(experiment)
    for step in range(experiment.steps + 1):
        if recorder.due(step):
            recorder.add(step, np.asarray(entity.get_qpos(q_idx).cpu(), dtype=float),
                         [np.asarray(b.get_pos().cpu(), dtype=float) for b in boxes])
        if step < experiment.steps:
            scene.step()
    return recorder.trajectory()


def _narrow_limits(entity, dofs: list[int], margin: np.ndarray) -> None:
    """Genesis's limit acts once a joint is past it and reads no MuJoCo joint margin; the
    margin (a limit that acts at contact) amounts in MuJoCo to the range narrowed by it:
    so narrowed here (engine_settings.LIMIT_MARGIN)."""
    if not dofs or not np.any(margin):
        return
    lower, upper = (np.asarray(v.cpu(), dtype=float) for v in entity.get_dofs_limit(dofs))
    limited = np.isfinite(lower) & np.isfinite(upper) & (upper - lower > 2 * margin)
    entity.set_dofs_limit(np.where(limited, lower + margin, lower),
                          np.where(limited, upper - margin, upper), dofs)


def _add_boxes(gs, scene, experiment: Experiment) -> list:
    size = experiment.box_size
    material = gs.materials.Rigid(rho=experiment.box_mass / size ** 3)
    return [scene.add_entity(gs.morphs.Box(size=(size, size, size), pos=tuple(centre)),
                             material=material) for centre in experiment.boxes]


if __name__ == "__main__":
    serve(simulate_here)
