"""USD (UsdPhysics): files we write are read by UsdPhysics' own parser and validators, the
probe built on that parser poses them like the model, units follow the schemas, and
import -> export is lossless and byte-stable."""

from __future__ import annotations

import math
import re
import warnings

import numpy as np
import pytest

from real2code_export import transforms as tf
from real2code_export.errors import FormatError, Real2CodeWarning
from real2code_export.formats import export, usd
from real2code_export.formats import load as load_any
from real2code_export.model import (
    ArticulatedObject,
    Dynamics,
    Joint,
    Limits,
    Mesh,
    Part,
    differences,
    forward_kinematics,
    sample_configuration,
)
from real2code_export.probes.usd import open_probes

from conftest import partnet_dir
from helpers import box_inertial, box_mesh, small_cabinet

pxr = pytest.importorskip("pxr")
# Newton's schemas (NewtonJointAPI, NewtonMassAPI), as our reader registers them before opening
# a stage: the writer authors the file through Sdf and registers nothing.
import newton_usd_schemas  # noqa: E402, F401
from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics, UsdValidation  # noqa: E402

TOL = 1e-6
VALIDATOR_KEYWORDS = ["UsdPhysicsValidators", "UsdGeomValidators", "UsdShadeValidators",
                      "UsdCoreValidators"]


def axes_zoo() -> ArticulatedObject:
    """Axes that are and are not coordinate axes (+Y, -X, -Z, diagonal), a massless root
    without geometry, a wide revolute range, a joint name equal to a part name."""
    def part(name, size, mass, color=(0.3, 0.6, 0.9, 0.5)):
        return Part(name, visual=box_mesh(size), collision=[box_mesh(size)],
                    inertial=box_inertial(size, mass), color=color)

    diagonal = np.ones(3) / math.sqrt(3.0)
    joints = [
        Joint("yaw", "revolute", "base", "arm", origin=tf.make(None, [0.0, 0.0, 0.1]),
              axis=[0.0, 1.0, 0.0], limits=Limits(-2 * math.pi, 2 * math.pi), state=4.0,
              dynamics=Dynamics(damping=0.3)),
        Joint("arm2", "revolute", "arm", "arm2",
              origin=tf.make(tf.rpy_to_matrix([0.4, 0.2, -1.0]), [0.3, 0.0, 0.0]),
              axis=[-1.0, 0.0, 0.0], limits=Limits(-0.5, 1.0, 3.0, 1.5), state=1.0),
        Joint("slide", "prismatic", "arm2", "slider", origin=tf.make(None, [0.1, 0.2, 0.0]),
              axis=[0.0, 0.0, -1.0], limits=Limits(-0.2, 0.1), state=-0.2,
              dynamics=Dynamics(damping=4.0, friction=1.0, stiffness=10.0, spring_ref=0.05)),
        Joint("spin", "continuous", "slider", "spin",
              origin=tf.make(tf.rpy_to_matrix([0.0, 1.0, 0.0]), [0.0, 0.0, 0.05]),
              axis=diagonal, state=2.5, dynamics=Dynamics(armature=0.02, friction=0.05)),
    ]
    parts = [Part("base"), part("arm", [0.3, 0.05, 0.05], 1.0), part("arm2", [0.2, 0.04, 0.04], 0.5),
             part("slider", [0.05, 0.05, 0.2], 0.2), part("spin", [0.05, 0.05, 0.05], 0.1)]
    return ArticulatedObject("axes_zoo", parts, joints, metadata={"note": "unit test"})


def _generated() -> list[tuple[str, ArticulatedObject]]:
    try:
        from pipeline.procedural import CATEGORIES, generate
    except ImportError:
        return []
    return [(f"generated_{c}", generate(c, None, seed=k)) for k, c in enumerate(CATEGORIES)]


OBJECTS = [("small_cabinet", small_cabinet()), ("axes_zoo", axes_zoo()), *_generated()]


@pytest.fixture(scope="module", params=OBJECTS, ids=[name for name, _ in OBJECTS])
def written(request, tmp_path_factory):
    _, obj = request.param
    return obj, usd.save(obj, tmp_path_factory.mktemp("usd"), write_meshes=False)


def _parsed(path):
    stage = Usd.Stage.Open(str(path))
    out = {}
    for kind, (paths, descs) in UsdPhysics.UsdPhysicsLoadStageFromPrimRange(stage, ["/"]).items():
        out.setdefault(kind.name, {}).update({str(p): d for p, d in zip(paths, descs, strict=True)})
    return stage, out


def _pose(position, quat) -> np.ndarray:
    return tf.make(tf.quat_to_matrix([quat.GetReal(), *quat.GetImaginary()]), list(position))


# -- UsdPhysics' parser and validators ------------------------------------------------------
def test_parser_finds_every_body_and_joint(written):
    obj, path = written
    stage, parsed = _parsed(path)
    bodies = {stage.GetPrimAtPath(p).GetName(): p for p in parsed["RigidBody"]}
    assert set(bodies) == {p.name for p in obj.parts}
    kinds = {"revolute": "RevoluteJoint", "continuous": "RevoluteJoint",
             "prismatic": "PrismaticJoint", "fixed": "FixedJoint"}
    joints = {p.rsplit("/", 1)[-1]: (kind, d) for kind, descs in parsed.items()
              if kind.endswith("Joint") for p, d in descs.items()}
    world = [(n, d) for n, (k, d) in joints.items() if not str(d.body0)]
    assert len(world) == 1 and world[0][1].type.name == "FixedJoint"
    assert str(world[0][1].body1) == bodies[obj.root.name]
    (articulation,) = parsed["Articulation"].values()
    assert [str(p) for p in articulation.rootPrims] == [str(world[0][1].primPath)]
    for j in obj.joints:
        kind, d = joints[j.name]
        assert kind == kinds[j.type.value], j.name
        assert (str(d.body0), str(d.body1)) == (bodies[j.parent], bodies[j.child])
        t0 = _pose(d.localPose0Position, d.localPose0Orientation)
        t1 = _pose(d.localPose1Position, d.localPose1Orientation)
        np.testing.assert_allclose(t0 @ tf.inverse(t1), j.origin, atol=TOL)
        if not j.type.movable:
            continue
        axis = t1[:3, :3] @ {"X": [1, 0, 0], "Y": [0, 1, 0], "Z": [0, 0, 1]}[str(d.axis)]
        np.testing.assert_allclose(axis, j.axis, atol=TOL)
        if j.type.value == "continuous":
            assert not (d.limit.enabled and math.isfinite(d.limit.lower))
        elif j.type.value == "revolute":  # degrees
            assert d.limit.enabled
            assert d.limit.lower == pytest.approx(math.degrees(j.limits.lower), abs=1e-4)
            assert d.limit.upper == pytest.approx(math.degrees(j.limits.upper), abs=1e-4)
            assert d.limit.lower <= math.degrees(j.limits.lower)  # rounded outward
            assert d.limit.upper >= math.degrees(j.limits.upper)
        else:
            assert (d.limit.lower, d.limit.upper) == pytest.approx(
                (j.limits.lower, j.limits.upper), abs=1e-7)


def _validation_errors(stage) -> list[str]:
    context = UsdValidation.ValidationContext(keywords=VALIDATOR_KEYWORDS)
    return [f"{e.GetName()}: {e.GetMessage()}" for e in context.Validate(stage)
            if e.GetType() == UsdValidation.ValidationErrorType.Error]


def test_validators_report_no_errors(written):
    _, path = written
    assert _validation_errors(Usd.Stage.Open(str(path))) == []


def test_validators_do_catch_a_broken_file(tmp_path):
    """The control: the same validators flag mass data we break on purpose."""
    path = usd.save(small_cabinet(), tmp_path, write_meshes=False)
    stage = Usd.Stage.Open(str(path))
    stage.GetPrimAtPath("/small_cabinet/Geometry/door").GetAttribute(
        "physics:principalAxes").Clear()
    assert any("InertiaInvalidValues" in e for e in _validation_errors(stage))


def test_stage_metadata(written):
    obj, path = written
    from pxr import UsdGeom

    stage = Usd.Stage.Open(str(path))
    assert UsdGeom.GetStageUpAxis(stage) == "Z"
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    assert UsdPhysics.GetStageKilogramsPerUnit(stage) == 1.0
    assert stage.GetDefaultPrim().GetName() == obj.name
    assert stage.GetDefaultPrim().HasAPI(UsdPhysics.ArticulationRootAPI)


# -- the probe --------------------------------------------------------------------------------
def test_probe_matches_forward_kinematics(written):
    obj, path = written
    (probe,) = open_probes(path)
    assert probe.label == "USD (UsdPhysics)"
    assert sorted(probe.parts) == sorted(p.name for p in obj.parts)
    assert {(i.name, i.kind) for i in probe.joints} == {(j.name, j.type.value)
                                                       for j in obj.movable_joints}
    rng = np.random.default_rng(7)
    configurations = [obj.observed_configuration()] + [sample_configuration(obj, rng)
                                                       for _ in range(100)]
    for q in configurations:
        expected, got = forward_kinematics(obj, q), probe.poses(q)
        for name, pose in expected.items():
            np.testing.assert_allclose(got[name][:3, 3], pose[:3, 3], atol=TOL, err_msg=name)
            assert tf.rotation_distance(got[name][:3, :3], pose[:3, :3]) <= TOL, name


# -- units ----------------------------------------------------------------------------------
def _joint_prim(path, name):
    stage = Usd.Stage.Open(str(path))
    (prim,) = [p for p in stage.Traverse() if p.GetName() == name and p.IsA(UsdPhysics.Joint)]
    return stage, prim


def test_damping_is_per_degree_in_newton_and_per_radian_on_import(tmp_path):
    obj = small_cabinet()
    hinge = obj.joint("door_hinge")
    assert hinge.dynamics.damping == 0.5
    path = usd.save(obj, tmp_path, write_meshes=False)
    _, prim = _joint_prim(path, "door_hinge")
    assert prim.HasAPI("NewtonJointAPI")
    assert prim.GetAttribute("newton:damping").Get() == pytest.approx(0.5 * math.pi / 180, rel=1e-7)
    # no angle in friction (N m) or armature (kg m^2): unconverted
    assert prim.GetAttribute("newton:friction").Get() == pytest.approx(0.1, rel=1e-7)
    assert prim.GetAttribute("newton:armature").Get() == pytest.approx(0.01, rel=1e-7)
    assert prim.GetAttribute("newton:velocityLimit").Get() == pytest.approx(math.degrees(2.0))
    assert prim.GetAttribute("mjc:damping").Get() == 0.5  # MuJoCo: per radian
    assert prim.GetAttribute("mjc:springref").Get() == pytest.approx(math.degrees(0.1))
    assert prim.GetAttribute("mjc:ref").Get() == pytest.approx(math.degrees(hinge.state))
    assert prim.GetAttribute("state:angular:physics:position").Get() == pytest.approx(
        math.degrees(hinge.state), rel=1e-7)  # PhysX JointStateAPI: the initial q, degrees
    assert usd.load(path).joint("door_hinge").dynamics.damping == 0.5

    # A file with only NewtonJointAPI (as Newton's tools write): 0.5 back from per degree.
    stage, prim = _joint_prim(path, "door_hinge")
    for name in [a.GetName() for a in prim.GetAttributes() if a.GetName().startswith("mjc:")]:
        prim.RemoveProperty(name)
    stage.GetRootLayer().Save()
    d = usd.load(path).joint("door_hinge").dynamics
    assert d.damping == pytest.approx(0.5, rel=1e-6)
    assert (d.friction, d.armature) == pytest.approx((0.1, 0.01), rel=1e-6)
    assert (d.stiffness, d.spring_ref) == (0.0, 0.0)


def test_only_mjc_attributes_are_read_too(tmp_path):
    path = usd.save(small_cabinet(), tmp_path, write_meshes=False)
    stage, prim = _joint_prim(path, "door_hinge")
    for name in [a.GetName() for a in prim.GetAttributes() if a.GetName().startswith("newton:")]:
        prim.RemoveProperty(name)
    stage.GetRootLayer().Save()
    assert differences(small_cabinet(), usd.load(path), TOL) == []


def test_stage_units_are_applied_on_import(tmp_path):
    obj = small_cabinet()
    path = usd.save(obj, tmp_path, write_meshes=False)
    layer = Sdf.Layer.FindOrOpen(str(path))
    layer.pseudoRoot.SetInfo("metersPerUnit", 0.01)  # the same numbers in centimetres
    layer.Save()
    with pytest.warns(Real2CodeWarning, match="real2code:state = 0.12 but the bodies stand at"):
        cm = usd.load(path)  # our attribute is SI; the bodies now say centimetres
    slide, hinge = cm.joint("drawer_slide"), cm.joint("door_hinge")
    np.testing.assert_allclose(slide.origin[:3, 3], obj.joint("drawer_slide").origin[:3, 3] / 100,
                               rtol=1e-6)
    assert slide.limits.upper == pytest.approx(0.0035, rel=1e-6)
    assert hinge.limits.upper == pytest.approx(1.6, rel=1e-6)  # angles do not scale
    assert hinge.dynamics.damping == pytest.approx(0.5e-4, rel=1e-6)  # N m s: kg m^2 / s
    assert slide.dynamics.damping == pytest.approx(2.0, rel=1e-6)  # N s/m: kg / s
    door = cm.part("door")
    assert door.inertial.mass == pytest.approx(2.0)
    np.testing.assert_allclose(door.inertial.inertia, obj.part("door").inertial.inertia * 1e-4,
                               rtol=1e-6)
    np.testing.assert_allclose(door.visual.vertices, obj.part("door").visual.vertices / 100,
                               atol=1e-9)


# -- round trip -------------------------------------------------------------------------------
def test_import_export_import_is_lossless_and_byte_stable(written, tmp_path):
    obj, path = written
    first = usd.load(path)
    assert differences(obj, first, TOL) == []
    assert first.metadata == obj.metadata
    again = usd.save(first, tmp_path, write_meshes=False)
    assert differences(first, usd.load(again), 0.0) == []
    assert again.read_bytes() == path.read_bytes()


def test_a_massless_fixed_part_with_geometry_belongs_to_its_parents_body(tmp_path):
    """A URDF ``ee_link`` with only a collision box (no mass), fixed to a moving link: USD
    cannot say "no mass" (0 means "computed"), so as a rigid body of its own a simulator
    would give it its colliders' mass. It is an Xform in its parent's body, its box the
    parent's collider; the probe poses it, the schema states every mass, and it reads back
    as the same part."""
    from real2code_export.probes.schema_dynamics import usd_dynamics

    arm = Part("arm", visual=box_mesh([0.3, 0.05, 0.05]), collision=[box_mesh([0.3, 0.05, 0.05])],
               inertial=box_inertial([0.3, 0.05, 0.05], 1.0))
    ee = Part("ee", visual=box_mesh([0.02, 0.02, 0.02]), collision=[box_mesh([0.01, 0.01, 0.01])],
              color=(0.9, 0.1, 0.1, 1.0))
    obj = ArticulatedObject("tool", [Part("base"), arm, ee], [
        Joint("yaw", "revolute", "base", "arm", axis=[0.0, 0.0, 1.0], limits=Limits(-1.0, 1.0)),
        Joint("ee_fixed", "fixed", "arm", "ee",
              origin=tf.make(tf.rpy_to_matrix([0.0, 0.0, 1.5]), [0.15, 0.0, 0.0]))])
    path = usd.save(obj, tmp_path, write_meshes=False)
    _, parsed = _parsed(path)
    assert sorted(p.rsplit("/", 1)[1] for p in parsed["RigidBody"]) == ["arm", "base"]
    colliders = [str(s) for s in parsed["RigidBody"]["/tool/Geometry/arm"].collisions]
    assert any(c.startswith("/tool/Geometry/arm/ee/") for c in colliders), colliders
    probe = open_probes(path)[0]
    assert "ee" in probe.parts
    dynamics = usd_dynamics(probe)
    assert dynamics.unstated == {}
    assert dynamics.group_inertias()[dynamics.group["arm"]][0] == pytest.approx(1.0)
    back = usd.load(path)
    assert differences(obj, back, TOL) == []
    assert back.part("ee").color == pytest.approx(obj.part("ee").color, abs=1e-6)


def test_a_chain_of_massless_fixed_parts_belongs_to_the_body_it_hangs_from(tmp_path):
    """Collision-only links fixed one below the other (Unitree's ``calflower`` and
    ``calflower1``): the upper has a child, so it was a rigid body of its own with no mass
    stated, which a simulator fills from its colliders. Both are Xforms, the lower inside
    the upper, in the moving link's body; every mass is stated and the chain reads back as
    the same parts and joints."""
    from real2code_export.probes.schema_dynamics import usd_dynamics

    calf = Part("calf", visual=box_mesh([0.05, 0.05, 0.3]),
                collision=[box_mesh([0.05, 0.05, 0.3])],
                inertial=box_inertial([0.05, 0.05, 0.3], 1.0))
    lower = Part("lower", collision=[box_mesh([0.02, 0.02, 0.06])])
    lowest = Part("lowest", collision=[box_mesh([0.03, 0.03, 0.03])])
    obj = ArticulatedObject("leg", [Part("base"), calf, lower, lowest], [
        Joint("knee", "revolute", "base", "calf", axis=[0.0, 1.0, 0.0], limits=Limits(-1.0, 1.0)),
        Joint("lower_joint", "fixed", "calf", "lower",
              origin=tf.make(tf.rpy_to_matrix([0.0, 0.05, 0.0]), [0.02, 0.0, -0.148])),
        Joint("lowest_joint", "fixed", "lower", "lowest",
              origin=tf.make(tf.rpy_to_matrix([0.0, 0.48, 0.0]), [-0.01, 0.0, -0.04]))])
    path = usd.save(obj, tmp_path, write_meshes=False)
    _, parsed = _parsed(path)
    assert sorted(p.rsplit("/", 1)[1] for p in parsed["RigidBody"]) == ["base", "calf"]
    colliders = [str(s) for s in parsed["RigidBody"]["/leg/Geometry/calf"].collisions]
    assert any(c.startswith("/leg/Geometry/calf/lower/lowest/") for c in colliders), colliders
    assert usd_dynamics(open_probes(path)[0]).unstated == {}
    back = usd.load(path)
    assert differences(obj, back, TOL) == []
    assert back.joint("lowest_joint").parent == "lower"


def test_a_massless_moving_body_states_the_mass_welded_below_it(tmp_path):
    """A free body with no mass of its own whose mass lies in a body welded under it and a
    handle welded under that (as MJCF writes a kettle): its rigid body stated no mass and
    had no collider, so PhysX gave it 1 kg (ovphysx read 1.0 for it) and the object weighed
    1.88 kg for 0.88. The welded parts are Xforms in its body, which states their summed
    mass properties; each prim keeps its part's own (``real2code:own*``), so the model
    reads back the same. The schema's view (what PhysX reads) agrees with the source, and
    flags the old form: a moving rigid body with neither mass nor collider."""
    from real2code_export.check import check_files
    from real2code_export.probes.schema_dynamics import usd_dynamics

    source = tmp_path / "kettle.xml"
    source.write_text("""<mujoco model="kettle">
  <worldbody>
    <body name="kettle" pos="0.3 0 0.5">
      <freejoint name="free"/>
      <body name="shell" pos="0 0.1 0.05" euler="0 0 30">
        <geom type="box" size=".05 .08 .1" mass="0.8"/>
        <body name="handle" pos="0 0 0.12" euler="0 90 0">
          <geom type="capsule" size=".01 .03" mass="0.08"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
""")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        obj = load_any(source)
    path = usd.save(obj, tmp_path / "out", write_meshes=False)
    _, parsed = _parsed(path)
    assert sorted(p.rsplit("/", 1)[1] for p in parsed["RigidBody"]) == ["kettle", "world"]
    stage = Usd.Stage.Open(str(path))
    kettle = UsdPhysics.MassAPI(stage.GetPrimAtPath("/kettle/Geometry/kettle"))
    assert kettle.GetMassAttr().Get() == pytest.approx(0.88)
    def point(t, p):
        return t[:3, :3] @ p + t[:3, 3]

    shell, handle = obj.joint("kettle_to_shell").origin, obj.joint("shell_to_handle").origin
    expected = (point(shell, obj.part("shell").inertial.com) * 0.8
                + point(shell @ handle, obj.part("handle").inertial.com) * 0.08) / 0.88
    np.testing.assert_allclose(kettle.GetCenterOfMassAttr().Get(), expected, atol=1e-6)
    view = usd_dynamics(open_probes(path)[0])
    assert view.unstated == {}
    back = usd.load(path)
    assert back.part("kettle").inertial is None
    assert differences(obj, back, TOL) == []
    report = check_files([path], source=source, n_configurations=5)
    assert report.ok, [m.message for m in report.mismatches]
    # the old form, two bodies held by a fixed joint, the moving one stating nothing
    stage = Usd.Stage.CreateNew(str(tmp_path / "old.usda"))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    bodies = []
    for name in ("kettle", "shell"):
        prim = UsdGeom.Xform.Define(stage, f"/old/{name}").GetPrim()
        UsdPhysics.RigidBodyAPI.Apply(prim)
        bodies.append(prim)
    UsdPhysics.MassAPI.Apply(bodies[1]).CreateMassAttr(0.88)
    UsdPhysics.MassAPI(bodies[1]).CreateCenterOfMassAttr(Gf.Vec3f(0, 0, 0))
    UsdPhysics.MassAPI(bodies[1]).CreateDiagonalInertiaAttr(Gf.Vec3f(1e-3, 1e-3, 1e-3))
    UsdPhysics.MassAPI(bodies[1]).CreatePrincipalAxesAttr(Gf.Quatf(1, 0, 0, 0))
    weld = UsdPhysics.FixedJoint.Define(stage, "/old/weld")
    weld.CreateBody0Rel().SetTargets([bodies[0].GetPath()])
    weld.CreateBody1Rel().SetTargets([bodies[1].GetPath()])
    stage.SetDefaultPrim(stage.GetPrimAtPath("/old"))
    stage.Save()
    view = usd_dynamics(open_probes(tmp_path / "old.usda")[0])
    assert "PhysX gives such a body 1 kg" in view.unstated["kettle"]


def test_a_massless_flange_the_hand_hangs_from_is_no_body(tmp_path):
    """A massless link fixed to a moving one with a hand (mass, a moving finger) hanging
    from it (the Panda's ``panda_link8``): it was a rigid body of its own stating no mass
    and no collider, which PhysX gives 1 kg (the check flags it now). It is an Xform in the
    arm's body, as urdf-usd-converter writes it; the hand's joint is written from the arm's
    body (its frame through the flange's), naming the flange (``real2code:parentPart``), and
    reads back from the flange: the same model."""
    from real2code_export.probes.schema_dynamics import usd_dynamics

    def link(name, size):
        return Part(name, visual=box_mesh(size), collision=[box_mesh(size)],
                    inertial=box_inertial(size, 0.5))

    flange_at = tf.make(tf.rpy_to_matrix([0.0, 0.0, -0.785]), [0.0, 0.0, 0.107])
    obj = ArticulatedObject("arm", [Part("base"), link("link7", [0.1, 0.1, 0.2]),
                                    Part("flange"), link("hand", [0.05, 0.2, 0.06]),
                                    link("finger", [0.02, 0.02, 0.05])], [
        Joint("joint7", "revolute", "base", "link7", axis=[0.0, 0.0, 1.0],
              limits=Limits(-2.0, 2.0), origin=tf.make(translation=[0.0, 0.0, 0.3])),
        Joint("joint8", "fixed", "link7", "flange", origin=flange_at),
        Joint("hand_joint", "fixed", "flange", "hand",
              origin=tf.make(tf.rpy_to_matrix([0.0, 0.3, 0.0]), [0.01, 0.0, 0.02])),
        Joint("finger_joint", "prismatic", "hand", "finger", axis=[0.0, 1.0, 0.0],
              limits=Limits(0.0, 0.04), origin=tf.make(translation=[0.0, 0.0, 0.06]))])
    path = usd.save(obj, tmp_path, write_meshes=False)
    _, parsed = _parsed(path)
    assert sorted(p.rsplit("/", 1)[1] for p in parsed["RigidBody"]) == [
        "base", "finger", "hand", "link7"]
    stage = Usd.Stage.Open(str(path))
    hand_joint = stage.GetPrimAtPath("/arm/Physics/hand_joint")
    assert [str(t) for t in hand_joint.GetRelationship("physics:body0").GetTargets()] == [
        "/arm/Geometry/link7"]
    assert hand_joint.GetAttribute("real2code:parentPart").Get() == "flange"
    assert usd_dynamics(open_probes(path)[0]).unstated == {}
    back = usd.load(path)
    assert back.joint("hand_joint").parent == "flange"
    assert differences(obj, back, TOL) == []


def test_a_mesh_is_written_once(tmp_path):
    """A collider with its part's visual mesh data, and a part whose visual mesh another
    part's already holds, refer to the mesh written first (an internal reference): the data
    is in the file once, and composed, each prim has it; a visual with other texture
    coordinates, or a mesh that differs, is written out."""
    arm = axes_zoo().part("arm")
    twin = Part("twin", visual=arm.visual, collision=[arm.visual, box_mesh([0.1, 0.1, 0.1])],
                inertial=arm.inertial)
    textured = Part("textured", visual=box_mesh([0.3, 0.05, 0.05]), inertial=arm.inertial)
    textured.visual.uv = np.zeros((len(textured.visual.vertices), 2))
    obj = ArticulatedObject("twins", [arm, twin, textured], [
        Joint("a", "fixed", "arm", "twin", origin=tf.make(None, [0.0, 0.5, 0.0])),
        Joint("b", "fixed", "arm", "textured", origin=tf.make(None, [0.0, 1.0, 0.0]))])
    path = usd.save(obj, tmp_path, write_meshes=False)
    layer = Sdf.Layer.FindOrOpen(str(path))
    arrays = Sdf.Layer.FindOrOpen(str(tmp_path / usd.mesh_layer_path("twins")))
    source = "/twins/Geometry/arm/arm"
    for prim, refers in [("arm/arm", None), ("arm/arm_collision_0", source),
                         ("twin/twin", source), ("twin/twin_collision_0", source),
                         ("twin/twin_collision_1", None), ("textured/textured", None)]:
        spec = layer.GetPrimAtPath(f"/twins/Geometry/{prim}")
        assert [str(r.primPath) for r in spec.referenceList.prependedItems] == \
            ([refers] if refers else []), prim
        assert "points" not in spec.attributes, prim
        data = arrays.GetPrimAtPath(f"/twins/Geometry/{prim}")
        assert ("points" in data.attributes) == (refers is None), prim
    stage = Usd.Stage.Open(str(path))
    points = stage.GetPrimAtPath(source).GetAttribute("points").Get()
    for prim in ["arm/arm_collision_0", "twin/twin", "twin/twin_collision_0"]:
        assert stage.GetPrimAtPath(f"/twins/Geometry/{prim}").GetAttribute("points").Get() \
            == points
    assert _validation_errors(stage) == []
    back = usd.load(path)
    assert differences(obj, back, TOL) == []
    assert usd.save(back, tmp_path / "again", write_meshes=False).read_bytes() == \
        path.read_bytes()


def _one_asset_placed_four_times():
    """A mesh asset placed twice in one part's visual (two colours) and once in another's,
    whose collider is the same placement: the model says so (Mesh.placements)."""
    asset = box_mesh([0.1, 0.04, 0.02])
    asset = Mesh(asset.vertices + [0.01, 0.0, 0.0], asset.faces)  # off its origin
    turned = tf.make(tf.quat_to_matrix([0.0, 0.0, 0.0, 1.0]), [0.0, 0.2, 0.0])
    visual = Mesh.concatenate([Mesh.placed(asset, tf.make(None, [0.3, 0.0, 0.0])),
                               Mesh.placed(asset, turned)],
                              [(1.0, 0.5, 0.25, 1.0), (0.25, 0.5, 1.0, 1.0)])
    lone = Mesh.placed(asset, tf.make(None, [0.0, 0.0, 0.1]))
    arm = Part("arm", visual=visual, inertial=box_inertial([0.3, 0.1, 0.1], 1.0),
               color=(1.0, 0.5, 0.25, 1.0))
    tip = Part("tip", visual=lone, collision=[lone], inertial=box_inertial([0.1] * 3, 0.1))
    return ArticulatedObject("placed", [Part("base"), arm, tip], [
        Joint("yaw", "revolute", "base", "arm", axis=[0.0, 0.0, 1.0], limits=Limits(-1.0, 1.0)),
        Joint("tip_fixed", "fixed", "arm", "tip", origin=tf.make(None, [0.4, 0.0, 0.0]))])


def test_a_mesh_asset_placed_several_times_is_written_once(tmp_path):
    """A mesh asset the model places several times (an MJCF mesh used by several geoms) is
    one abstract prim under MeshAssets, with the only copy of its arrays; each placement is
    a prim referring to it at its own pose, of its own colour; the stage validates, reads
    back as the same object placing one asset (so written so again)."""
    obj = _one_asset_placed_four_times()
    path = usd.save(obj, tmp_path, write_meshes=False)
    layer = Sdf.Layer.FindOrOpen(str(path))
    arrays = Sdf.Layer.FindOrOpen(str(tmp_path / usd.mesh_layer_path("placed")))
    asset = "/placed/MeshAssets/mesh_0"
    assert layer.GetPrimAtPath("/placed/MeshAssets").specifier == Sdf.SpecifierClass
    assert layer.GetPrimAtPath("/placed/MeshAssets/mesh_1") is None
    with_points = []
    arrays.Traverse("/", lambda p: with_points.append(str(p.GetPrimPath()))
                    if p.IsPropertyPath() and p.name == "points" else None)
    assert with_points == [asset]
    for prim in ("arm/arm_mesh_0", "arm/arm_mesh_1", "tip/tip", "tip/tip_collision_0"):
        spec = layer.GetPrimAtPath(f"/placed/Geometry/{prim}")
        assert [str(r.primPath) for r in spec.referenceList.prependedItems] == [asset], prim
        assert "xformOp:orient" in spec.attributes, prim
    stage = Usd.Stage.Open(str(path))
    assert not [p for p in stage.Traverse() if "MeshAssets" in str(p.GetPath())]  # abstract
    assert _validation_errors(stage) == []
    back = usd.load(path)
    assert differences(obj, back, TOL) == []
    arm = back.part("arm").visual
    assert arm.colors == obj.part("arm").visual.colors
    np.testing.assert_allclose(arm.vertices, obj.part("arm").visual.vertices, atol=1e-7)
    placed = [p.asset for p in arm.placements] + [back.part("tip").visual.placements[0].asset,
                                                  back.part("tip").collision[0].placements[0].asset]
    assert len(placed) == 4 and all(a is placed[0] for a in placed)
    # written so again: the same prims (the poses' quaternions may move in their last bit:
    # USD turns an orient op into a matrix through its own rotation)
    again = usd.save(back, tmp_path / "again", write_meshes=False)
    assert _usda_lines(again, "references", "def ") == _usda_lines(path, "references", "def ")


def _usda_lines(path, *starts: str) -> list[str]:
    return [line.strip() for line in path.read_text().splitlines()
            if line.strip().startswith(starts) or any(f" {s}" in line for s in starts)]


def test_a_mesh_placed_once_is_written_where_it_is(tmp_path):
    """Placements of assets each used once change nothing: the visual is one mesh as
    before, no MeshAssets."""
    asset = box_mesh([0.1, 0.1, 0.1])
    obj = ArticulatedObject("once", [Part("base", visual=Mesh.placed(
        asset, tf.make(None, [0.0, 0.0, 0.2])), inertial=box_inertial([0.1] * 3, 1.0))], [])
    path = usd.save(obj, tmp_path, write_meshes=False)
    layer = Sdf.Layer.FindOrOpen(str(path))
    assert layer.GetPrimAtPath("/once/MeshAssets") is None
    assert not layer.GetPrimAtPath("/once/Geometry/base/base").referenceList.prependedItems


def test_the_mesh_arrays_are_a_binary_layer_beside_the_text(tmp_path):
    """``<name>.usda`` (text: every prim, schema and value but the mesh arrays) sublayers
    ``meshes/<name>.usdc`` (binary: points, triangles, texture coordinates, at the same prim
    paths, in the same order); composed, the stage reads as before; without its mesh layer
    the file is refused, naming the layer."""
    obj = small_cabinet()
    path = usd.save(obj, tmp_path / "out", write_meshes=False)
    mesh_layer = tmp_path / "out" / usd.mesh_layer_path(obj.name)
    assert mesh_layer.read_bytes().startswith(b"PXR-USDC")
    layer = Sdf.Layer.FindOrOpen(str(path))
    assert list(layer.subLayerPaths) == [f"./{usd.mesh_layer_path(obj.name)}"]
    text = path.read_text()
    assert not re.search(r"\b(points|faceVertexIndices|faceVertexCounts|primvars:st) =", text)
    stage = Usd.Stage.Open(str(path))
    meshes = [p for p in stage.Traverse() if p.GetTypeName() == "Mesh"]
    assert meshes and all(len(p.GetAttribute("points").Get()) for p in meshes)
    order = [p.name for p in layer.GetPrimAtPath(f"/{obj.name}/Geometry").nameChildren]
    assert [p.GetName() for p in stage.GetPrimAtPath(f"/{obj.name}/Geometry").GetChildren()] \
        == order
    assert _validation_errors(stage) == []
    assert differences(obj, usd.load(path), TOL) == []
    del stage, meshes  # (USD keeps a layer loaded while a stage holds it)
    mesh_layer.unlink()
    with pytest.raises(FormatError, match=f"sublayers.*{obj.name}.usdc"):
        usd.load(path)


def test_a_box_shades_flat_and_a_cylinder_smooth(tmp_path):
    """A visual mesh's normals are split along creases (indexed, face-varying), as glTF's:
    a box's 8 shared corners shade flat, each corner with its face's normal, where a
    renderer given no normals (Storm, Blender's importer) would smooth them into a blob; a
    finely tessellated cylinder's side stays smooth."""
    import trimesh
    from pxr import UsdGeom

    cylinder = trimesh.creation.cylinder(radius=0.05, height=0.2, sections=48)
    obj = ArticulatedObject("shading", [
        Part("box", visual=box_mesh([0.3, 0.2, 0.1]), inertial=box_inertial([0.3, 0.2, 0.1], 1.0)),
        Part("drum", visual=Mesh(cylinder.vertices, cylinder.faces),
             inertial=box_inertial([0.1, 0.1, 0.2], 1.0))],
        [Joint("j", "fixed", "box", "drum", origin=tf.make(None, [0.0, 0.5, 0.0]))])
    stage = Usd.Stage.Open(str(usd.save(obj, tmp_path, write_meshes=False)))
    corner_normals = {}
    for name in ("box", "drum"):
        prim = stage.GetPrimAtPath(f"/shading/Geometry/{name}/{name}")
        primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar("normals")
        assert primvar.GetInterpolation() == "faceVarying" and primvar.IsIndexed()
        corner_normals[name] = np.asarray(primvar.ComputeFlattened()).reshape(-1, 3, 3)
    box = obj.part("box").visual
    tri = box.vertices[box.faces]
    face = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    face /= np.linalg.norm(face, axis=1, keepdims=True)
    np.testing.assert_allclose(corner_normals["box"], np.repeat(face[:, None], 3, axis=1),
                               atol=1e-6)
    side = np.abs(corner_normals["drum"][..., 2]) < 0.5  # corners on the side, not the caps
    assert side.sum() > 100
    assert np.abs(np.linalg.norm(corner_normals["drum"][side][:, :2], axis=1) - 1).max() < 1e-5
    # smooth: each corner's normal near the radius through it (within 2 degrees, where a
    # face's flat normal is 3.75 degrees from its corners' radii with 48 sections)
    radial = cylinder.vertices[cylinder.faces][side][:, :2]
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    cosine = np.einsum("ij,ij->i", radial, corner_normals["drum"][side][:, :2])
    assert np.degrees(np.arccos(np.clip(cosine, -1, 1))).max() < 2.0
    assert _validation_errors(stage) == []


@pytest.mark.partnet
@pytest.mark.parametrize("object_id", ["8867", "101773", "26387"])
def test_partnet_objects_round_trip(tmp_path, object_id):
    """Real objects: 8867 once re-exported a 0 quaternion component as 9e-25; 101773 has
    11 parts; 26387 has 3 MB of meshes."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # URDF repairs, tested in the URDF tests
        obj = load_any(partnet_dir() / object_id / "mobility.urdf")
    path = usd.save(obj, tmp_path / "first", write_meshes=False)
    assert _validation_errors(Usd.Stage.Open(str(path))) == []
    first = usd.load(path)
    assert differences(obj, first, TOL) == []
    assert usd.save(first, tmp_path / "again", write_meshes=False).read_bytes() == path.read_bytes()


@pytest.mark.partnet
def test_an_export_to_usd_alone_leaves_the_hulls_to_physx(tmp_path):
    """``real2code export mobility.urdf --to usd`` computes no hulls: each collision mesh is
    written as the URDF gives it, with approximation convexHull (PhysX hulls it), flat ones
    thickened so that hull has the volume the computed piece would; kinematics and masses are
    those of the default read. No trimesh or scipy is imported (issue 17: their import cost
    more than the export), nor USD's schema modules (the writer authors through Sdf), nor
    ``numpy.ma`` (``np.unique`` imports it: 13 ms), nor the cutting apart of pieces made."""
    import subprocess
    import sys

    from real2code_export.collision import convex_hull

    urdf = partnet_dir() / "41083" / "mobility.urdf"
    code = ("import sys, warnings; warnings.simplefilter('ignore'); "
            "from real2code_export.cli import run; "
            f"rc = run(['export', {str(urdf)!r}, '--to', 'usd', '--out', {str(tmp_path)!r}]); "
            "print(rc, ' '.join(sorted({m.split('.')[0] for m in sys.modules} "
            "& {'trimesh', 'scipy'} | {m for m in sys.modules} & {'pxr.Usd', 'pxr.UsdGeom', "
            "'pxr.UsdPhysics', 'pxr.UsdShade', 'newton_usd_schemas', 'numpy.ma', "
            "'real2code_export.collision_separation'})))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True, env={**__import__("os").environ, "REAL2CODE_CACHE": "off"})
    assert done.stdout.split("\n")[-2].strip() == "0", done.stdout[-2000:]
    written = next(tmp_path.glob("*.usda"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        computed = load_any(urdf)
        raw = load_any(urdf, hull_collision=False)
    stage = Usd.Stage.Open(str(written))
    shapes = [p for p in stage.Traverse() if p.HasAPI(UsdPhysics.CollisionAPI)]
    assert shapes and all(UsdPhysics.MeshCollisionAPI(p).GetApproximationAttr().Get()
                          == UsdPhysics.Tokens.convexHull for p in shapes)
    assert differences(raw, usd.load(written), TOL) == []
    for a, b in zip(computed.parts, raw.parts, strict=True):
        assert differences(ArticulatedObject("a", [Part("p", inertial=a.inertial)], []),
                           ArticulatedObject("a", [Part("p", inertial=b.inertial)], []),
                           0.0) == []
        if not a.collision:
            continue
        # the computed pieces hull the same points (tiny ones merged into neighbours)
        hull_of_raw = convex_hull(type(a.collision[0]).concatenate(b.collision))
        hull_of_computed = convex_hull(type(a.collision[0]).concatenate(a.collision))
        assert hull_of_raw.to_trimesh().volume == pytest.approx(
            hull_of_computed.to_trimesh().volume, rel=1e-6)
        for piece in b.collision:  # every piece a solid once hulled, none flat
            assert convex_hull(piece).to_trimesh().volume > 0


def test_thickened_flat_piece_hulls_like_a_computed_piece():
    from real2code_export.collision import convex_hull, thickened
    from real2code_export.model import Mesh

    square = Mesh([[0, 0, 0], [0.3, 0, 0], [0.3, 0.2, 0], [0, 0.2, 0], [9, 9, 9]],
                  [[0, 1, 2], [0, 2, 3]])  # and a vertex no face uses
    thick = thickened(square)
    assert len(thick.vertices) == 8 and np.ptp(thick.vertices[:, 2]) == pytest.approx(1e-3)
    assert convex_hull(thick).to_trimesh().volume == pytest.approx(
        convex_hull(square).to_trimesh().volume)
    box = box_mesh([0.1, 0.2, 0.3])
    assert np.array_equal(thickened(box).vertices, box.vertices)


def test_usdc_and_registry(tmp_path):
    obj = small_cabinet()
    written = export(obj, tmp_path / "out", ["usd"])
    usda = written["usd"]
    assert usda.name == "small_cabinet.usda"
    # USD holds its meshes in its own binary layer: an export to USD alone writes no OBJ
    assert [p.name for p in (tmp_path / "out" / "meshes").iterdir()] == ["small_cabinet.usdc"]
    both = export(obj, tmp_path / "both", ["usd", "urdf"])
    assert (tmp_path / "both" / "meshes" / "door.obj").is_file()  # the URDF's mesh files
    assert both["usd"].read_bytes() == usda.read_bytes()
    crate = tmp_path / "small_cabinet.usdc"
    assert Usd.Stage.Open(str(usda)).Export(str(crate))  # one binary file, flattened
    assert differences(obj, load_any(crate), TOL) == []


def test_a_file_from_another_tool(tmp_path):
    """No custom attributes, a reversed joint (body0 = child), joint frames on both sides
    (localPos1 != 0), a Y axis, the child written at 30 degrees, no joint to the world (free,
    as PhysX and Newton simulate it: a floating base): the importer and the probe must agree
    with each other at every configuration."""
    text = """#usda 1.0
(
    defaultPrim = "thing"
    metersPerUnit = 1
    upAxis = "Z"
)
def Xform "thing"
{
    def Xform "base" (prepend apiSchemas = ["PhysicsRigidBodyAPI", "PhysicsMassAPI"])
    {
        float physics:mass = 3
        point3f physics:centerOfMass = (0, 0, 0.1)
        float3 physics:diagonalInertia = (0.1, 0.2, 0.25)
        quatf physics:principalAxes = (1, 0, 0, 0)
        def Cube "box" (prepend apiSchemas = ["PhysicsCollisionAPI"])
        {
            double size = 0.2
        }
    }
    def Xform "lid" (prepend apiSchemas = ["PhysicsRigidBodyAPI", "PhysicsMassAPI"])
    {
        double3 xformOp:translate = (0.12448287781021136, 0.2, 0.2880932931151505)
        quatd xformOp:orient = (0.79335333404749, 0, -0.6087614371457277, 0)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:orient"]
        float physics:mass = 0.5
        point3f physics:centerOfMass = (0.05, 0, 0)
        float3 physics:diagonalInertia = (0.01, 0.01, 0.015)
        quatf physics:principalAxes = (1, 0, 0, 0)
        def Mesh "shell"
        {
            point3f[] points = [(0, 0, 0), (0.1, 0, 0), (0.1, 0.1, 0), (0, 0.1, 0)]
            int[] faceVertexCounts = [4]
            int[] faceVertexIndices = [0, 1, 2, 3]
        }
    }
    def PhysicsRevoluteJoint "lid_hinge"
    {
        rel physics:body0 = </thing/lid>
        rel physics:body1 = </thing/base>
        uniform token physics:axis = "Y"
        point3f physics:localPos0 = (0.02, 0, 0.01)
        quatf physics:localRot0 = (0.9238795, 0, 0.38268343, 0)
        point3f physics:localPos1 = (0.12, 0.2, 0.31)
        quatf physics:localRot1 = (1, 0, 0, 0)
        float physics:lowerLimit = -90
        float physics:upperLimit = 45
    }
}
"""
    path = tmp_path / "thing.usda"
    path.write_text(text)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        obj = usd.load(path)
    assert [str(w.message).split(": ", 1)[1] for w in caught] == [
        "no joint fixes the object to the world: it is free, as UsdPhysics' simulators take "
        "it (its first body </thing/base> floats from a massless part 'world')"]
    (probe,) = open_probes(path)
    hinge = obj.joint("lid_hinge")
    assert (hinge.parent, hinge.child, hinge.type.value) == ("base", "lid", "revolute")
    free = obj.parent_joint("base")
    assert (free.parent, free.type.value) == ("world", "floating")
    assert hinge.state == pytest.approx(math.radians(30), abs=1e-6)
    assert (hinge.limits.lower, hinge.limits.upper) == pytest.approx((-math.pi / 2, math.pi / 4))
    assert obj.part("lid").visual.faces.shape == (2, 3)  # the quad, fanned
    assert len(obj.part("base").collision) == 1  # the cube, meshed
    rng = np.random.default_rng(3)
    for q in [obj.observed_configuration()] + [sample_configuration(obj, rng) for _ in range(20)]:
        expected, got = forward_kinematics(obj, q), probe.poses(q)
        assert sorted(got) == ["base", "lid"]  # (the world part is not in the file)
        for name in got:
            np.testing.assert_allclose(got[name], expected[name], atol=TOL, err_msg=name)


def test_a_moving_joint_to_the_world_in_a_y_up_centimetre_stage(tmp_path):
    """A pendulum hinged to the world: a massless 'world' part becomes the root; Y up and
    centimetres are converted (mass properties too); importer and probe agree."""
    path = tmp_path / "pendulum.usda"
    path.write_text("""#usda 1.0
(
    defaultPrim = "pendulum"
    upAxis = "Y"
    metersPerUnit = 0.01
)
def Xform "pendulum"
{
    def Xform "bob" (prepend apiSchemas = ["PhysicsRigidBodyAPI", "PhysicsMassAPI"])
    {
        double3 xformOp:translate = (0, -50, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
        float physics:mass = 1
        point3f physics:centerOfMass = (0, 0, 0)
        float3 physics:diagonalInertia = (10, 10, 10)
        quatf physics:principalAxes = (1, 0, 0, 0)
    }
    def PhysicsRevoluteJoint "swing"
    {
        rel physics:body1 = </pendulum/bob>
        uniform token physics:axis = "Z"
        point3f physics:localPos1 = (0, 50, 0)
        float physics:lowerLimit = -90
        float physics:upperLimit = 90
    }
}
""")
    with pytest.warns(Real2CodeWarning, match="a massless part 'world' is the root"):
        obj = usd.load(path)
    swing = obj.joint("swing")
    assert (obj.root.name, swing.parent, swing.child) == ("world", "world", "bob")
    np.testing.assert_allclose(obj.part("bob").inertial.inertia, np.eye(3) * 1e-3)
    (probe,) = open_probes(path)
    for q in (0.0, 0.7, -1.2):
        bob = forward_kinematics(obj, {"swing": q})["bob"]
        np.testing.assert_allclose(probe.poses({"swing": q})["bob"], bob, atol=TOL)
        # the part frame is at the hinge (localPos1), the bob's centre 50 stage units along
        # stage -Y = world -Z from it; the stage Z axis is world -Y
        expected = tf.axis_angle_matrix([0.0, -1.0, 0.0], q) @ [0.0, 0.0, -0.5]
        np.testing.assert_allclose(bob[:3, :3] @ [0.0, -0.5, 0.0] + bob[:3, 3], expected,
                                   atol=TOL)


def test_a_joint_to_a_static_collider_holds_to_the_world_at_its_frame(tmp_path):
    """A joint whose body0 is a prim without PhysicsRigidBodyAPI (a static collider, as
    OpenUSD's own UsdPhysics examples write it): UsdPhysics holds the joint to the world at
    that prim's frame, its local position in the prim's space (scaled), its rotation turned
    by the prim's. Read so (it crashed the reader), warned; the hinge where UsdPhysics puts it."""
    path = tmp_path / "hinged.usda"
    path.write_text("""#usda 1.0
(
    defaultPrim = "World"
    upAxis = "Z"
    metersPerUnit = 1
)
def Xform "World"
{
    def Cube "Wall" (prepend apiSchemas = ["PhysicsCollisionAPI"])
    {
        double size = 1
        double3 xformOp:translate = (1, 0, 2)
        float3 xformOp:rotateXYZ = (0, 0, 90)
        float3 xformOp:scale = (2, 0.5, 1)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ", "xformOp:scale"]
    }
    def Cube "Flap" (prepend apiSchemas = ["PhysicsCollisionAPI", "PhysicsRigidBodyAPI",
                                           "PhysicsMassAPI"])
    {
        double size = 0.2
        float physics:mass = 1
        double3 xformOp:translate = (0.75, 0.5, 2)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def PhysicsRevoluteJoint "hinge"
    {
        rel physics:body0 = </World/Wall>
        rel physics:body1 = </World/Flap>
        uniform token physics:axis = "X"
        point3f physics:localPos0 = (0.25, 0.5, 0)
        point3f physics:localPos1 = (0, 0, 0)
        quatf physics:localRot0 = (0.70710677, 0, 0, -0.70710677)
        float physics:lowerLimit = -45
        float physics:upperLimit = 45
    }
}
""")
    with pytest.warns(Real2CodeWarning, match=r"joint prim </World/hinge>: body0 </World/Wall> "
                      r"is no rigid body \(a static prim\)"):
        obj = usd.load(path)
    hinge = obj.joint("hinge")
    assert (hinge.parent, hinge.child) == ("world", "Flap")
    # Wall: scale (2, 0.5, 1), then 90 degrees about Z, then (1, 0, 2): its local (0.25, 0.5,
    # 0) is (0.5, 0.25, 0) scaled, (-0.25, 0.5, 0) turned, (0.75, 0.5, 2) placed; localRot0
    # turns back the wall's 90 degrees, so the hinge axis X stays the world's X.
    frame = forward_kinematics(obj, {"hinge": 0.0})["Flap"]
    np.testing.assert_allclose(frame[:3, 3], [0.75, 0.5, 2.0], atol=1e-6)
    np.testing.assert_allclose(frame[:3, :3] @ hinge.axis, [1.0, 0.0, 0.0], atol=1e-6)


def test_a_colliders_own_mass_counts_in_its_bodys(tmp_path):
    """A body with no mass authored on it whose colliders carry PhysicsMassAPI themselves
    (OpenUSD's nested-articulation example: "explicit mass on the collider contributes to
    implicit mass on the body"): each collider at its own mass, the rest at the default
    density, summed about their joint centre of mass (was: every collider at the default
    density, the authored mass ignored)."""
    path = tmp_path / "arm.usda"
    path.write_text("""#usda 1.0
(
    defaultPrim = "World"
    upAxis = "Z"
    metersPerUnit = 1
    kilogramsPerUnit = 1
)
def Xform "World"
{
    def Xform "Arm" (prepend apiSchemas = ["PhysicsRigidBodyAPI"])
    {
        def Cube "Heavy" (prepend apiSchemas = ["PhysicsCollisionAPI", "PhysicsMassAPI"])
        {
            double size = 0.1
            float physics:mass = 2
            double3 xformOp:translate = (0.5, 0, 0)
            uniform token[] xformOpOrder = ["xformOp:translate"]
        }
        def Cube "Plain" (prepend apiSchemas = ["PhysicsCollisionAPI"])
        {
            double size = 0.1
            double3 xformOp:translate = (-0.5, 0, 0)
            uniform token[] xformOpOrder = ["xformOp:translate"]
        }
    }
    def PhysicsRevoluteJoint "pivot"
    {
        rel physics:body1 = </World/Arm>
        uniform token physics:axis = "Z"
    }
}
""")
    with pytest.warns(Real2CodeWarning, match=r"prim </World/Arm>: mass not authored: computed "
                      r"from its 2 collider\(s\), 1 at their own mass or density"):
        obj = usd.load(path)
    inertial = obj.part("Arm").inertial
    plain = 1000.0 * 0.1**3  # the default density
    assert inertial.mass == pytest.approx(2.0 + plain)
    np.testing.assert_allclose(inertial.com, [(2.0 * 0.5 - plain * 0.5) / (2.0 + plain), 0, 0],
                               atol=1e-9)
    box = 0.1**2 / 6.0  # a cube's moment per kg about its centre
    assert inertial.inertia[0, 0] == pytest.approx((2.0 + plain) * box)


def test_a_prim_of_a_type_no_schema_defines_is_said(tmp_path):
    """A joint typed ``DistancePhysicsJoint`` (an old spelling, in OpenUSD's own examples):
    UsdPhysics' parser, and so PhysX and Newton, skip it; the reader names it in a warning
    rather than passing over it in silence."""
    path = tmp_path / "typo.usda"
    path.write_text("""#usda 1.0
(
    defaultPrim = "World"
    metersPerUnit = 1
)
def Xform "World"
{
    def Cube "Box" (prepend apiSchemas = ["PhysicsCollisionAPI", "PhysicsRigidBodyAPI"])
    {
        double size = 0.1
    }
    def DistancePhysicsJoint "Tether"
    {
        rel physics:body1 = </World/Box>
    }
}
""")
    with pytest.warns(Real2CodeWarning, match=r"prims of a type no schema defines, which "
                      r"UsdPhysics' parser skips: </World/Tether> \(DistancePhysicsJoint\)"):
        usd.load(path)


# -- bad input ------------------------------------------------------------------------------
def test_missing_file(tmp_path):
    missing = tmp_path / "nothing.usda"
    with pytest.raises(FormatError, match=re.escape(str(missing))):
        usd.load(missing)


def test_malformed_usda_names_file_and_line(tmp_path):
    path = tmp_path / "broken.usda"
    path.write_text('#usda 1.0\ndef Xform "a"\n{\n    float physics:mass = \n}\n')
    with pytest.raises(FormatError) as err:
        usd.load(path)
    assert err.value.path == str(path) and err.value.line == 4, str(err.value)
    assert str(path) in str(err.value)


def test_joint_whose_body1_does_not_exist(tmp_path):
    path = usd.save(small_cabinet(), tmp_path, write_meshes=False)
    text = path.read_text().replace("rel physics:body1 = </small_cabinet/Geometry/drawer>",
                                    "rel physics:body1 = </small_cabinet/Geometry/nothing>")
    path.write_text(text)
    with pytest.raises(FormatError) as err:
        usd.load(path)
    message = str(err.value)
    assert str(path) in message
    assert "/small_cabinet/Physics/drawer_slide" in message
    assert "body1 </small_cabinet/Geometry/nothing> does not exist" in message


def test_unsupported_joint_type_is_refused(tmp_path):
    path = usd.save(small_cabinet(), tmp_path, write_meshes=False)
    path.write_text(path.read_text().replace('def PhysicsRevoluteJoint "knob_turn"',
                                             'def PhysicsDistanceJoint "knob_turn"'))
    with pytest.raises(FormatError, match="knob_turn.*DistanceJoint cannot be represented"):
        usd.load(path)


def test_spherical_joint_is_a_ball_joint_with_its_cone_limit(tmp_path):
    """A spherical joint's cone (both angles, degrees) is the ball's cone limit; an elliptic
    one keeps its smaller angle, warned; a negative angle (UsdPhysics' "no limit") none."""
    path = usd.save(small_cabinet(), tmp_path, write_meshes=False)
    text = path.read_text().replace('def PhysicsRevoluteJoint "knob_turn"',
                                    'def PhysicsSphericalJoint "knob_turn"')
    body = text.index("{", text.index('"knob_turn"')) + 1
    for cones, expected in [((30, 30), math.radians(30)), ((30, 20), math.radians(20)),
                            ((-1, -1), None)]:
        path.write_text(text[:body] + f"\n float physics:coneAngle0Limit = {cones[0]}\n"
                        f" float physics:coneAngle1Limit = {cones[1]}\n" + text[body:])
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            obj = usd.load(path)
        ball = obj.joint("knob_turn")
        assert ball.type.value == "ball"
        assert ball.cone_limit == (None if expected is None else pytest.approx(expected))
        elliptic = [w for w in caught if "elliptic cone" in str(w.message)]
        assert len(elliptic) == (cones[0] != cones[1]), [str(w.message) for w in caught]


def test_a_foreign_body_without_mass_and_with_instanced_colliders(tmp_path):
    """Other people's USD (Newton's example assets): a moving body with MassAPI's density
    and no mass, its collider under an instanceable prim (an instance proxy, which
    UsdPhysics parses and a plain traversal does not see). The simulators compute its mass
    from the collider at the authored density; so does the reader, warned. A body the
    world holds keeps none (its mass moves nothing)."""
    from pxr import Gf, UsdGeom

    path = tmp_path / "arm.usda"
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdGeom.Xform.Define(stage, "/arm")
    prototype = UsdGeom.Cube.Define(stage, "/prototypes/block/cube")
    prototype.CreateSizeAttr(0.2)
    UsdPhysics.CollisionAPI.Apply(prototype.GetPrim())
    stage.GetPrimAtPath("/prototypes").SetSpecifier(Sdf.SpecifierClass)
    for name, at in (("base", (0.0, 0.0, 0.0)), ("link", (0.5, 0.0, 0.0))):
        body = UsdGeom.Xform.Define(stage, f"/arm/{name}")
        body.AddTranslateOp().Set(Gf.Vec3d(*at))
        UsdPhysics.RigidBodyAPI.Apply(body.GetPrim())
        shapes = stage.DefinePrim(f"/arm/{name}/collisions")
        shapes.GetReferences().AddInternalReference("/prototypes/block")
        shapes.SetInstanceable(True)
    UsdPhysics.MassAPI.Apply(stage.GetPrimAtPath("/arm/link")).CreateDensityAttr(500.0)
    fixed = UsdPhysics.FixedJoint.Define(stage, "/arm/world_joint")
    fixed.CreateBody1Rel().SetTargets(["/arm/base"])
    hinge = UsdPhysics.RevoluteJoint.Define(stage, "/arm/hinge")
    hinge.CreateBody0Rel().SetTargets(["/arm/base"])
    hinge.CreateBody1Rel().SetTargets(["/arm/link"])
    hinge.CreateAxisAttr("Z")
    hinge.CreateLocalPos0Attr(Gf.Vec3f(0.5, 0.0, 0.0))
    stage.GetRootLayer().Save()
    with pytest.warns(Real2CodeWarning, match=r"computed from its 1 collider\(s\) at 500 kg/m"):
        obj = usd.load(path)
    link = obj.part("link")
    assert link.inertial.mass == pytest.approx(500.0 * 0.2**3)
    assert len(link.collision) == 1 and obj.part("base").inertial is None


def test_a_foreign_body_whose_xform_is_scaled(tmp_path):
    """A rigid body's Xform scaled along its own axes (Newton's cartpole: the cart a unit
    cube under ``xformOp:scale = (0.2, 0.25, 0.2)``): the body is where its translation
    and rotation put it, its shapes are scaled (as PhysX and Newton's importer take them:
    the cart's cube is 0.2 x 0.25 x 0.2 m) and so are the joints' positions and its
    authored centre of mass in it. A body whose Xform shears is refused, naming it."""
    from pxr import Gf, UsdGeom

    def stage_with(cart_ops):
        path = tmp_path / "cart.usda"
        stage = Usd.Stage.CreateNew(str(path))
        UsdGeom.SetStageMetersPerUnit(stage, 1.0)
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
        UsdGeom.Xform.Define(stage, "/cartpole")
        rail = UsdGeom.Xform.Define(stage, "/cartpole/rail")
        UsdPhysics.RigidBodyAPI.Apply(rail.GetPrim())
        cart = UsdGeom.Xform.Define(stage, "/cartpole/cart")
        cart_ops(cart)
        UsdPhysics.RigidBodyAPI.Apply(cart.GetPrim())
        mass = UsdPhysics.MassAPI.Apply(cart.GetPrim())
        mass.CreateMassAttr(1.0)
        mass.CreateCenterOfMassAttr(Gf.Vec3f(0.5, 0.0, -0.2))  # in the cart's scaled space
        cube = UsdGeom.Cube.Define(stage, "/cartpole/cart/box")
        cube.CreateSizeAttr(1.0)
        UsdPhysics.CollisionAPI.Apply(cube.GetPrim())
        fixed = UsdPhysics.FixedJoint.Define(stage, "/cartpole/root")
        fixed.CreateBody1Rel().SetTargets(["/cartpole/rail"])
        slide = UsdPhysics.PrismaticJoint.Define(stage, "/cartpole/slide")
        slide.CreateBody0Rel().SetTargets(["/cartpole/rail"])
        slide.CreateBody1Rel().SetTargets(["/cartpole/cart"])
        slide.CreateAxisAttr("X")
        slide.CreateLocalPos0Attr(Gf.Vec3f(0.0, 0.0, 1.0))
        slide.CreateLocalPos1Attr(Gf.Vec3f(0.0, 0.0, 0.0))
        stage.GetRootLayer().Save()
        return path

    def scaled(cart):
        cart.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 1.0))
        cart.AddScaleOp().Set(Gf.Vec3f(0.2, 0.25, 0.2))

    obj = usd.load(stage_with(scaled))
    world = forward_kinematics(obj, obj.observed_configuration())["cart"]
    corners = obj.part("cart").collision[0].vertices @ world[:3, :3].T + world[:3, 3]
    np.testing.assert_allclose(corners.min(axis=0), [-0.1, -0.125, 0.9], atol=1e-9)
    np.testing.assert_allclose(corners.max(axis=0), [0.1, 0.125, 1.1], atol=1e-9)
    assert obj.part("cart").inertial.mass == pytest.approx(1.0)
    np.testing.assert_allclose(world[:3, :3] @ obj.part("cart").inertial.com + world[:3, 3],
                               [0.1, 0.0, 0.96], atol=1e-7)  # scaled as Newton's importer

    def sheared(cart):
        cart.AddTransformOp().Set(Gf.Matrix4d(1, 0, 0, 0, 0.5, 1, 0, 0, 0, 0, 1, 0, 0, 0, 1, 1))

    with pytest.raises(FormatError, match=r"prim </cartpole/cart>: rigid body transform has "
                                          "shear"):
        usd.load(stage_with(sheared))


def _scene_stage(path, anchored: bool):
    """Boxes no joint holds (free bodies) beside, if ``anchored``, a body fixed to the world
    with a flap hinged to it (Newton's sensor_contact_scene; without it, its palletizer)."""
    from pxr import Gf, UsdGeom

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    stage.SetDefaultPrim(UsdGeom.Xform.Define(stage, "/scene").GetPrim())
    bodies = [("crate_0", (1.0, 0.0, 0.3)), ("crate_1", (-1.0, 0.5, 0.3)),
              ("crate_2", (0.0, -1.0, 0.6))]
    if anchored:
        bodies = [("anchor", (0.0, 0.0, 1.0)), ("flap", (0.0, 0.2, 1.0))] + bodies
    for name, at in bodies:
        body = UsdGeom.Xform.Define(stage, f"/scene/{name}")
        body.AddTranslateOp().Set(Gf.Vec3d(*at))
        body.AddOrientOp().Set(Gf.Quatf(0.9659258, 0.0, 0.0, 0.2588190))  # 30 deg about Z
        UsdPhysics.RigidBodyAPI.Apply(body.GetPrim())
        UsdPhysics.MassAPI.Apply(body.GetPrim()).CreateMassAttr(1.0)
        cube = UsdGeom.Cube.Define(stage, f"/scene/{name}/box")
        cube.CreateSizeAttr(0.1)
        UsdPhysics.CollisionAPI.Apply(cube.GetPrim())
    if anchored:
        fixed = UsdPhysics.FixedJoint.Define(stage, "/scene/anchor_joint")
        fixed.CreateBody1Rel().SetTargets(["/scene/anchor"])
        fixed.CreateLocalPos0Attr(Gf.Vec3f(0.0, 0.0, 1.0))
        fixed.CreateLocalRot0Attr(Gf.Quatf(0.9659258, 0.0, 0.0, 0.2588190))
        hinge = UsdPhysics.RevoluteJoint.Define(stage, "/scene/hinge")
        hinge.CreateBody0Rel().SetTargets(["/scene/anchor"])
        hinge.CreateBody1Rel().SetTargets(["/scene/flap"])
        hinge.CreateAxisAttr("X")
        hinge.CreateLocalPos0Attr(Gf.Vec3f(0.0, 0.1, 0.0))
        hinge.CreateLocalPos1Attr(Gf.Vec3f(0.0, -0.1, 0.0))
        hinge.CreateLowerLimitAttr(-45.0)
        hinge.CreateUpperLimitAttr(45.0)
    stage.GetRootLayer().Save()
    return path


@pytest.mark.parametrize("anchored", [True, False], ids=["anchored", "all_free"])
def test_a_scene_of_free_bodies_in_every_format(tmp_path, anchored):
    """A scene of free bodies (rigid bodies no joint holds), beside a body the world holds
    or alone. Alone, none is more fixed than another: each floats from a massless part
    'world' (warned). Beside one held off the world's origin, that body keeps its own frame,
    held by its fixed joint to the part 'world', from which the others float too. Every
    export reads back equal and agrees with the others in its own tools."""
    import mujoco

    from real2code_export.check import check_files

    path = _scene_stage(tmp_path / "scene.usda", anchored)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        obj = usd.load(path)
    said = [str(w.message) for w in caught]
    assert obj.root.name == "world"
    free = [j for j in obj.joints if j.type.value == "floating"]
    assert sorted(j.child for j in free) == ["crate_0", "crate_1", "crate_2"] and all(
        j.parent == "world" for j in free)
    if anchored:  # at the joint's frame: 1 m up, turned 30 degrees about Z
        held = obj.joint("anchor_joint")
        assert (held.type.value, held.parent, held.child) == ("fixed", "world", "anchor")
        np.testing.assert_allclose(forward_kinematics(obj)["anchor"], tf.make(
            tf.axis_angle_matrix([0.0, 0.0, 1.0], math.radians(30.0)), [0.0, 0.0, 1.0]),
            atol=1e-6)
    assert any("form 3 groups no joint connects: each is free" in m for m in said) \
        != anchored, said
    np.testing.assert_allclose(forward_kinematics(obj)["crate_2"][:3, 3], [0.0, -1.0, 0.6],
                               atol=1e-6)
    written = export(obj, tmp_path / "out", formats=["mjcf", "urdf", "usd", "gltf"])
    for fmt, out in written.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Real2CodeWarning)
            assert not differences(obj, load_any(out)), fmt
    model = mujoco.MjModel.from_xml_path(str(written["urdf"]))
    assert sum(int(t) == mujoco.mjtJoint.mjJNT_FREE for t in model.jnt_type) == 3
    report = check_files(list(written.values()), n_configurations=5, validate=False)
    assert report.ok, report.mismatches


@pytest.mark.parametrize("kinematic", [False, True], ids=["dynamic", "kinematic"])
def test_one_group_no_joint_holds_is_free_unless_kinematic(tmp_path, kinematic):
    """A body with a flap hinged to it and no joint to the world (an ant, a humanoid, a
    prop: PhysX and Newton simulate it falling): free, from a massless part 'world', so the
    MJCF export has a free joint (it was fixed where it stands: a floating base welded to
    the world). A kinematic first body (``physics:kinematicEnabled``: moved by the user, not
    the simulation) stays the root, fixed where it stands; each warned."""
    import mujoco

    from real2code_export.check import check_files

    path = _scene_stage(tmp_path / "scene.usda", True)
    stage = Usd.Stage.Open(str(path))
    stage.RemovePrim("/scene/anchor_joint")
    for crate in ("crate_0", "crate_1", "crate_2"):
        stage.RemovePrim(f"/scene/{crate}")
    if kinematic:
        UsdPhysics.RigidBodyAPI(stage.GetPrimAtPath("/scene/anchor")) \
            .CreateKinematicEnabledAttr(True)
    stage.GetRootLayer().Save()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        obj = usd.load(path)
    said = " ".join(str(w.message) for w in caught)
    if kinematic:
        assert obj.root.name == "anchor" and "kinematic (physics:kinematicEnabled): taken " \
            "as fixed where it stands" in said
    else:  # (where the file puts it)
        assert obj.root.name == "world" and obj.parent_joint("anchor").type.value == "floating"
        assert "it is free, as UsdPhysics' simulators take it" in said
        np.testing.assert_allclose(forward_kinematics(obj)["anchor"][:3, 3], [0.0, 0.0, 1.0],
                                   atol=1e-6)
    written = export(obj, tmp_path / "out", formats=["mjcf", "usd"])
    model = mujoco.MjModel.from_xml_path(str(written["mjcf"]))
    assert sum(int(t) == mujoco.mjtJoint.mjJNT_FREE for t in model.jnt_type) == (not kinematic)
    report = check_files(list(written.values()), n_configurations=5, validate=False)
    assert report.ok, report.mismatches


def test_a_diagonal_inertia_without_principal_axes_is_in_the_body_axes(tmp_path):
    """``physics:diagonalInertia`` authored and ``principalAxes`` left at its fallback, the
    zero quaternion (Newton's own test assets write bodies so): the diagonal in the body's
    axes, as Newton's importer takes it (the reader made a NaN tensor of it and refused the
    file: "inertia is not finite"); the check's schema view reads it so too."""
    from real2code_export.check import check_files

    path = _scene_stage(tmp_path / "scene.usda", True)
    stage = Usd.Stage.Open(str(path))
    for crate in ("crate_0", "crate_1", "crate_2"):
        stage.RemovePrim(f"/scene/{crate}")
    for name in ("anchor", "flap"):
        UsdPhysics.MassAPI(stage.GetPrimAtPath(f"/scene/{name}")).CreateDiagonalInertiaAttr(
            Gf.Vec3f(0.01, 0.02, 0.03))
    stage.GetRootLayer().Save()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        obj = usd.load(path)
    np.testing.assert_allclose(obj.part("flap").inertial.inertia, np.diag([0.01, 0.02, 0.03]),
                               atol=1e-9)
    written = export(obj, tmp_path / "out", formats=["mjcf", "usd"])
    report = check_files(list(written.values()), n_configurations=5, validate=False)
    assert report.ok, report.mismatches


def _mujoco_stage(path):
    """An MJCF body with two hinges at anchors of their own, written as mujoco-usd-converter
    writes one: two PhysicsRevoluteJoints between the same two bodies (MuJoCo's order), an
    MjcActuator on the first (a position servo with MuJoCo's spec values: a dampratio in
    biasPrm[2] and inheritrange), one on a site; names that are no identifier encoded by
    usd-exchange (``tn__``) with the source's in ``displayName``. Returns the MJCF it
    states."""
    from pxr import Gf, UsdGeom

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    stage.SetDefaultPrim(UsdGeom.Xform.Define(stage, "/arm").GetPrim())
    rest = (0.1, 0.0, 0.5)
    for name, at, shown in (("base", (0.0, 0.0, 0.5), None),
                            ("tn__upperarm_kE", (0.1, 0.0, 0.5), "upper-arm")):
        body = UsdGeom.Xform.Define(stage, f"/arm/{name}")
        body.AddTranslateOp().Set(Gf.Vec3d(*at))
        UsdPhysics.RigidBodyAPI.Apply(body.GetPrim())
        mass = UsdPhysics.MassAPI.Apply(body.GetPrim())
        mass.CreateMassAttr(1.0)
        mass.CreateCenterOfMassAttr(Gf.Vec3f(0.0, 0.0, 0.1))
        mass.CreateDiagonalInertiaAttr(Gf.Vec3f(0.01, 0.01, 0.002))
        if shown:
            body.GetPrim().SetDisplayName(shown)
    UsdGeom.Xform.Define(stage, "/arm/tn__upperarm_kE/tip").AddTranslateOp().Set(
        Gf.Vec3d(0.0, 0.0, 0.3))
    fixed = UsdPhysics.FixedJoint.Define(stage, "/arm/to_world")
    fixed.CreateBody1Rel().SetTargets(["/arm/base"])
    fixed.CreateLocalPos0Attr(Gf.Vec3f(0.0, 0.0, 0.5))
    anchors = {"shoulder_x": ((0.0, 0.0, 0.05), "X"), "tn__shoulderz_wB": ((0.02, 0.0, 0.0), "Z")}
    for name, (anchor, axis) in anchors.items():
        joint = UsdPhysics.RevoluteJoint.Define(stage, f"/arm/tn__upperarm_kE/{name}")
        joint.CreateBody0Rel().SetTargets(["/arm/base"])
        joint.CreateBody1Rel().SetTargets(["/arm/tn__upperarm_kE"])
        joint.CreateAxisAttr(axis)
        joint.CreateLocalPos0Attr(Gf.Vec3f(*(np.array(anchor) + np.array(rest)
                                              - np.array([0.0, 0.0, 0.5]))))
        joint.CreateLocalPos1Attr(Gf.Vec3f(*anchor))
        joint.CreateLowerLimitAttr(-90.0)
        joint.CreateUpperLimitAttr(60.0)
    stage.GetPrimAtPath("/arm/tn__upperarm_kE/tn__shoulderz_wB").SetDisplayName("shoulder-z")
    servo = stage.DefinePrim("/arm/servo", "MjcActuator")
    servo.CreateAttribute("mjc:gainPrm", Sdf.ValueTypeNames.DoubleArray).Set([40.0] + [0.0] * 9)
    servo.CreateAttribute("mjc:biasType", Sdf.ValueTypeNames.Token).Set("affine")
    servo.CreateAttribute("mjc:biasPrm", Sdf.ValueTypeNames.DoubleArray).Set(
        [0.0, -40.0, 0.7] + [0.0] * 7)  # (a dampratio: MuJoCo's compiler makes it a kv)
    servo.CreateAttribute("mjc:inheritRange", Sdf.ValueTypeNames.Double).Set(1.0)
    servo.CreateRelationship("mjc:target").SetTargets(["/arm/tn__upperarm_kE/shoulder_x"])
    pusher = stage.DefinePrim("/arm/pusher", "MjcActuator")
    pusher.CreateAttribute("mjc:gear", Sdf.ValueTypeNames.DoubleArray).Set([0, 0, 1, 0, 0, 0])
    pusher.CreateRelationship("mjc:target").SetTargets(["/arm/tn__upperarm_kE/tip"])
    stage.GetRootLayer().Save()
    return """<mujoco><compiler angle="radian"/><worldbody><body name="base" pos="0 0 0.5">
      <inertial pos="0 0 0.1" mass="1" diaginertia="0.01 0.01 0.002"/>
      <body name="upper_arm" pos="0.1 0 0">
        <inertial pos="0 0 0.1" mass="1" diaginertia="0.01 0.01 0.002"/>
        <joint name="shoulder_x" pos="0 0 0.05" axis="1 0 0" range="-1.5708 1.0472"/>
        <joint name="shoulder_z" pos="0.02 0 0" axis="0 0 1" range="-1.5708 1.0472"/>
        <site name="tip" pos="0 0 0.3"/>
      </body></body></worldbody>
      <actuator><position joint="shoulder_x" kp="40" dampratio="0.7" inheritrange="1"/>
        <general site="tip" gear="0 0 1 0 0 0"/></actuator></mujoco>"""


def test_usd_from_mujocos_converter_reads_as_the_mjcf_it_came_from(tmp_path):
    """A USD file as mujoco-usd-converter writes an MJCF body of two joints: read as a
    chain through a massless part (the MJCF reader's form), the bodies where MuJoCo puts
    them at every configuration (they were one joint and a loop closer: a degree of freedom
    lost); the MjcActuator servo the drive MuJoCo compiles (its dampratio's damping from the
    joint's inertia, its range from the joint's), the one on a site kept as MJCF; the
    source's names from ``displayName`` where the prim's is usd-exchange's encoding."""
    import mujoco

    from real2code_export.formats.mjcf.kept import ELEMENTS_KEY

    xml = _mujoco_stage(tmp_path / "arm.usda")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        obj = usd.load(tmp_path / "arm.usda")
    said = " ".join(str(w.message) for w in caught)
    assert "join the same two bodies: read as one body's joints" in said
    # the base held 0.5 m up by its joint to the world keeps its frame there, as in the MJCF
    assert [p.name for p in obj.parts] == ["world", "base", "upper_arm",
                                           "upper_arm_shoulder_x", "tip"]
    np.testing.assert_allclose(forward_kinematics(obj)["base"][:3, 3], [0.0, 0.0, 0.5],
                               atol=1e-9)
    assert [j.name for j in obj.movable_joints] == ["shoulder_x", "shoulder_z"]
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    servo = obj.joint("shoulder_x").drive
    assert servo.stiffness == pytest.approx(m.actuator_gainprm[0, 0])
    assert servo.damping == pytest.approx(-m.actuator_biasprm[0, 2], rel=1e-6)
    np.testing.assert_allclose(servo.target_range, m.actuator_ctrlrange[0], atol=1e-5)
    assert "<general" in obj.metadata[ELEMENTS_KEY]["actuator"] and 'site="tip"' in \
        obj.metadata[ELEMENTS_KEY]["actuator"]
    rng = np.random.default_rng(5)
    anchor = np.array([0.02, 0.0, 0.0])  # the part's frame: the last joint's anchor
    for _ in range(10):
        q = {"shoulder_x": rng.uniform(-1.5, 1.0), "shoulder_z": rng.uniform(-1.5, 1.0)}
        d.qpos[:] = [q["shoulder_x"], q["shoulder_z"]]
        mujoco.mj_kinematics(m, d)
        pose = forward_kinematics(obj, q)["upper_arm"]
        body = np.eye(4)
        body[:3, :3] = d.xmat[2].reshape(3, 3)
        body[:3, 3] = d.xpos[2]
        np.testing.assert_allclose(pose, body @ tf.make(translation=anchor), atol=1e-6)
    written = export(obj, tmp_path / "out", formats=["mjcf"])
    back = mujoco.MjModel.from_xml_path(str(written["mjcf"]))
    assert back.nu == 2 and back.body("upper_arm").jntnum[0] == 2  # one body again


def test_usd_from_the_urdf_converter_is_repaired_as_its_urdf_is(tmp_path):
    """What urdf-usd-converter writes of robot files as they ship: a sensor link's all-zero
    tensor and a tensor off the triangle inequality (repaired and warned, as the URDF and
    MJCF readers repair them: the reader refused the file), a revolute joint whose limits
    are 0 and 0 (a URDF <limit> with effort and velocity only: PhysX and Newton hold it
    there, MuJoCo refuses the range: a fixed joint), a flat collider mesh (MuJoCo refuses
    to hull it: thickened, as the URDF reader does). The MJCF export compiles and agrees."""
    import mujoco
    from pxr import Gf

    from real2code_export.check import check_files

    path = _scene_stage(tmp_path / "scene.usda", True)
    stage = Usd.Stage.Open(str(path))
    for crate in ("crate_0", "crate_1"):
        stage.RemovePrim(f"/scene/{crate}")
    stage.GetPrimAtPath("/scene/flap").CreateAttribute(  # (as the converter writes it)
        "newton:inertia", Sdf.ValueTypeNames.DoubleArray).Set([0.0] * 6)
    anchor = UsdPhysics.MassAPI(stage.GetPrimAtPath("/scene/anchor"))
    anchor.CreateDiagonalInertiaAttr(Gf.Vec3f(0.001, 0.001, 0.01))
    hinge = UsdPhysics.RevoluteJoint(stage.GetPrimAtPath("/scene/hinge"))
    hinge.CreateLowerLimitAttr(0.0)
    hinge.CreateUpperLimitAttr(0.0)
    stage.RemovePrim("/scene/crate_2/box")
    plate = UsdGeom.Mesh.Define(stage, "/scene/crate_2/plate")
    plate.CreatePointsAttr([(0, 0, 0), (0.2, 0, 0), (0.2, 0.1, 0), (0, 0.1, 0)])
    plate.CreateFaceVertexCountsAttr([4])
    plate.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    UsdPhysics.CollisionAPI.Apply(plate.GetPrim())
    stage.GetRootLayer().Save()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        obj = usd.load(path)
    said = " ".join(str(w.message) for w in caught)
    assert "prim </scene/flap>: inertia tensor is zero" in said
    assert "prim </scene/anchor>: inertia tensor violates the triangle inequality" in said
    assert "hold the joint there; read as a fixed joint at q = 0" in said
    assert obj.joint("hinge").type.value == "fixed"
    plate_mesh = obj.part("crate_2").collision[0]
    assert np.ptp(plate_mesh.vertices[:, 2]) > 0  # a volume to hull
    written = export(obj, tmp_path / "out", formats=["mjcf", "usd"])
    mujoco.MjModel.from_xml_path(str(written["mjcf"]))
    report = check_files(list(written.values()), n_configurations=5, validate=False)
    assert report.ok, report.mismatches


def _d6_stage(path, joints, distance: bool = False):
    """A base fixed to the world and, per entry of ``joints`` (name, free axes with their
    range in degrees or metres, None for no limit; the values the child stands at; whether
    body0 is the child), a child body on a generic joint (PhysicsJoint, a D6) whose other
    axes are locked (low > high), its frames rotated and off both bodies' origins."""
    from pxr import Gf, UsdGeom

    from real2code_export.formats.usd import d6

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    stage.SetDefaultPrim(UsdGeom.Xform.Define(stage, "/robot").GetPrim())

    def body(name, pose):
        xform = UsdGeom.Xform.Define(stage, f"/robot/{name}")
        xform.AddTransformOp().Set(Gf.Matrix4d(pose.T.tolist()))
        UsdPhysics.RigidBodyAPI.Apply(xform.GetPrim())
        UsdPhysics.MassAPI.Apply(xform.GetPrim()).CreateMassAttr(1.0)
        cube = UsdGeom.Cube.Define(stage, f"/robot/{name}/box")
        cube.CreateSizeAttr(0.1)
        UsdPhysics.CollisionAPI.Apply(cube.GetPrim())

    base = tf.make(tf.axis_angle_matrix([0.0, 0.0, 1.0], 0.4), [0.0, 0.0, 1.0])
    body("base", base)
    fixed = UsdPhysics.FixedJoint.Define(stage, "/robot/to_world")
    fixed.CreateBody1Rel().SetTargets(["/robot/base"])
    fixed.CreateLocalPos0Attr(Gf.Vec3f(0.0, 0.0, 1.0))
    fixed.CreateLocalRot0Attr(Gf.Quatf(*tf.matrix_to_quat(base[:3, :3]).tolist()))
    r0 = tf.axis_angle_matrix(np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0), 0.3)
    r1 = tf.axis_angle_matrix(np.array([0.0, 1.0, 1.0]) / math.sqrt(2.0), -0.6)
    t0, t1 = tf.make(r0, [0.1, 0.2, -0.1]), tf.make(r1, [0.0, 0.05, 0.15])
    for k, (name, free, values, reversed_) in enumerate(joints):
        dofs = [d6.Dof(a, a[-1], a.startswith("rot")) for a in d6.ORDER if a in free]
        at = np.array(values, float)
        moved = d6.motion(dofs, [math.radians(v) if d.angular else v
                                 for d, v in zip(dofs, at, strict=True)])
        child = f"link_{k}"  # (body1 = body0 T0 M(q) T1^-1, whichever body0 is)
        body(child, base @ t0 @ (tf.inverse(moved) if reversed_ else moved) @ tf.inverse(t1))
        joint = UsdPhysics.Joint.Define(stage, f"/robot/{name}")
        ends = ["/robot/base", f"/robot/{child}"][::-1 if reversed_ else 1]
        frames = [t0, t1][::-1 if reversed_ else 1]
        joint.CreateBody0Rel().SetTargets([ends[0]])
        joint.CreateBody1Rel().SetTargets([ends[1]])
        for side, frame in enumerate(frames):
            quat = Gf.Quatf(*tf.matrix_to_quat(frame[:3, :3]).tolist())
            getattr(joint, f"CreateLocalPos{side}Attr")(Gf.Vec3f(*frame[:3, 3].tolist()))
            getattr(joint, f"CreateLocalRot{side}Attr")(quat)
        for axis in d6.ORDER + (("distance",) if distance else ()):
            if axis in free and free[axis] is None:
                continue  # no PhysicsLimitAPI: free
            low, high = free.get(axis) or (1.0, -1.0)  # locked
            limit = UsdPhysics.LimitAPI.Apply(joint.GetPrim(), axis)
            limit.CreateLowAttr(low)
            limit.CreateHighAttr(high)
    stage.GetRootLayer().Save()
    return path


def test_a_generic_joint_is_the_joint_its_free_axes_make(tmp_path):
    """A generic joint (a D6: PhysicsJoint, each axis locked by a limit whose low is above
    its high) is, by its free axes: one rotation a revolute joint, one translation a
    prismatic one, the three rotations unlimited a ball, none a fixed joint; else a chain
    of joints, one per free axis in Newton's order (translations, then rotations X, Y, Z,
    each about its axis as the ones before turned it: as Newton's importer and MuJoCo's
    several joints of a body take it) through massless intermediate parts (warned). The
    bodies' poses give the values; a joint running child -> parent is the chain reversed.
    The MJCF export holds a chain as one body of several joints, the USD export as the
    generic joint again; every export reads back equal and agrees with the others."""
    import mujoco

    from real2code_export.check import check_files

    joints = [
        ("hip", {"rotX": (-45.0, 30.0), "rotZ": (-60.0, 35.0)}, (20.0, -30.0), False),
        ("knee", {"rotY": (-150.0, 0.0)}, (-40.0,), False),
        ("wrist", {"rotZ": None}, (70.0,), True),
        ("rail", {"transY": (-0.2, 0.3)}, (0.1,), False),
        ("shoulder", {"rotX": None, "rotY": None, "rotZ": None}, (0.0, 0.0, 0.0), False),
        ("ankle", {"transX": None, "rotX": (-10.0, 50.0), "rotY": (-50.0, 50.0)},
         (0.05, 25.0, -15.0), True),
        ("weld", {}, (), False),
        ("neck", {"rotY": (-30.0, 30.0), "rotZ": None}, (15.0, 0.0), False),
    ]
    path = _d6_stage(tmp_path / "robot.usda", joints)
    with pytest.warns(Real2CodeWarning, match=r"generic joints \(D6\) of several free axes split"):
        obj = usd.load(path)
    kinds = {j.name: j.type.value for j in obj.joints}
    assert {k: kinds[k] for k in ("knee", "wrist", "rail", "shoulder", "weld")} == {
        "knee": "revolute", "wrist": "continuous", "rail": "prismatic", "shoulder": "ball",
        "weld": "fixed"}
    hip = [obj.joint("hip_rotX"), obj.joint("hip_rotZ")]
    assert [(j.parent, j.child) for j in hip] == [("base", "link_0_hip_rotX"),
                                                 ("link_0_hip_rotX", "link_0")]
    assert obj.part("link_0_hip_rotX").inertial.mass == pytest.approx(1e-6)
    assert (hip[1].limits.lower, hip[1].limits.upper) == pytest.approx(
        (math.radians(-60.0), math.radians(35.0)))
    ankle = [obj.joint(n) for n in ("ankle_rotY", "ankle_rotX", "ankle_transX")]  # reversed
    assert [(j.parent, j.child) for j in ankle] == [
        ("base", "link_5_ankle_rotY"), ("link_5_ankle_rotY", "link_5_ankle_rotX"),
        ("link_5_ankle_rotX", "link_5")]
    for name, free, values, _ in joints:  # the values the bodies stand at
        if name in ("shoulder", "weld"):
            continue
        got = [obj.joint(f"{name}_{a}" if len(free) > 1 else name).state for a in free]
        expected = [math.radians(v) if a.startswith("rot") else v
                    for a, v in zip(free, values, strict=True)]
        assert got == pytest.approx(expected, abs=1e-6), name
    # the model poses the child as the D6 does: T0 M(q) T1^-1 from the base body (which,
    # the root, stands where its fixed joint puts it: the root part's frame is the world's)
    q = {"hip_rotX": 0.2, "hip_rotZ": -0.7}
    fk = forward_kinematics(obj, {**obj.observed_configuration(), **q})
    r0 = tf.axis_angle_matrix(np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0), 0.3)
    base = tf.make(tf.axis_angle_matrix([0.0, 0.0, 1.0], 0.4), [0.0, 0.0, 1.0])
    expected = base @ tf.make(r0, [0.1, 0.2, -0.1]) @ tf.make(
        tf.axis_angle_matrix([1.0, 0.0, 0.0], 0.2) @ tf.axis_angle_matrix([0.0, 0.0, 1.0], -0.7))
    # (the part frame is the child body's frame at the joint: localRot1 turned, no offset)
    expected = expected @ tf.make(tf.axis_angle_matrix(np.array([0.0, 1.0, 1.0]) / math.sqrt(2.0), -0.6)).T
    np.testing.assert_allclose(fk["link_0"], expected, atol=1e-6)

    written = export(obj, tmp_path / "out", formats=["mjcf", "urdf", "usd", "gltf"])
    for fmt, out in written.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Real2CodeWarning)
            assert not differences(obj, load_any(out)), fmt
    # USD: a chain in the generic joint's order is that generic joint again, no bodies
    # between; the reversed one (rotations before the slide) stays joints and bodies
    exported = Usd.Stage.Open(str(written["usd"]))
    kinds = {p.GetName(): p.GetTypeName()
             for p in exported.GetPrimAtPath("/robot/Physics").GetChildren()}
    assert kinds["hip"] == kinds["neck"] == "PhysicsJoint" and "hip_rotX" not in kinds
    assert kinds["ankle_rotY"] == "PhysicsRevoluteJoint" and "ankle" not in kinds
    assert not exported.GetPrimAtPath("/robot/Geometry/link_0_hip_rotX")
    # one body of several joints where the joints after the first stand at 0 (a later one
    # elsewhere would be written as its ref, which MuJoCo reads as a turned frame)
    model = mujoco.MjModel.from_xml_path(str(written["mjcf"]))
    assert [int(model.body(b).jntnum[0]) for b in ("link_7", "link_0", "link_5")] == [2, 1, 1]
    report = check_files(list(written.values()), n_configurations=5, validate=False)
    assert report.ok, report.mismatches

    with pytest.raises(FormatError, match=r"joint prim </robot/hip>: a generic joint with a "
                                          "distance limit cannot be represented"):
        usd.load(_d6_stage(tmp_path / "rope.usda", joints[:1], distance=True))


def _z_up_stage(path, root: str):
    """A new stage in metres, Z up, ``/<root>`` its default prim."""
    from pxr import UsdGeom

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    stage.SetDefaultPrim(UsdGeom.Xform.Define(stage, f"/{root}").GetPrim())
    return stage


def _rigid_body(stage, path: str, at=None):
    """An Xform at ``path`` (moved to ``at``) that is a rigid body of 1 kg."""
    from pxr import Gf, UsdGeom

    body = UsdGeom.Xform.Define(stage, path)
    if at is not None:
        body.AddTranslateOp().Set(Gf.Vec3d(*at))
    UsdPhysics.RigidBodyAPI.Apply(body.GetPrim())
    UsdPhysics.MassAPI.Apply(body.GetPrim()).CreateMassAttr(1.0)
    return body


# a four-bar's hinges: (name, body0, body1, localPos0, localPos1)
FOURBAR_HINGES = (("A", "base", "crank", (-0.5, 0, 0), (0, 0, -0.5)),
                  ("B", "crank", "coupler", (0, 0, 0.5), (-0.5, 0, 0)),
                  ("C", "base", "rocker", (0.5, 0, 0), (0, 0, -0.5)),
                  ("D", "rocker", "coupler", (0, 0, 0.5), (0.5, 0, 0)))


def _fourbar_bodies(path):
    """A stage of a four-bar's four bodies, its base held 0.5 m along X by the fixed joint
    ``ground``; its hinges (:data:`FOURBAR_HINGES`) are the caller's."""
    from pxr import Gf

    stage = _z_up_stage(path, "fourbar")
    for name, at in (("base", (0.5, 0.0, 0.0)), ("crank", (0.0, 0.0, 0.5)),
                     ("coupler", (0.5, 0.0, 1.0)), ("rocker", (1.0, 0.0, 0.5))):
        _rigid_body(stage, f"/fourbar/{name}", at)
    fixed = UsdPhysics.FixedJoint.Define(stage, "/fourbar/ground")
    fixed.CreateBody1Rel().SetTargets(["/fourbar/base"])
    fixed.CreateLocalPos0Attr(Gf.Vec3f(0.5, 0.0, 0.0))
    return stage


@pytest.mark.parametrize("closing", ["revolute", "generic"])
def test_a_joint_closing_a_kinematic_loop_is_kept_and_carried_to_mujoco(tmp_path, closing):
    """A four-bar: four bodies, four hinges, one too many for a tree. The joint the file
    excludes from the articulation (physics:excludeFromArticulation) is the one left out
    of the tree, even where the walk from the root would meet another last: kept in the
    metadata, written back to USD excluded from the articulation, and carried to MuJoCo as
    an equality connect at its anchor (warned), which holds at the written pose; every
    export reads back equal and agrees with the others. The closing joint a hinge, or a
    generic joint (D6) whose one free axis is the hinge's."""
    import mujoco
    from pxr import Gf

    from real2code_export.check import check_files

    path = tmp_path / "fourbar.usda"
    stage = _fourbar_bodies(path)
    for name, body0, body1, pos0, pos1 in FOURBAR_HINGES:
        generic = name == "B" and closing == "generic"
        hinge = (UsdPhysics.Joint if generic else UsdPhysics.RevoluteJoint).Define(
            stage, f"/fourbar/{name}")
        hinge.CreateBody0Rel().SetTargets([f"/fourbar/{body0}"])
        hinge.CreateBody1Rel().SetTargets([f"/fourbar/{body1}"])
        if generic:  # every axis locked (low above high) but rotY
            for axis in ("transX", "transY", "transZ", "rotX", "rotZ"):
                limit = UsdPhysics.LimitAPI.Apply(hinge.GetPrim(), axis)
                limit.CreateLowAttr(1.0)
                limit.CreateHighAttr(-1.0)
        else:
            hinge.CreateAxisAttr("Y")
        hinge.CreateLocalPos0Attr(Gf.Vec3f(*pos0))
        hinge.CreateLocalPos1Attr(Gf.Vec3f(*pos1))
        hinge.CreateExcludeFromArticulationAttr(name == "B")
        if name == "B":  # a drive on the closing joint (its axis's instance), kept with it
            drive = UsdPhysics.DriveAPI.Apply(hinge.GetPrim(), "rotY" if generic else "angular")
            drive.CreateStiffnessAttr(3.0)
    stage.GetRootLayer().Save()
    with pytest.warns(Real2CodeWarning, match=r"joint prim </fourbar/B> \(continuous\) closes "
                                              "a kinematic loop"):
        obj = usd.load(path)
    assert sorted(j.name for j in obj.joints) == ["A", "C", "D", "ground"]
    (loop,) = obj.metadata["loop_joints"]
    assert (loop["name"], loop["body0"], loop["body1"]) == ("B", "crank", "coupler")
    generic_b = closing == "generic"
    assert loop["type"] == ("generic" if generic_b else "continuous")
    assert loop["drives"] == [{"instance": "rotY" if generic_b else "angular",
                               "attributes": {"stiffness": 3.0}}]
    written = export(obj, tmp_path / "out", formats=["mjcf", "urdf", "usd", "gltf"])
    for fmt, out in written.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Real2CodeWarning)
            back = load_any(out)
        assert not differences(obj, back), fmt
        assert back.metadata["loop_joints"] == obj.metadata["loop_joints"], fmt
    model = mujoco.MjModel.from_xml_path(str(written["mjcf"]))
    assert model.neq == 1 and int(model.eq_type[0]) == mujoco.mjtEq.mjEQ_CONNECT
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    residual = data.efc_pos[data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY]
    np.testing.assert_allclose(residual, 0.0, atol=1e-9)
    exported = Usd.Stage.Open(str(written["usd"]))
    closing = UsdPhysics.Joint(exported.GetPrimAtPath("/fourbar/Physics/B"))
    assert closing.GetPrim().GetTypeName() == ("PhysicsJoint" if generic_b else
                                               "PhysicsRevoluteJoint")
    assert closing.GetExcludeFromArticulationAttr().Get() is True
    assert closing.GetPrim().GetAttribute(
        f"drive:{'rotY' if generic_b else 'angular'}:physics:stiffness").Get() == 3.0
    assert [str(t) for t in closing.GetBody1Rel().GetTargets()] == ["/fourbar/Geometry/coupler"]
    report = check_files(list(written.values()), n_configurations=5, validate=False)
    assert report.ok, report.mismatches


def test_joint_drives_are_kept_and_written_back(tmp_path):
    """A force drive (PhysicsDriveAPI) is the model joint's drive (a generic joint's on its
    axis's joint), in SI per radian (a centimetre stage here, gains per degree as UsdPhysics
    states them); one the model's drives cannot be (an acceleration drive: PhysX scales it by
    the joint's inertia) is kept in the metadata as UsdPhysics states it, warned. Both are
    written back to USD on the joint they drive, and read back the same; the model drive is
    an MJCF actuator too; a drive on a locked axis drives nothing: said."""
    from pxr import Gf, UsdGeom

    path = tmp_path / "driven.usda"
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageMetersPerUnit(stage, 0.01)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    stage.SetDefaultPrim(UsdGeom.Xform.Define(stage, "/arm").GetPrim())
    for name, x in (("base", 0.0), ("upper", 10.0), ("lower", 20.0)):
        body = UsdGeom.Xform.Define(stage, f"/arm/{name}")
        body.AddTranslateOp().Set(Gf.Vec3d(x, 0.0, 0.0))
        UsdPhysics.RigidBodyAPI.Apply(body.GetPrim())
        UsdPhysics.MassAPI.Apply(body.GetPrim()).CreateMassAttr(1.0)
    UsdPhysics.FixedJoint.Define(stage, "/arm/root").CreateBody1Rel().SetTargets(["/arm/base"])
    elbow = UsdPhysics.RevoluteJoint.Define(stage, "/arm/elbow")
    shoulder = UsdPhysics.Joint.Define(stage, "/arm/shoulder")
    for joint, ends in ((shoulder, ("base", "upper")), (elbow, ("upper", "lower"))):
        joint.CreateBody0Rel().SetTargets([f"/arm/{ends[0]}"])
        joint.CreateBody1Rel().SetTargets([f"/arm/{ends[1]}"])
        joint.CreateLocalPos0Attr(Gf.Vec3f(10.0, 0.0, 0.0))
    elbow.CreateAxisAttr("Z")
    for axis in ("transX", "transY", "transZ", "rotX"):  # rotY, rotZ free
        limit = UsdPhysics.LimitAPI.Apply(shoulder.GetPrim(), axis)
        limit.CreateLowAttr(1.0)
        limit.CreateHighAttr(-1.0)
    for joint, instance, gains, kind in (
            (elbow, "angular", (2.0, 0.5), "acceleration"), (shoulder, "rotZ", (4.0, 1.0), "force"),
            (shoulder, "transX", (1.0, 1.0), "force")):
        drive = UsdPhysics.DriveAPI.Apply(joint.GetPrim(), instance)
        drive.CreateTypeAttr(kind)
        drive.CreateStiffnessAttr(gains[0])
        drive.CreateDampingAttr(gains[1])
        drive.CreateTargetPositionAttr(30.0)
        drive.CreateMaxForceAttr(float("inf"))  # no limit: not kept
    stage.GetRootLayer().Save()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        obj = usd.load(path)
    said = "\n".join(str(w.message) for w in caught)
    assert "drives (PhysicsDriveAPI) the model's drives cannot be: elbow (a drive of type " \
           "'acceleration'" in said
    assert "drives on no free axis (a locked one, a fixed or ball joint) ignored: " \
           "</arm/shoulder> transX" in said
    drives = {(d["joint"], d["instance"]): d["attributes"] for d in obj.metadata["usd_drives"]}
    # N cm / degree -> N m / degree: 1e-4 (kg cm^2 s^-2 -> kg m^2 s^-2)
    assert drives == {("elbow", "angular"): pytest.approx(
        {"type": "acceleration", "stiffness": 2e-4, "damping": 5e-5, "targetPosition": 30.0})}
    rot_z = obj.joint("shoulder_rotZ").drive  # per radian: 180 / pi times per degree
    assert (rot_z.kind.value, rot_z.target, rot_z.force_limit) == ("position",
                                                                  pytest.approx(np.pi / 6), None)
    assert [rot_z.stiffness, rot_z.damping] == pytest.approx(np.array([4e-4, 1e-4]) * 180 / np.pi)
    assert obj.joint("elbow").drive is None
    written = export(obj, tmp_path / "out", formats=["usd", "mjcf"])
    exported = Usd.Stage.Open(str(written["usd"]))  # (the shoulder a generic joint again)
    prim = exported.GetPrimAtPath("/arm/Physics/shoulder")
    assert "PhysicsDriveAPI:rotZ" in prim.GetAppliedSchemas()
    assert prim.GetAttribute("drive:rotZ:physics:stiffness").Get() == pytest.approx(4e-4)
    assert prim.GetAttribute("drive:rotZ:physics:targetPosition").Get() == pytest.approx(30.0)
    prim = exported.GetPrimAtPath("/arm/Physics/elbow")
    assert prim.GetAttribute("drive:angular:physics:stiffness").Get() == pytest.approx(2e-4)
    assert prim.GetAttribute("drive:angular:physics:type").Get() == "acceleration"
    for out in written.values():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Real2CodeWarning)
            back = load_any(out)
        assert back.metadata["usd_drives"] == obj.metadata["usd_drives"]
        assert not back.joint("shoulder_rotZ").drive.differences(rot_z, 1e-6)


def test_kept_loops_and_drives_that_are_not_ours_are_refused_or_said(tmp_path):
    """The USD writer writes back the loop-closing joints and drives the reader keeps; an
    entry it cannot read is an error naming the metadata entry, one naming a part or joint
    the object no longer has is warned about and not written."""
    from real2code_export.errors import ModelError

    obj = small_cabinet()
    loop = {"name": "closing", "type": "revolute", "body0": "body", "body1": "drawer",
            "frame0": {"translation": [0.0, 0.0, 0.0], "rotation": [1.0, 0.0, 0.0, 0.0]},
            "frame1": {"translation": [0.0, 0.0, 0.0], "rotation": [1.0, 0.0, 0.0, 0.0]},
            "axis": "Z", "limits": None}
    obj.metadata["loop_joints"] = [{k: v for k, v in loop.items() if k != "frame1"}]
    with pytest.raises(ModelError, match=r"metadata 'loop_joints'\[0\].*not a joint as the "
                                         r"USD reader keeps it \(missing or wrong: 'frame1'\)"):
        usd.save(obj, tmp_path / "a", write_meshes=False)
    obj.metadata["loop_joints"] = [{**loop, "body1": "gone"}]
    obj.metadata["usd_drives"] = [{"joint": "no_such_joint", "instance": "angular",
                                   "attributes": {"stiffness": 1.0}}]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        usd.save(obj, tmp_path / "b", write_meshes=False)
    said = "\n".join(str(w.message) for w in caught)
    assert "part(s) ['gone'] are not the object's: not written" in said
    assert "joint 'no_such_joint' is not a joint prim of the object" in said
    obj.metadata["usd_drives"] = [{"joint": "drawer_slide", "instance": "sideways",
                                   "attributes": {}}]
    obj.metadata.pop("loop_joints")
    with pytest.raises(ModelError, match=r"metadata 'usd_drives'\[0\].*instance 'sideways'"):
        usd.save(obj, tmp_path / "c", write_meshes=False)


HELD_BALL = """<mujoco model="held">
  <default><joint limited="true" damping="1"/></default>
  <worldbody>
    <body name="base" pos="0 0 1">
      <geom type="sphere" size="0.05"/>
      <body name="link" pos="0.2 0 0">
        <joint name="ankle" type="ball"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_a_ball_limited_without_a_range_is_held_at_rest_in_every_format(tmp_path):
    """A ball under ``limited="true"`` with no range: MuJoCo compiles a cone of 0, the ball
    held at its rest. The model keeps a cone limit of 0; USD writes a generic joint with its
    translations locked and its rotations limited to [0, 0] (a spherical joint's cone of 0
    would leave the twist free), read back as the held ball; glTF locks every axis; every
    export reads back the same and agrees with the source, dynamics included."""
    from real2code_export.check import check_files

    source = tmp_path / "held.xml"
    source.write_text(HELD_BALL)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        obj = load_any(source)
        assert obj.joint("ankle").cone_limit == 0.0
        written = export(obj, tmp_path / "out", ["json", "mjcf", "urdf", "usd", "gltf"])
        for fmt, path in written.items():
            assert not differences(obj, load_any(path)), fmt
        report = check_files(list(written.values()), source=source, n_configurations=3,
                             validate=False, warned=[])
    assert not report.mismatches, report.mismatches
    stage = Usd.Stage.Open(str(written["usd"]))
    prim = stage.GetPrimAtPath("/held/Physics/ankle")
    assert prim.GetTypeName() == "PhysicsJoint"
    for axis in ("rotX", "rotY", "rotZ"):
        assert (prim.GetAttribute(f"limit:{axis}:physics:low").Get(),
                prim.GetAttribute(f"limit:{axis}:physics:high").Get()) == (0.0, 0.0)


def test_snapped_quat_iterates_in_floats_as_on_arrays():
    """The fixed-point iteration in Python floats does numpy's operations: quantised,
    canonical and renormalised agree with the array helpers bit for bit, and the answer is
    their fixed point."""
    from real2code_export.formats.usd import conventions as c

    rng = np.random.default_rng(3)
    for k in range(2000):
        q = rng.normal(size=4)
        q[rng.integers(0, 4, size=k % 3)] = 0.0
        if k % 5 == 0:
            q[rng.integers(0, 4)] = 1e-9 * rng.normal()  # below 2^-16: the fine grid
        q /= np.linalg.norm(q)
        assert np.array(c._quantised_floats(q.tolist())).tobytes() == c._quantised(q).tobytes()
        assert np.array(c._canonical_floats(q.tolist())).tobytes() == c._canonical(q).tobytes()
        snapped = c.snapped_quat(tf.quat_to_matrix(q))
        assert c._renormalised(snapped).tobytes() == snapped.tobytes()


def test_creased_normals_row_norms_and_crease_test_are_numpys():
    """normals.row_norms is np.linalg.norm(axis=1) bit for bit (float64 and float32), and
    the crease test by the dot alone away from the crease's cosine answers as arccos does,
    at the band's edges, inside it, and for NaN and infinities (the normals, and so every
    exported file, stay the same)."""
    from real2code_export import normals

    rng = np.random.default_rng(12)
    rows = rng.normal(size=(200_000, 3)) * 10.0 ** rng.integers(-18, 18, (200_000, 1))
    rows[:3] = [[0.0, 0.0, 0.0], [-0.0, 3.0, -4.0], [1e-160, 1e-160, 0.0]]
    for dtype in (np.float64, np.float32):
        a = rows.astype(dtype)
        assert normals.row_norms(a).tobytes() == np.linalg.norm(a, axis=1).tobytes()
    c, band = normals._CREASE_COS, normals._CREASE_BAND
    dots = np.concatenate([np.linspace(-1.5, 1.5, 200_001), c + np.arange(-500, 501) * 1e-17,
                           c + band * np.array([-1.0, 1.0, -1.0000001, 1.0000001, 2, -2]),
                           [np.nan, np.inf, -np.inf, 1.0, -1.0]])
    want = np.abs(np.arccos(np.clip(dots, -1.0, 1.0))) < normals.CREASE_ANGLE
    assert np.array_equal(normals._under_crease_angle(dots), want)


def test_creased_normals_face_cross_products_are_numpys():
    """meshtopology.face_cross_products: each face's (b - a) x (c - a) bit for bit as
    np.cross gives it (the creased normals, and so every exported file, stay the same)."""
    from real2code_export.meshtopology import face_cross_products as _cross

    rng = np.random.default_rng(11)
    vertices = rng.normal(size=(500, 3)) * 10.0 ** rng.integers(-6, 3, (500, 1))
    vertices[7] = vertices[3]  # degenerate faces too
    faces = rng.integers(0, 500, (2000, 3))
    faces[:5, 1] = faces[:5, 0]
    tri = vertices[faces]
    want = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    assert np.array_equal(_cross(vertices, faces), want)
    assert _cross(vertices, faces[:0]).shape == (0, 3)


def test_joints_stacked_from_the_world_are_one_bodys_joints(tmp_path):
    """An MJCF body of several joints in the worldbody (the Menagerie's umi_gripper), as
    mujoco-usd-converter writes it: a slide and a hinge from the world (body0 unset) to the
    same body, in MuJoCo's order. Read as a chain, as between two bodies; they were one
    joint and a loop closer (a degree of freedom lost, the MJCF export an equality
    ``connect``): the body stands where MuJoCo puts it at every configuration."""
    import mujoco

    stage = Usd.Stage.CreateNew(str(tmp_path / "gripper.usda"))
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    stage.SetDefaultPrim(UsdGeom.Xform.Define(stage, "/gripper").GetPrim())
    body = UsdGeom.Xform.Define(stage, "/gripper/body")
    body.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 0.1))
    UsdPhysics.RigidBodyAPI.Apply(body.GetPrim())
    mass = UsdPhysics.MassAPI.Apply(body.GetPrim())
    mass.CreateMassAttr(1.0)
    mass.CreateDiagonalInertiaAttr(Gf.Vec3f(0.01, 0.01, 0.01))
    for name, schema, axis in (("slide_x", UsdPhysics.PrismaticJoint, "X"),
                               ("turn_z", UsdPhysics.RevoluteJoint, "Z")):
        joint = schema.Define(stage, f"/gripper/body/{name}")
        joint.CreateBody1Rel().SetTargets(["/gripper/body"])
        joint.CreateAxisAttr(axis)
        joint.CreateLocalPos0Attr(Gf.Vec3f(0.0, 0.0, 0.1))
        joint.CreateLocalPos1Attr(Gf.Vec3f(0.0))
    stage.GetRootLayer().Save()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        obj = usd.load(tmp_path / "gripper.usda")
    assert not [w for w in caught if "kinematic loop" in str(w.message)]
    assert [j.name for j in obj.movable_joints] == ["slide_x", "turn_z"]
    m = mujoco.MjModel.from_xml_string("""<mujoco><worldbody><body name="body" pos="0 0 0.1">
      <joint name="slide_x" type="slide" axis="1 0 0"/><joint name="turn_z" axis="0 0 1"/>
      <inertial pos="0 0 0" mass="1" diaginertia="0.01 0.01 0.01"/></body></worldbody>
      </mujoco>""")
    d = mujoco.MjData(m)
    d.qpos[:] = [0.3, 0.7]
    mujoco.mj_kinematics(m, d)
    pose = forward_kinematics(obj, {"slide_x": 0.3, "turn_z": 0.7})["body"]
    np.testing.assert_allclose(pose[:3, 3], d.xpos[1], atol=1e-7)
    np.testing.assert_allclose(pose[:3, :3], d.xmat[1].reshape(3, 3), atol=1e-7)


def test_usdphysics_probe_poses_stacked_joints_as_mujoco(tmp_path):
    """The UsdPhysics probe reads hinges stacked between two bodies (mujoco-usd-converter's
    form of an MJCF body of two joints) as MuJoCo applies them, in stage order, each about
    its own anchor: the body where MuJoCo puts it (the probe refused such a file as a
    kinematic loop); names as the source had them (usd-exchange's ``tn__`` decoded), so
    `check` of the file beside its exports compares them by name."""
    import mujoco

    from real2code_export.check import check_files
    from real2code_export.probes.usd import UsdProbe

    xml = _mujoco_stage(tmp_path / "arm.usda")
    probe = UsdProbe(tmp_path / "arm.usda")
    assert [j.name for j in probe.joints] == ["shoulder_x", "shoulder_z"]
    assert {"base", "upper_arm", "upper_arm_shoulder_x", "tip"} <= set(probe.parts)
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    anchor = tf.make(translation=[0.02, 0.0, 0.0])  # the part frame: the last joint's anchor
    rng = np.random.default_rng(3)
    for _ in range(10):
        q = rng.uniform(-1.5, 1.0, 2)
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        body = m.body("upper_arm").id
        expected = tf.make(d.xmat[body].reshape(3, 3), d.xpos[body]) @ anchor
        pose = probe.poses({"shoulder_x": q[0], "shoulder_z": q[1]})["upper_arm"]
        np.testing.assert_allclose(pose, expected, atol=1e-9)
    # beside its MJCF export (one body of two joints again, MuJoCo's actuators compiled
    # from the file's MjcActuator prims, which UsdPhysics does not read as drives): agrees
    written = export(usd.load(tmp_path / "arm.usda"), tmp_path / "out", formats=["mjcf"])
    report = check_files([tmp_path / "arm.usda", written["mjcf"]], n_configurations=5,
                         validate=False)
    assert report.ok, report.mismatches


def test_usdphysics_probe_holds_equal_limits_and_names_repeated_frames_apart(tmp_path):
    """Two links on hinges, each with an empty Xform (a frame) named ``tool``: the probe
    names the second ``tool_1`` in stage order, as the reader does (both were ``tool``, the
    second compared as the first); a hinge whose limits are equal (30 and 30 degrees:
    PhysX and Newton hold it there) is no joint of the probe, held at 30 degrees, as the
    reader reads it (a fixed joint): the file and its MJCF export agree."""
    from pxr import Gf, UsdGeom

    from real2code_export.check import check_files
    from real2code_export.probes.usd import UsdProbe

    path = tmp_path / "arm.usda"
    stage = _z_up_stage(path, "arm")
    for name in ("base", "link_a", "link_b"):
        _rigid_body(stage, f"/arm/{name}")
        cube = UsdGeom.Cube.Define(stage, f"/arm/{name}/box")
        cube.CreateSizeAttr(0.05)
        if name != "base":
            UsdGeom.Xform.Define(stage, f"/arm/{name}/tool").AddTranslateOp().Set(
                Gf.Vec3d(0.0, 0.0, 0.1))
    UsdPhysics.FixedJoint.Define(stage, "/arm/to_world").CreateBody1Rel().SetTargets(
        ["/arm/base"])
    for name, body0, body1, limits in (("hinge_a", "base", "link_a", (-45.0, 45.0)),
                                       ("held", "link_a", "link_b", (30.0, 30.0))):
        hinge = UsdPhysics.RevoluteJoint.Define(stage, f"/arm/{name}")
        hinge.CreateBody0Rel().SetTargets([f"/arm/{body0}"])
        hinge.CreateBody1Rel().SetTargets([f"/arm/{body1}"])
        hinge.CreateAxisAttr("Y")
        hinge.CreateLocalPos0Attr(Gf.Vec3f(0.0, 0.0, 0.2))
        hinge.CreateLowerLimitAttr(limits[0])
        hinge.CreateUpperLimitAttr(limits[1])
    stage.GetRootLayer().Save()
    probe = UsdProbe(path)
    assert [j.name for j in probe.joints] == ["hinge_a"]
    assert [p for p in probe.parts if p.startswith("tool")] == ["tool", "tool_1"]
    tool = probe.poses({"hinge_a": 0.0})["tool_1"]  # link_b turned 30 degrees about Y
    np.testing.assert_allclose(tool[:3, 3], [0.1 * math.sin(math.radians(30.0)), 0.0,
                                             0.4 + 0.1 * math.cos(math.radians(30.0))],
                               atol=1e-6)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        written = export(usd.load(path), tmp_path / "out", formats=["mjcf"])
    report = check_files([path, written["mjcf"]], n_configurations=5, validate=False)
    assert report.ok, report.mismatches


def test_usdphysics_probe_leaves_a_loop_closing_joint_beside_the_tree(tmp_path):
    """A four-bar whose file marks no joint out of the articulation: the probe closes the
    loop with the joint the reader keeps aside (the last met in stage order from the
    world) and poses the tree (it refused the file), so the file and its MJCF agree."""
    from pxr import Gf

    from real2code_export.check import check_files

    path = tmp_path / "fourbar.usda"
    stage = _fourbar_bodies(path)
    for name, body0, body1, pos0, pos1 in FOURBAR_HINGES:
        hinge = UsdPhysics.RevoluteJoint.Define(stage, f"/fourbar/{name}")
        hinge.CreateBody0Rel().SetTargets([f"/fourbar/{body0}"])
        hinge.CreateBody1Rel().SetTargets([f"/fourbar/{body1}"])
        hinge.CreateAxisAttr("Y")
        hinge.CreateLocalPos0Attr(Gf.Vec3f(*pos0))
        hinge.CreateLocalPos1Attr(Gf.Vec3f(*pos1))
    stage.GetRootLayer().Save()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        obj = usd.load(path)
        written = export(obj, tmp_path / "out", formats=["mjcf"])
    assert sorted(j.name for j in obj.movable_joints) == ["A", "B", "C"]  # D closes it
    report = check_files([path, written["mjcf"]], n_configurations=5, validate=False)
    assert report.ok, report.mismatches


def test_usdphysics_probe_names_two_robots_of_one_scene_apart(tmp_path):
    """A scene of two copies of one robot (the same body and joint names under two
    prims): the probe names the second copy's bodies and joints as the reader does
    (``link_1``, ``hinge_1``: it refused the file, "rigid body names are not unique"), its
    drives by the same names, so the file and its MJCF export agree."""
    from pxr import Gf

    from real2code_export.check import check_files

    path = tmp_path / "scene.usda"
    stage = _z_up_stage(path, "scene")
    for k, robot in enumerate(("robot_a", "robot_b")):
        for name in ("base", "link"):
            _rigid_body(stage, f"/scene/{robot}/{name}")
        fixed = UsdPhysics.FixedJoint.Define(stage, f"/scene/{robot}/to_world")
        fixed.CreateBody1Rel().SetTargets([f"/scene/{robot}/base"])
        fixed.CreateLocalPos0Attr(Gf.Vec3f(float(k), 0.0, 0.0))
        hinge = UsdPhysics.RevoluteJoint.Define(stage, f"/scene/{robot}/hinge")
        hinge.CreateBody0Rel().SetTargets([f"/scene/{robot}/base"])
        hinge.CreateBody1Rel().SetTargets([f"/scene/{robot}/link"])
        hinge.CreateAxisAttr("Z")
        hinge.CreateLocalPos0Attr(Gf.Vec3f(0.0, 0.0, 0.1))
        drive = UsdPhysics.DriveAPI.Apply(hinge.GetPrim(), "angular")
        drive.CreateStiffnessAttr(10.0 * (k + 1))
    stage.GetRootLayer().Save()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        obj = usd.load(path)
        written = export(obj, tmp_path / "out", formats=["mjcf"])
    assert sorted(j.name for j in obj.movable_joints) == ["hinge", "hinge_1"]
    report = check_files([path, written["mjcf"]], n_configurations=5, validate=False)
    assert report.ok, report.mismatches


def test_usdphysics_probe_drive_of_a_generic_joints_one_free_axis(tmp_path):
    """A generic joint (D6) leaving one rotation free, driven on that axis
    (``PhysicsDriveAPI:rotY``): the probe's joint is the prim's own name, and so is the
    drive's (it was ``<joint>_rotY``, a drive of no joint), so the file agrees with its MJCF
    export, whose actuator drives that joint."""
    from pxr import Gf

    from real2code_export.check import check_files

    path = tmp_path / "flap.usda"
    stage = _z_up_stage(path, "flap")
    for name in ("base", "lid"):
        _rigid_body(stage, f"/flap/{name}")
    UsdPhysics.FixedJoint.Define(stage, "/flap/to_world").CreateBody1Rel().SetTargets(
        ["/flap/base"])
    joint = UsdPhysics.Joint.Define(stage, "/flap/hinge")
    joint.CreateBody0Rel().SetTargets(["/flap/base"])
    joint.CreateBody1Rel().SetTargets(["/flap/lid"])
    joint.CreateLocalPos0Attr(Gf.Vec3f(0.0, 0.0, 0.2))
    for axis in ("transX", "transY", "transZ", "rotX", "rotZ"):
        limit = UsdPhysics.LimitAPI.Apply(joint.GetPrim(), axis)
        limit.CreateLowAttr(1.0)
        limit.CreateHighAttr(-1.0)
    limit = UsdPhysics.LimitAPI.Apply(joint.GetPrim(), "rotY")
    limit.CreateLowAttr(-30.0)
    limit.CreateHighAttr(60.0)
    drive = UsdPhysics.DriveAPI.Apply(joint.GetPrim(), "rotY")
    drive.CreateStiffnessAttr(5.0)
    drive.CreateDampingAttr(0.5)
    stage.GetRootLayer().Save()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        obj = usd.load(path)
        written = export(obj, tmp_path / "out", formats=["mjcf"])
    assert obj.joint("hinge").drive is not None
    report = check_files([path, written["mjcf"]], n_configurations=5, validate=False)
    assert report.ok, report.mismatches


def test_usdphysics_probe_free_body_stands_at_its_frame_without_its_scale(tmp_path):
    """A lone rigid body scaled by its prim (0.2) and turned 30 degrees: the probe poses it
    at the prim's frame as a rotation (it held the scale, 1.02 rad off its MJCF export)."""
    from pxr import Gf, UsdGeom

    from real2code_export.probes.usd import UsdProbe

    path = tmp_path / "cube.usda"
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    body = UsdGeom.Xform.Define(stage, "/cube")
    stage.SetDefaultPrim(body.GetPrim())
    body.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 1.0))
    body.AddRotateZOp().Set(30.0)
    body.AddScaleOp().Set(Gf.Vec3d(0.2, 0.2, 0.2))
    UsdPhysics.RigidBodyAPI.Apply(body.GetPrim())
    stage.GetRootLayer().Save()
    pose = UsdProbe(path).poses({})["cube"]
    np.testing.assert_allclose(pose, tf.make(tf.axis_angle_matrix(
        [0.0, 0.0, 1.0], math.radians(30.0)), [0.0, 0.0, 1.0]), atol=1e-9)


def test_a_mimic_reads_back_where_newtons_schema_registers_late(tmp_path):
    """NewtonMimicAPI read from the composed list of applied schemas, not UsdPrim's
    GetAppliedSchemas(), which leaves out a schema registered after the process's first
    stage (newton-usd-schemas imported late: a mimic was lost in the USD export's read back,
    in a process that had opened a stage before, as the test suite's order showed). Run in a
    process of its own, which opens a stage before anything imports the schema."""
    import subprocess
    import sys
    from pathlib import Path

    script = f"""
from pxr import Usd
Usd.Stage.CreateInMemory().DefinePrim("/first", "Xform")  # the schema registry is built
from real2code_export.formats import export, urdf, usd
obj = urdf.load({str(Path(__file__).parent / "fixtures" / "urdf" / "mimic_gripper.urdf")!r})
path = export(obj, {str(tmp_path)!r}, formats=["usd"])["usd"]
mimic = usd.load(path).joint("right_finger").mimic
print(None if mimic is None else (mimic.joint, mimic.multiplier))
"""
    done = subprocess.run([sys.executable, "-W", "ignore", "-c", script], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "('left_finger', -1.0)", done.stdout
