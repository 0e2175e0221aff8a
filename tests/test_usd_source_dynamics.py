"""A USD source's dynamics in its own tool: ``check --reference FILE.usda`` and ``export
--check`` compare the exports' masses, inertias, centres of mass and joint damping, friction,
armature and ranges with Newton's model of the source (``probes.newton``'s answer,
``probes.dynamics.against_newton``), as they compare an MJCF or URDF source's in MuJoCo and
Pinocchio."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from real2code_export.check import check_files
from real2code_export.cli import EXIT_OK, run
from real2code_export.dynamics.venv import ENGINES_VENV

# a rotation of 45 degrees about Z as a float32 matrix holds it (Newton's ant writes its
# leg capsules so): its columns' norms are 1 +- 1e-8
TURNED = ((0.7071067450934194, 0.7071068030891894, 0, 0),
          (-0.7071068030891894, 0.7071067450934194, 0, 0), (0, 0, 1, 0), (0.1, 0.1, 0, 1))


def _arm(path: Path) -> Path:
    """A stage in centimetres, kilograms per unit 2: a base welded to the world (mass
    stated), an arm on a hinge with NewtonJointAPI's damping (per degree), friction and
    armature, whose mass the file leaves to its capsule collider, turned by ``TURNED``, at
    an authored density."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 0.01)
    UsdPhysics.SetStageKilogramsPerUnit(stage, 2.0)
    root = UsdGeom.Xform.Define(stage, "/arm").GetPrim()
    stage.SetDefaultPrim(root)
    UsdPhysics.ArticulationRootAPI.Apply(root)
    base = UsdGeom.Xform.Define(stage, "/arm/base").GetPrim()
    UsdPhysics.RigidBodyAPI.Apply(base)
    mass = UsdPhysics.MassAPI.Apply(base)
    mass.CreateMassAttr(1.5)
    mass.CreateDiagonalInertiaAttr(Gf.Vec3f(20.0, 30.0, 40.0))
    mass.CreateCenterOfMassAttr(Gf.Vec3f(1.0, 0.0, 2.0))
    cube = UsdGeom.Cube.Define(stage, "/arm/base/box")
    cube.CreateSizeAttr(4.0)
    UsdPhysics.CollisionAPI.Apply(cube.GetPrim())
    leg = UsdGeom.Xform.Define(stage, "/arm/leg")
    leg.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 10.0))
    UsdPhysics.RigidBodyAPI.Apply(leg.GetPrim())
    mass = UsdPhysics.MassAPI.Apply(leg.GetPrim())
    mass.CreateDensityAttr(2e-3)  # (kilograms per unit, per cubic centimetre)
    capsule = UsdGeom.Capsule.Define(stage, "/arm/leg/capsule")
    capsule.CreateAxisAttr("X")
    capsule.CreateRadiusAttr(2.0)
    capsule.CreateHeightAttr(8.0)
    capsule.AddTransformOp().Set(Gf.Matrix4d(TURNED))
    UsdPhysics.CollisionAPI.Apply(capsule.GetPrim())
    weld = UsdPhysics.FixedJoint.Define(stage, "/arm/weld")
    weld.CreateBody1Rel().SetTargets([Sdf.Path("/arm/base")])
    hinge = UsdPhysics.RevoluteJoint.Define(stage, "/arm/hinge")
    hinge.CreateBody0Rel().SetTargets([Sdf.Path("/arm/base")])
    hinge.CreateBody1Rel().SetTargets([Sdf.Path("/arm/leg")])
    hinge.CreateLocalPos0Attr(Gf.Vec3f(0.0, 0.0, 10.0))
    hinge.CreateLocalPos1Attr(Gf.Vec3f(0.0))
    hinge.CreateAxisAttr("Y")
    hinge.CreateLowerLimitAttr(-45.0)
    hinge.CreateUpperLimitAttr(60.0)
    # a tip on a ball joint (a URDF fixes it at its rest: the tip weighs with the leg) and a
    # second ball from the base closing a loop (excluded from the articulation: no URDF
    # joint, it joins nothing)
    tip = UsdGeom.Xform.Define(stage, "/arm/tip")
    tip.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 20.0))
    UsdPhysics.RigidBodyAPI.Apply(tip.GetPrim())
    mass = UsdPhysics.MassAPI.Apply(tip.GetPrim())
    mass.CreateMassAttr(0.25)
    mass.CreateDiagonalInertiaAttr(Gf.Vec3f(2.0, 2.0, 2.0))
    mass.CreateCenterOfMassAttr(Gf.Vec3f(0.0))
    for name, body0, at, loop in (("wrist", "leg", (0.0, 0.0, 10.0), False),
                                  ("strut", "base", (0.0, 0.0, 20.0), True)):
        ball = UsdPhysics.SphericalJoint.Define(stage, f"/arm/{name}")
        ball.CreateBody0Rel().SetTargets([Sdf.Path(f"/arm/{body0}")])
        ball.CreateBody1Rel().SetTargets([Sdf.Path("/arm/tip")])
        ball.CreateLocalPos0Attr(Gf.Vec3f(*at))
        ball.CreateLocalPos1Attr(Gf.Vec3f(0.0))
        ball.CreateExcludeFromArticulationAttr(loop)
    prim = hinge.GetPrim()
    prim.AddAppliedSchema("NewtonJointAPI")
    for name, value in (("damping", 0.2), ("friction", 0.3), ("armature", 0.05)):
        prim.CreateAttribute(f"newton:{name}", Sdf.ValueTypeNames.Float).Set(value)
    stage.Save()
    return path


def test_a_capsule_turned_by_a_float32_rotation_is_still_a_capsule():
    """A rotation authored in float32 scales by 1 +- 1e-7: the capsule is kept (its exact
    solid weighs it, as Newton and PhysX weigh it), not read as its bare tessellation, 2.6 %
    light."""
    from pxr import Usd, UsdGeom

    from real2code_export.formats.usd.geometry import shape_mesh
    from real2code_export.primitives import ShapeKind

    stage = Usd.Stage.CreateInMemory()
    capsule = UsdGeom.Capsule.Define(stage, "/capsule")
    capsule.CreateAxisAttr("X")
    capsule = capsule.GetPrim()
    turned = np.array(TURNED, float).T
    # (its x and y columns 1e-8 shorter than its z: a capsule along X, squashed by 1e-8)
    assert abs(np.linalg.norm(turned[:3, 0]) - np.linalg.norm(turned[:3, 2])) > 1e-9
    mesh = shape_mesh(capsule, turned)
    assert mesh.primitive is not None and mesh.primitive.kind is ShapeKind.CAPSULE


def test_a_shape_and_its_bare_tessellation_are_not_one_cache_entry(tmp_path, monkeypatch):
    """The mass cache keys a mesh by the shapes it keeps too: a capsule weighs its exact
    solid even where its bare tessellation (the same triangles, 2.6 % lighter) was weighed
    first (Newton's ant_multi, read after a capsule was taken for a squash)."""
    from real2code_export.inertia import inertial_from_meshes
    from real2code_export.model import Mesh
    from real2code_export.primitives import Primitive, ShapeKind

    monkeypatch.setenv("REAL2CODE_CACHE", str(tmp_path / "cache"))
    capsule = Primitive(ShapeKind.CAPSULE, [0.08, 0.28])
    bare = inertial_from_meshes([Mesh(*capsule.tessellation())], 1.0)
    exact = inertial_from_meshes([Mesh.of_primitive(capsule)], 1.0)
    solid = math.pi * 0.08 ** 2 * 0.28 + 4.0 / 3.0 * math.pi * 0.08 ** 3
    assert exact.mass == pytest.approx(solid, rel=1e-12)
    assert bare.mass < 0.99 * solid


def test_usd_source_dynamics_are_compared_with_newtons_model(tmp_path, capsys):
    """Every export of a USD source (centimetres, kilogramsPerUnit 2, a mass computed from a
    capsule collider at an authored density, a hinge's damping per degree) weighs and damps
    its bodies and joints as Newton's model of the source does; an export whose mass or
    damping differs is caught against the source, named."""
    if ENGINES_VENV.python() is None:
        pytest.skip(f"no engines venv at {ENGINES_VENV.default_python.parents[1]} "
                    f"(run {ENGINES_VENV.setup}): Newton cannot read the source")
    source = _arm(tmp_path / "arm.usda")
    out = tmp_path / "out"
    assert run(["export", str(source), "--to", "mjcf,urdf,usd,gltf", "--check", "--out",
                str(out)]) == EXIT_OK
    table = capsys.readouterr().out
    for tool in ("Newton / MuJoCo ", "Newton / MuJoCo (URDF import)", "Newton / UsdPhysics",
                 "Newton / KHR_physics_rigid_bodies"):
        assert any(tool in line and line.rstrip().endswith("equal")
                   for line in table.splitlines()), (tool, table)
    # the export's leg 1 % heavier, its hinge damped 10 % more: caught, named
    from pxr import Usd, UsdPhysics

    export = out / "arm.usda"
    stage = Usd.Stage.Open(str(export))
    prims = {p.GetName(): p for p in stage.Traverse()
             if p.HasAPI(UsdPhysics.MassAPI) or p.IsA(UsdPhysics.Joint)}
    mass = UsdPhysics.MassAPI(prims["leg"]).GetMassAttr()
    mass.Set(mass.Get() * 1.01)
    for name in ("newton:damping", "mjc:damping"):
        damping = prims["hinge"].GetAttribute(name)
        damping.Set(damping.Get() * 1.1)
    stage.Save()
    report = check_files([export], source=source, n_configurations=3, validate=False)
    found = {(m.name, m.message.split(": ")[2].split(" ")[0]) for m in report.mismatches
             if m.kind == "dynamics"}
    assert {("leg", "mass"), ("hinge", "damping")} <= found <= {
        ("leg", "mass"), ("leg", "principal"), ("hinge", "damping")}, report.mismatches


def test_a_colliders_physics_material_density_weighs_it(tmp_path):
    """A body that states no mass weighs its colliders each at its physics material's
    density (PhysicsMaterialAPI bound for "physics"), as UsdPhysics and Newton weigh it, not
    at the default 1000 kg/m^3 (Newton's cube_cylinder: 1.2 kg, read as 1.5)."""
    from pxr import Usd, UsdGeom, UsdPhysics, UsdShade

    from real2code_export.formats import load

    path = tmp_path / "bottle.usda"
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    body = UsdGeom.Xform.Define(stage, "/bottle").GetPrim()
    stage.SetDefaultPrim(body)
    UsdPhysics.RigidBodyAPI.Apply(body)
    material = UsdShade.Material.Define(stage, "/bottle/plastic")
    UsdPhysics.MaterialAPI.Apply(material.GetPrim()).CreateDensityAttr(800.0)
    cube = UsdGeom.Cube.Define(stage, "/bottle/box")
    cube.CreateSizeAttr(0.1)
    UsdPhysics.CollisionAPI.Apply(cube.GetPrim())
    UsdShade.MaterialBindingAPI.Apply(cube.GetPrim()).Bind(
        material, UsdShade.Tokens.weakerThanDescendants, "physics")
    stage.Save()
    with pytest.warns(Warning, match="physics material"):
        obj = load(path, hull_collision=False)
    (part,) = [p for p in obj.parts if p.inertial is not None and p.inertial.mass > 0]
    assert part.inertial.mass == pytest.approx(800.0 * 0.1 ** 3, rel=1e-9)


def test_what_newton_does_not_read_is_left_out_and_said():
    """A joint's damping stated in MjcJointAPI only (MuJoCo's USD, cartpole_mjc) is read by
    our reader and not by Newton's default importer: not compared, said; one stated in
    NewtonJointAPI is compared."""
    from pxr import Sdf, Usd

    from real2code_export.probes.newton import _unread
    from real2code_export.probes.schema_dynamics import newton_dynamics

    stage = Usd.Stage.CreateInMemory()
    hinge = stage.DefinePrim("/hinge", "PhysicsRevoluteJoint")
    hinge.CreateAttribute("mjc:damping", Sdf.ValueTypeNames.Float).Set(0.05)
    hinge.CreateAttribute("mjc:armature", Sdf.ValueTypeNames.Float).Set(0.1)
    hinge.CreateAttribute("newton:armature", Sdf.ValueTypeNames.Float).Set(0.1)
    unread = _unread(hinge)
    assert unread == ["damping (mjc:damping)"]
    view = newton_dynamics("cartpole.usda", {
        "bodies": {}, "group": {}, "group_as_urdf": {}, "joints": {"hinge": {
            "damping": 0.0, "frictionloss": 0.0, "armature": 0.1, "limited": False,
            "unread": unread}}})
    assert [q for _, q, _ in view.joints["hinge"]] == ["frictionloss", "armature", "limited"]
    assert view.left_out == ["joint 'hinge': its damping (mjc:damping), which Newton's "
                             "default importer does not read"]



def test_newtons_stand_in_inertia_is_not_compared_its_mass_is():
    """Where Newton's mass computation leaves a body with mass and no tensor it makes one up
    (a sphere of its mass at its default density: urdf-usd-converter's a1, whose cylinder
    OpenUSD's own ComputeMassProperties weighs as our reader does): the group's moments are
    left out, said; its mass and centre of mass are compared."""
    from real2code_export.probes.dynamics import view_differences
    from real2code_export.probes.schema_dynamics import SchemaDynamics, newton_dynamics

    body = {"mass": 0.169, "inertia": (7.951e-5 * np.eye(3)).tolist(), "com": [0.0, 0.0, 0.0]}
    source = newton_dynamics("a1.usda", {
        "bodies": {"shoulder": body}, "group": {"shoulder": "shoulder"},
        "group_as_urdf": {"shoulder": "shoulder"}, "joints": {},
        "default_inertia": ["shoulder"]})
    export = SchemaDynamics("a1.xml", bodies={"shoulder": (
        0.169, np.diag([8.544e-5, 1.4204e-4, 8.544e-5]), np.zeros(3))},
        group={"shoulder": "shoulder"})
    left_out: list[str] = []
    assert view_differences(source, export, 1e-6, left_out) == []
    assert "principal moments" in left_out[0] and "'shoulder'" in left_out[0]
    export.bodies["shoulder"] = (0.17, *export.bodies["shoulder"][1:])
    assert [d.message.split(": ")[1].split(" ")[0]
            for d in view_differences(source, export, 1e-6)] == ["mass"]


def test_a_usd_readers_repair_explains_a_difference_with_newton():
    """Our USD reader names what it repairs by its prim's path (a tensor off the triangle
    inequality, which Newton keeps as written: the Allegro hand through urdf-usd-converter):
    the difference with Newton's model names the prims of its group too, so the warning
    explains it; a warning about another prim does not."""
    from real2code_export.probes.dynamics import explaining, view_differences
    from real2code_export.probes.schema_dynamics import SchemaDynamics, newton_dynamics

    body = {"mass": 0.1, "inertia": np.diag([1e-5, 2e-5, 4e-5]).tolist(), "com": [0, 0, 0]}
    source = newton_dynamics("hand.usda", {
        "bodies": {"link_3": body}, "group": {"link_3": "link_3"},
        "group_as_urdf": {"link_3": "link_3"}, "joints": {},
        "paths": {"link_3": "/hand/palm/tn__link_3_XB"}})
    export = SchemaDynamics("hand.xml", bodies={"link_3": (
        0.1, np.diag([1.5e-5, 2e-5, 4e-5]), np.zeros(3))}, group={"link_3": "link_3"})
    (difference,) = view_differences(source, export, 1e-6)
    said = "hand.usda: prim </hand/palm/tn__link_3_XB>: inertia tensor violates the triangle"
    assert explaining(difference, [said + " inequality; balanced"]) != []
    assert explaining(difference, [said.replace("link_3", "link_4") + " inequality"]) == []


def test_an_authored_centre_of_mass_stands_beside_a_computed_mass(tmp_path):
    """A body stating mass 0 (computed) and a centre of mass (urdf-usd-converter's ur10
    ``ee_link``: (0, 0, 0), its box collider 1 cm off): the centre stands as authored, the
    colliders' inertia taken about it, as OpenUSD's ComputeMassProperties and Newton read
    it (it was the colliders' centre, 1 cm off)."""
    from pxr import Gf, Usd, UsdGeom, UsdPhysics

    from real2code_export.formats import load

    path = tmp_path / "tool.usda"
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    body = UsdGeom.Xform.Define(stage, "/tool").GetPrim()
    stage.SetDefaultPrim(body)
    UsdPhysics.RigidBodyAPI.Apply(body)
    mass = UsdPhysics.MassAPI.Apply(body)
    mass.CreateMassAttr(0.0)
    mass.CreateCenterOfMassAttr(Gf.Vec3f(0.0))
    cube = UsdGeom.Cube.Define(stage, "/tool/box")
    cube.CreateSizeAttr(0.1)
    cube.AddTranslateOp().Set(Gf.Vec3d(-0.1, 0.0, 0.0))
    UsdPhysics.CollisionAPI.Apply(cube.GetPrim())
    stage.Save()
    with pytest.warns(Warning, match="mass not authored"):
        obj = load(path, hull_collision=False)
    (part,) = [p for p in obj.parts if p.inertial is not None and p.inertial.mass > 0]
    m = 1000.0 * 0.1 ** 3
    assert part.inertial.mass == pytest.approx(m, rel=1e-9)
    np.testing.assert_allclose(part.inertial.com, [0.0, 0.0, 0.0], atol=1e-12)
    own = m * 0.1 ** 2 / 6
    np.testing.assert_allclose(np.diag(part.inertial.inertia),
                               [own, own + m * 0.01, own + m * 0.01], rtol=1e-9)
