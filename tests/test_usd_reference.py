"""A USD source as the reference of ``check --reference`` and ``export --check``: loaded in
Newton's own importer (probes/newton.py, in the engines venv), so an export that moves a
joint is caught against the source, not only against our own reading of it."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from real2code_export.check import check_files
from real2code_export.cli import EXIT_OK, run
from real2code_export.dynamics.venv import ENGINES_VENV
from real2code_export.errors import CheckError, Real2CodeWarning


def _needs_newton() -> None:
    if ENGINES_VENV.python() is None:
        pytest.skip(f"no engines venv at {ENGINES_VENV.default_python.parents[1]} "
                    f"(run {ENGINES_VENV.setup}): Newton cannot read the source")


def _robot(path: Path, hinge_height: float = 10.0, free_axis: bool = False) -> Path:
    """A stage in centimetres: a base welded to the world, an arm on a limited hinge about
    Z, a slide along X and a wrist on a generic joint (D6) of two rotations, one limited, the
    other axes locked (``free_axis``: rotZ left without a limit, free as the schema says)."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 0.01)
    root = UsdGeom.Xform.Define(stage, "/robot").GetPrim()
    stage.SetDefaultPrim(root)
    UsdPhysics.ArticulationRootAPI.Apply(root)
    places = {"base": (0, 0, 0), "arm": (0, 0, hinge_height), "slider": (20, 0, hinge_height),
              "wrist": (20, 0, hinge_height - 5), "finger": (25, 0, hinge_height - 5),
              "thumb": (20, 5, hinge_height - 5)}
    for name, place in places.items():
        body = UsdGeom.Xform.Define(stage, f"/robot/{name}")
        body.AddTranslateOp().Set(Gf.Vec3d(*place))
        UsdPhysics.RigidBodyAPI.Apply(body.GetPrim())
        mass = UsdPhysics.MassAPI.Apply(body.GetPrim())
        mass.CreateMassAttr(0.5)
        mass.CreateDiagonalInertiaAttr(Gf.Vec3f(20.0, 30.0, 40.0))
        mass.CreateCenterOfMassAttr(Gf.Vec3f(1.0, 0.0, 0.0))
        mass.CreatePrincipalAxesAttr(Gf.Quatf(1.0))
        cube = UsdGeom.Cube.Define(stage, f"/robot/{name}/box")
        cube.CreateSizeAttr(4.0)
        UsdPhysics.CollisionAPI.Apply(cube.GetPrim())

    def joint(schema, name, body0, body1, at):
        j = schema.Define(stage, f"/robot/{name}")
        if body0:
            j.CreateBody0Rel().SetTargets([Sdf.Path(f"/robot/{body0}")])
        j.CreateBody1Rel().SetTargets([Sdf.Path(f"/robot/{body1}")])
        j.CreateLocalPos0Attr(Gf.Vec3f(*at))
        j.CreateLocalPos1Attr(Gf.Vec3f(0.0))
        j.CreateLocalRot0Attr(Gf.Quatf(1.0))
        j.CreateLocalRot1Attr(Gf.Quatf(1.0))
        return j

    joint(UsdPhysics.FixedJoint, "weld", None, "base", (0, 0, 0))
    hinge = joint(UsdPhysics.RevoluteJoint, "hinge", "base", "arm", (0, 0, hinge_height))
    hinge.CreateAxisAttr("Z")
    hinge.CreateLowerLimitAttr(-90.0)
    hinge.CreateUpperLimitAttr(90.0)
    slide = joint(UsdPhysics.PrismaticJoint, "slide", "arm", "slider", (20, 0, 0))
    slide.CreateAxisAttr("X")
    slide.CreateLowerLimitAttr(0.0)
    slide.CreateUpperLimitAttr(15.0)
    # urdf-usd-converter's forms: a hinge whose limits are both 0 (held there: a fixed
    # joint), one at URDF's "no limit" (+-1e16 rad, in degrees), which Newton clamps
    for name, at, bound in (("finger", (5, 0, 0), (0.0, 0.0)), ("thumb", (0, 5, 0), (-5.729578e17,
                                                                                     5.729578e17))):
        held = joint(UsdPhysics.RevoluteJoint, f"{name}_joint", "wrist", name, at)
        held.CreateAxisAttr("Y")
        held.CreateLowerLimitAttr(bound[0])
        held.CreateUpperLimitAttr(bound[1])
    wrist = joint(UsdPhysics.Joint, "wrist_joint", "slider", "wrist", (0, 0, -5)).GetPrim()
    # (rotY: a limit of +-inf, unlimited, which Newton keeps as +-1e10 degrees)
    ranges = {"rotX": (-30.0, 30.0), "rotY": (-math.inf, math.inf), "transX": (1.0, -1.0),
              "transY": (1.0, -1.0), "transZ": (1.0, -1.0), "rotZ": (1.0, -1.0)}
    if free_axis:
        del ranges["rotZ"]
    for axis, (low, high) in ranges.items():
        limit = UsdPhysics.LimitAPI.Apply(wrist, axis)
        limit.CreateLowAttr(low)
        limit.CreateHighAttr(high)
    stage.Save()
    return path


def test_usd_source_is_compared_in_newton_and_a_moved_joint_is_caught(tmp_path, capsys):
    """The exports of a USD source agree with Newton's reading of it (units, a D6 split
    into ``<joint>_<axis>`` joints, a slide in centimetres); a file whose hinge stands 2 cm
    higher is caught against the source."""
    _needs_newton()
    source = _robot(tmp_path / "robot.usda")
    assert run(["export", str(source), "--to", "mjcf,urdf,usd,gltf", "--check",
                "--out", str(tmp_path / "out")]) == EXIT_OK
    table = capsys.readouterr().out
    assert "reference: source Newton (USD) robot.usda" in table
    moved = _robot(tmp_path / "moved.usda", hinge_height=12.0)
    report = check_files([moved], source=source, n_configurations=5, validate=False)
    assert report.reference.startswith("source Newton (USD)")
    assert {j.name for j in report.joints} >= {"hinge", "slide", "wrist_joint_rotX",
                                               "wrist_joint_rotY"}
    assert {(m.kind, m.name) for m in report.mismatches} >= {("pose", "arm")}
    assert report.max_position_error == pytest.approx(0.02, rel=1e-5)


def test_without_newton_the_usd_reference_is_refused_and_export_check_warns(
        tmp_path, monkeypatch):
    """No engines venv: ``check --reference`` says what is missing and how to get it;
    ``export --check`` (``source_required=False``) warns and compares the files alone."""
    monkeypatch.setenv(ENGINES_VENV.override, str(tmp_path / "no-python"))
    source = _robot(tmp_path / "robot.usda")
    with pytest.raises(CheckError, match=r"Newton.*not installed.*setup_engines\.sh"):
        check_files([source], source=source, validate=False)
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        report = check_files([source], source=source, validate=False, source_required=False,
                             n_configurations=3)
    assert report.ok and not report.reference.startswith("source")
    assert any(issubclass(w.category, Real2CodeWarning) and "compared with each other only"
               in str(w.message) for w in said)


def test_newton_is_no_reference_for_a_d6_axis_it_locks(tmp_path):
    """A generic joint's axis without a PhysicsLimitAPI is free (the schema); Newton's
    importer locks it: the probe refuses such a file rather than compare a different
    model (the check then goes on without it, warned)."""
    from pxr import Usd

    from real2code_export.probes.newton import _refuse_locked_axes

    _refuse_locked_axes(Usd.Stage.Open(str(_robot(tmp_path / "robot.usda"))))
    loose = Usd.Stage.Open(str(_robot(tmp_path / "loose.usda", free_axis=True)))
    with pytest.raises(ValueError, match=r"<\/robot\/wrist_joint> leaves rotZ free"):
        _refuse_locked_axes(loose)


def _installed_asset(relative: str) -> Path:
    python = ENGINES_VENV.python()
    found = sorted(Path(python).parents[1].glob(f"lib/python3*/site-packages/newton/{relative}")
                   ) if python is not None else []
    if not found:
        pytest.skip(f"Newton's {relative} is not installed (run {ENGINES_VENV.setup})")
    return found[0]


def test_newton_example_of_generic_joints_agrees_with_its_source(tmp_path, capsys):
    """Newton's own ``humanoid.usda`` (bodies on generic joints of several limited
    rotations, masses from capsule colliders): every export agrees with Newton's reading,
    joint for joint, and weighs and damps as Newton's model does."""
    asset = _installed_asset("examples/assets/humanoid.usda")
    assert run(["export", str(asset), "--to", "mjcf,urdf,usd,gltf", "--check",
                "--out", str(tmp_path / "out")]) == EXIT_OK
    table = capsys.readouterr().out
    assert "reference: source Newton (USD) humanoid.usda" in table
    compared = [line.split()[-1] for line in table.splitlines() if " Newton / " in line]
    assert compared == ["equal"] * 4, table


def test_newton_is_no_reference_for_stacked_joints_it_reorders(tmp_path):
    """Hinges stacked between two bodies turn in the stage's order (MuJoCo's, our
    reader's); Newton merges them in its parser's order: where that differs, refused."""
    from pxr import Usd, UsdPhysics

    from real2code_export.probes.newton import _refuse_reordered_stacks, stage_order

    stage = Usd.Stage.CreateInMemory()
    for name in ("hip_x", "hip_z", "hip_y"):
        UsdPhysics.RevoluteJoint.Define(stage, f"/body/{name}")
    order = stage_order(stage)
    _refuse_reordered_stacks(order, [["/body/hip_x", "/body/hip_z", "/body/hip_y"]])
    with pytest.raises(ValueError, match="Newton merges them as hip_x, hip_y, hip_z"):
        _refuse_reordered_stacks(order, [["/body/hip_x", "/body/hip_y", "/body/hip_z"]])


def test_newton_is_no_reference_for_two_rotations_at_a_skew(tmp_path):
    """Two hinges of one body about axes not at 90 degrees (the softfoot's, through
    mujoco-usd-converter): Newton's D6 law orthonormalises them, so refused."""
    from types import SimpleNamespace

    from real2code_export.probes.newton import _refuse_skew_axes

    def model(axis_1):
        arrays = {"joint_type": [6], "joint_dof_dim": [[0, 2]], "joint_qd_start": [0],
                  "joint_axis": [[1.0, 0.0, 0.0], axis_1]}
        return SimpleNamespace(**{k: SimpleNamespace(numpy=lambda v=v: np.array(v))
                                  for k, v in arrays.items()})

    _refuse_skew_axes(model([0.0, 1.0, 0.0]), 6, ["knee"])
    with pytest.raises(ValueError, match="joint 'knee': two rotations about axes 45 degrees"):
        _refuse_skew_axes(model([0.7071068, 0.7071068, 0.0]), 6, ["knee"])
