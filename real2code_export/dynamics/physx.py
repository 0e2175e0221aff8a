"""PhysX through ``ovphysx`` (CPU mode): the USD as written, stepped at the experiment's
time step; its tensor API reads and writes joint positions and velocities in radians (the
USD's attributes are in degrees), joints in its own order (by name here).

The USD carries what PhysX would otherwise default: link damping 0 (``physxRigidBody:``,
else 0.05), joint damping and friction (``newton:``), the observed state
(``state:*:physics:position``). What the experiment sets goes into a layer over the file,
which is left as written: its gravity (on every PhysicsScene), its boxes, and with
``self_contacts`` every joint's ``physics:collisionEnabled``.
Runs in the engines venv when ovphysx is not importable here (venv.py).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import Experiment, Recorder, Trajectory
from .venv import Outcome, run_in_venv, run_many_in_venv, serve


def simulate(path: Path, experiment: Experiment) -> Trajectory:
    return run_in_venv(__name__, "ovphysx", path, experiment)


def simulate_many(cases: list[tuple[Path, Experiment]]) -> list[Outcome]:
    """Every case in one process (venv.py)."""
    return run_many_in_venv(__name__, "ovphysx", cases)


def _attach(physx, ovphysx, path: Path):
    import ovstage
    from ovphysx.samples.python_samples.schema_support import physx_schema_paths

    # PhysX and Newton schemas must be known before the first population.
    ovstage.population.register_usd_schemas(
        [*[str(p) for p in physx_schema_paths()], str(ovphysx.newton_schema_root())])
    stage = ovstage.Stage("real2code-simulate")
    ovstage.population.open_usd(stage, str(path), ordinal=1,
                                domains=ovstage.PopulationDomain.ALL)
    stage.advance_write_floor(ordinal=1).wait()
    physx.wait_task(physx.attach_ovstage(stage, read_ordinal=1))
    return stage


def _layer_over(path: Path, experiment: Experiment) -> tuple[Path, float]:
    """A layer over ``path`` (beside it): the experiment's gravity, its boxes as rigid cubes
    and, with ``self_contacts``, every joint's bodies colliding; and the stage's metres per
    unit."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics

    from ..formats import FORMATS

    source = Usd.Stage.Open(str(path))
    units = UsdGeom.GetStageMetersPerUnit(source)
    over = path.with_name(f"{path.stem}.contacts{FORMATS['usd'].output_suffix}")
    layer = Sdf.Layer.CreateNew(str(over))
    layer.subLayerPaths.append(path.name)
    layer.defaultPrim = source.GetRootLayer().defaultPrim
    stage = Usd.Stage.Open(layer)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.GetStageUpAxis(source))
    UsdGeom.SetStageMetersPerUnit(stage, units)
    gravity = np.asarray(experiment.gravity, dtype=float)
    magnitude = float(np.linalg.norm(gravity))
    for prim in stage.Traverse():
        if prim.IsA(UsdPhysics.Scene):
            scene = UsdPhysics.Scene(prim)
            scene.CreateGravityMagnitudeAttr(magnitude / units)
            if magnitude > 0:
                scene.CreateGravityDirectionAttr(Gf.Vec3f(*(gravity / magnitude)))
        elif experiment.self_contacts and prim.IsA(UsdPhysics.Joint):
            UsdPhysics.Joint(prim).CreateCollisionEnabledAttr(True)
    for i, centre in enumerate(experiment.boxes):
        cube = UsdGeom.Cube.Define(stage, f"/real2code_box_{i}")
        cube.CreateSizeAttr(experiment.box_size / units)
        cube.AddTranslateOp().Set(Gf.Vec3d(*(c / units for c in centre)))
        UsdPhysics.RigidBodyAPI.Apply(cube.GetPrim())
        UsdPhysics.CollisionAPI.Apply(cube.GetPrim())
        UsdPhysics.MassAPI.Apply(cube.GetPrim()).CreateMassAttr(experiment.box_mass)
    layer.Save()
    return over, units


def _root_path(path: Path) -> str:
    from pxr import Usd, UsdPhysics

    stage = Usd.Stage.Open(str(path))
    for prim in stage.Traverse():
        if prim.HasAPI(UsdPhysics.ArticulationRootAPI):
            return str(prim.GetPath())
    raise ValueError(f"{path}: no prim with PhysicsArticulationRootAPI")


def simulate_here(path: Path, experiment: Experiment) -> Trajectory:
    import ovphysx
    from ovphysx import PhysX
    from ovphysx.types import TensorType

    root = _root_path(path)
    path, units = _layer_over(path, experiment)
    PhysX.set_cpu_mode(True)
    physx = PhysX()
    stage = None
    try:
        stage = _attach(physx, ovphysx, path)
        physx.wait_all()
        physx.warmup()  # before the state is written: its first step would overwrite it
        position = physx.create_tensor_binding(
            pattern=root, tensor_type=TensorType.ARTICULATION_DOF_POSITION)
        velocity = physx.create_tensor_binding(
            pattern=root, tensor_type=TensorType.ARTICULATION_DOF_VELOCITY)
        names = list(position.dof_names)
        missing = [n for n in experiment.joints if n not in names]
        if missing:
            raise KeyError(f"{path}: PhysX's articulation has no joint named {missing[0]!r} "
                           f"(it has {names})")
        column = np.array([names.index(n) for n in experiment.joints])
        q = np.zeros(position.shape, dtype=np.float32)
        v = np.zeros(velocity.shape, dtype=np.float32)
        position.read(q)
        velocity.read(v)
        q[0, column] = experiment.q0
        v[0, column] = experiment.v0
        position.write(q)
        velocity.write(v)
        boxes = [physx.create_tensor_binding(pattern=f"/real2code_box_{i}",
                                             tensor_type=TensorType.RIGID_BODY_POSE)
                 for i in range(len(experiment.boxes))]
        pose = np.zeros((1, 7), dtype=np.float32)
        recorder = Recorder(experiment)
        for step in range(experiment.steps + 1):
            if recorder.due(step):
                position.read(q)
                centres = []
                for box in boxes:
                    box.read(pose)
                    centres.append(pose[0, :3].astype(np.float64) * units)
                recorder.add(step, q[0, column].astype(np.float64), centres)
            if step < experiment.steps:
                physx.step_sync(experiment.dt)
        return recorder.trajectory()
    finally:
        physx.wait_all()
        if stage is not None and physx.is_stage_attached(stage):
            physx.wait_task(physx.detach_ovstage())
        physx.destroy()


if __name__ == "__main__":
    serve(simulate_here)
