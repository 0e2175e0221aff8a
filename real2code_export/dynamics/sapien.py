"""SAPIEN 3 (its PhysX, on the CPU): the URDF, root link fixed. Runs in the engines venv
(venv.py) when ``sapien`` does not import here.

What a user must set (docs/engines.md): no renderer, so the URDF is read without its
``<visual>``s (a copy beside it: SAPIEN's loader makes a render material for every visual,
which fails without a rendering device); link
damping 0 (PhysX's default is 0.05); PhysX's PGS solver (SAPIEN defaults to TGS); the joint
laws from the file, as SAPIEN's loader leaves them at its own defaults: armature from our
``real2code:`` attribute; damping and springs as a joint force each step; dry friction as
a velocity drive to rest whose force limit is the URDF's friction (PhysX's joint
"friction" is a coefficient on the joint's constraint force, not a friction torque).
Limits are PhysX's hard stops.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from . import Experiment, Recorder, Trajectory, urdf_laws
from .venv import Outcome, run_in_venv, run_many_in_venv, serve

FRICTION_DRIVE_DAMPING = 1e4  # N m s/rad: the friction drive holds a joint still below it


def simulate(path: Path, experiment: Experiment) -> Trajectory:
    return run_in_venv(__name__, "sapien", path, experiment)


def simulate_many(cases: list[tuple[Path, Experiment]]) -> list[Outcome]:
    """Every case in one process (venv.py)."""
    return run_many_in_venv(__name__, "sapien", cases)


def _without_visuals(path: Path) -> Path:
    from lxml import etree

    from ..formats import FORMATS

    tree = etree.parse(str(path))
    for visual in tree.getroot().findall("link/visual"):
        visual.getparent().remove(visual)
    out = path.with_name(f"{path.stem}.sapien{FORMATS['urdf'].output_suffix}")
    tree.write(str(out))
    return out


def simulate_here(path: Path, experiment: Experiment) -> Trajectory:
    with warnings.catch_warnings():  # no system Vulkan: it says so, and renders nothing here
        warnings.simplefilter("ignore")
        import sapien

    sapien.physx.set_scene_config(gravity=list(experiment.gravity), enable_tgs=False)
    scene = sapien.Scene([sapien.physx.PhysxCpuSystem()])
    scene.set_timestep(experiment.dt)
    loader = scene.create_urdf_loader()
    loader.fix_root_link = True
    articulation = loader.load_file_as_articulation_builder(str(_without_visuals(path))).build()
    for link in articulation.links:
        link.linear_damping = 0.0
        link.angular_damping = 0.0
        if not experiment.contacts:
            for shape in link.collision_shapes:
                shape.set_collision_groups([0, 0, 0, 0])
    joints = {j.name: j for j in articulation.active_joints}
    missing = [n for n in experiment.joints if n not in joints]
    if missing:
        raise KeyError(f"{path}: SAPIEN's articulation has no joint named {missing[0]!r}")
    laws = urdf_laws(path)
    active = list(articulation.active_joints)
    law = [laws.get(j.name, {}) for j in active]
    damping = np.array([x.get("damping", 0.0) for x in law])
    stiffness = np.array([x.get("stiffness", 0.0) for x in law])
    spring_ref = np.array([x.get("springref", 0.0) for x in law])
    for joint, x in zip(active, law, strict=True):
        joint.set_friction(0.0)  # a coefficient on the constraint force, not ours
        joint.set_armature([x.get("armature", 0.0)])
        # dry friction as a velocity drive to rest that gives up beyond the friction
        friction = x.get("friction", 0.0)
        joint.set_drive_properties(0.0, FRICTION_DRIVE_DAMPING if friction else 0.0,
                                   force_limit=friction, mode="force")
        joint.set_drive_velocity_target(0.0)
    order = [articulation.active_joints.index(joints[n]) for n in experiment.joints]
    qpos = articulation.get_qpos()
    qvel = articulation.get_qvel()
    qpos[order] = experiment.q0
    qvel[order] = experiment.v0
    articulation.set_qpos(qpos)
    articulation.set_qvel(qvel)
    recorder = Recorder(experiment)
    for step in range(experiment.steps + 1):
        if recorder.due(step):
            recorder.add(step, np.asarray(articulation.get_qpos(), dtype=float)[order])
        if step < experiment.steps:
            q, v = articulation.get_qpos(), articulation.get_qvel()
            articulation.set_qf(-damping * v - stiffness * (q - spring_ref))
            scene.step()
    return recorder.trajectory()


if __name__ == "__main__":
    serve(simulate_here)
