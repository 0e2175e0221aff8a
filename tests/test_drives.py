"""Joint drives (model.Drive): MJCF actuators and USD PhysicsDriveAPI drives of the model's
three laws read into the model, written to every format and read back; what is not one of
them kept as before; and the same drive holding a joint at its target in MuJoCo (from the
MJCF) and in PhysX and Newton (from the USD), where those engines are installed."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from real2code_export.errors import ModelError
from real2code_export.formats import export, load
from real2code_export.model import (
    ArticulatedObject,
    Drive,
    DriveKind,
    Inertial,
    Joint,
    JointType,
    Limits,
    Part,
    differences,
    validate,
)

ARM = """<mujoco model="arm">
  <default><default class="big"><position kp="50" forcerange="-20 20"/></default></default>
  <worldbody>
    <body name="base">
      <geom type="box" size="0.1 0.1 0.05"/>
      <body name="upper" pos="0 0 0.1">
        <joint name="shoulder" axis="0 1 0" range="-2 2" damping="0.1"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
        <body name="fore" pos="0.3 0 0">
          <joint name="elbow" axis="0 1 0" range="-2 2"/>
          <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.025"/>
          <body name="hand" pos="0.3 0 0">
            <joint name="wrist" axis="1 0 0"/>
            <geom type="sphere" size="0.04"/>
            <body name="finger" pos="0.05 0 0">
              <joint name="slide" type="slide" axis="1 0 0" range="0 0.05"/>
              <geom type="box" size="0.01 0.01 0.01"/>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <tendon><fixed name="t"><joint joint="slide" coef="1"/></fixed></tendon>
  <actuator>
    <position name="a_shoulder" class="big" joint="shoulder" ctrlrange="-1.5 1.5"/>
    <motor name="a_tendon" tendon="t" gear="2"/>
    <velocity name="a_elbow" joint="elbow" kv="3" gear="2" ctrlrange="-1 1"/>
    <motor name="a_wrist" joint="wrist" gear="5" ctrlrange="-1 1" forcerange="-3 3"/>
    <general name="a_slide" joint="slide" gainprm="100" biasprm="0 -100 -5" biastype="affine"/>
    <general name="a_filtered" joint="elbow" dyntype="filter" dynprm="0.1"/>
  </actuator>
</mujoco>
"""


def _load(path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        obj = load(path)
    return obj, "\n".join(str(w.message) for w in caught)


@pytest.fixture
def arm(tmp_path):
    path = tmp_path / "arm.xml"
    path.write_text(ARM)
    return path


def test_mjcf_actuators_of_the_three_laws_are_drives(arm):
    """<position> (from its class), <velocity>, <motor> and a <general> of the position form
    on one joint are the joints' drives, the gear folded in (stiffness and damping times
    gear^2, the target and its range over the gear, the force limit times the gear); the
    tendon's motor and a filtered actuator stay kept MJCF, named in a warning, the drives'
    places marked among them (the order is the ctrl index)."""
    obj, said = _load(arm)
    d = {j.name: j.drive for j in obj.joints if j.drive is not None}
    assert not d["shoulder"].differences(Drive(DriveKind.POSITION, 50.0, 0.0, force_limit=20.0,
                                               target_range=(-1.5, 1.5), name="a_shoulder"), 0)
    assert not d["elbow"].differences(Drive(DriveKind.VELOCITY, 0.0, 12.0,
                                            target_range=(-0.5, 0.5), name="a_elbow", gear=2.0), 0)
    assert not d["wrist"].differences(Drive(DriveKind.EFFORT, force_limit=15.0,
                                            target_range=(-0.2, 0.2), name="a_wrist", gear=5.0), 0)
    assert not d["slide"].differences(Drive(DriveKind.POSITION, 100.0, 5.0, name="a_slide"), 0)
    kept = obj.metadata["mjcf_elements"]["actuator"]
    order = [kept.index(s) for s in ("real2code:drive shoulder", 'name="a_tendon"',
                                     "real2code:drive elbow", "real2code:drive wrist",
                                     "real2code:drive slide", 'name="a_filtered"')]
    assert order == sorted(order)
    assert "'a_tendon' (not a joint transmission)" in said
    assert "'a_filtered' (activation dynamics)" in said


def test_mjcf_round_trip_keeps_actuator_names_order_and_ranges(arm, tmp_path):
    """MJCF -> model -> MJCF: MuJoCo compiles the same actuators, in the same order (ctrl
    indices), with the same names, gains, biases, gears, ctrl and force ranges; a second
    export is byte-identical."""
    import mujoco

    obj, _ = _load(arm)
    first = export(obj, tmp_path / "one", ["mjcf"])["mjcf"]
    back, _ = _load(first)
    assert not differences(obj, back)
    second = export(back, tmp_path / "two", ["mjcf"])["mjcf"]
    assert first.read_bytes() == second.read_bytes()
    a, b = mujoco.MjModel.from_xml_path(str(arm)), mujoco.MjModel.from_xml_path(str(first))
    assert [a.actuator(i).name for i in range(a.nu)] == [b.actuator(i).name for i in range(b.nu)]
    for field in ("actuator_gainprm", "actuator_biasprm", "actuator_gear", "actuator_ctrlrange",
                  "actuator_forcerange", "actuator_ctrllimited", "actuator_forcelimited",
                  "actuator_dyntype", "actuator_trntype"):
        np.testing.assert_allclose(getattr(a, field), getattr(b, field), err_msg=field)


def test_drives_in_every_format_read_back_the_same(arm, tmp_path):
    """Every format carries the drives (URDF as <real2code:drive>, glTF and object.json in
    their joint data, USD as PhysicsDriveAPI: angular gains per degree, targets in degrees),
    and each reads them back within the model's tolerance."""
    from pxr import Usd

    obj, _ = _load(arm)
    obj.joint("shoulder").drive.target = 0.4
    obj.joint("slide").drive.target = 0.02
    obj.joint("wrist").drive.target = 0.1  # an effort: our USD attribute
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        written = export(obj, tmp_path / "out", ["json", "mjcf", "urdf", "usd", "gltf"])
    said = "\n".join(str(w.message) for w in caught)
    assert "URDF: 'arm': joint drives (actuators) have no place in URDF" in said
    assert "glTF: 'arm': joint drives (actuators) kept in the joints' extras only" in said
    for fmt, path in written.items():
        back, _ = _load(path)
        assert not [x for x in differences(obj, back) if "drive" in x], fmt
    # the USD's float32 read as the shortest decimal it rounds: kp="50" comes back 50
    drive = _load(written["usd"])[0].joint("shoulder").drive
    assert (drive.stiffness, drive.target) == (50.0, 0.4)
    stage = Usd.Stage.Open(str(written["usd"]))
    shoulder = next(p for p in stage.Traverse() if p.GetName() == "shoulder")
    get = shoulder.GetAttribute
    assert get("drive:angular:physics:stiffness").Get() == pytest.approx(50 * math.pi / 180)
    assert get("drive:angular:physics:targetPosition").Get() == pytest.approx(math.degrees(0.4))
    assert get("drive:angular:physics:maxForce").Get() == pytest.approx(20.0)
    slide = next(p for p in stage.Traverse() if p.GetName() == "slide")
    assert slide.GetAttribute("drive:linear:physics:stiffness").Get() == pytest.approx(100.0)


def test_model_refuses_drives_that_are_not_their_kind():
    def arm(drive, kind=JointType.REVOLUTE):
        return ArticulatedObject("a", [Part("base"), Part("link", inertial=Inertial(1.0))], [
            Joint("hinge", kind, "base", "link",
                  limits=Limits(-1, 1) if kind is JointType.REVOLUTE else None, drive=drive)])

    validate(arm(Drive(DriveKind.POSITION, 10.0, 1.0)))
    for drive, kind, message in (
            (Drive(DriveKind.POSITION, 0.0, 1.0), JointType.REVOLUTE, "needs a stiffness"),
            (Drive(DriveKind.EFFORT, 0.0, 1.0), JointType.REVOLUTE, "no stiffness nor damping"),
            (Drive(DriveKind.VELOCITY, 0.0, 1.0, force_limit=0.0), JointType.REVOLUTE,
             "force limit must be > 0"),
            (Drive(DriveKind.VELOCITY, 0.0, 1.0), JointType.FIXED, "takes no drive")):
        with pytest.raises(ModelError, match=f"joint 'hinge'.*{message}"):
            validate(arm(drive, kind))


# -- the same drive in the engines ------------------------------------------------------------
TARGET = 0.6  # rad
STIFFNESS, DAMPING = 40.0, 4.0  # N m / rad, N m s / rad


def _pendulum() -> ArticulatedObject:
    """A 1 kg rod 0.4 m long on a horizontal hinge, driven to TARGET: gravity holds it below
    the target by about m g l/2 cos(q) / stiffness."""
    from real2code_export.model import Mesh
    from real2code_export.primitives import Primitive

    rod = Mesh.of_primitive(Primitive("box", [0.2, 0.02, 0.02],
                                      np.array([[1, 0, 0, 0.2], [0, 1, 0, 0], [0, 0, 1, 0],
                                                [0, 0, 0, 1.0]])))
    inertia = np.diag([1e-4, 1 / 12 * 0.4**2, 1 / 12 * 0.4**2])
    origin = np.eye(4)
    origin[2, 3] = 1.0
    return ArticulatedObject("pendulum", [
        Part("base"),
        Part("rod", visual=rod, collision=[rod], inertial=Inertial(1.0, [0.2, 0, 0], inertia))],
        [Joint("hinge", JointType.REVOLUTE, "base", "rod", origin=origin, axis=[0, -1, 0],
               limits=Limits(-3.0, 3.0),
               drive=Drive(DriveKind.POSITION, STIFFNESS, DAMPING, TARGET, name="hold"))])


def _mujoco_hold(path, experiment) -> float:
    """The hinge's angle after the experiment in MuJoCo, the actuator's ctrl its target (what
    a MuJoCo user sets: ctrl = gear * target)."""
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(path))
    model.opt.timestep = experiment.dt
    data = mujoco.MjData(model)
    data.ctrl[model.actuator("hold").id] = TARGET
    for _ in range(experiment.steps):
        mujoco.mj_step(model, data)
    return float(data.qpos[model.joint("hinge").qposadr[0]])


@pytest.fixture(scope="module")
def held(tmp_path_factory):
    from real2code_export.dynamics import Experiment

    obj = _pendulum()
    written = export(obj, tmp_path_factory.mktemp("held"), ["mjcf", "usd"])
    experiment = Experiment("hold", ("hinge",), (True,), (0.0,), (0.0,), dt=1e-3,
                            duration=3.0, sample_every=100)
    return written, experiment, _mujoco_hold(written["mjcf"], experiment)


def _equilibrium() -> float:
    """q with STIFFNESS (TARGET - q) = m g l/2 cos(q), the rod raised by q about -y."""
    from scipy.optimize import brentq

    return brentq(lambda q: STIFFNESS * (TARGET - q) - 9.81 * 0.2 * math.cos(q), -1.0, 1.0)


def test_mujoco_holds_the_driven_joint_where_the_drive_says(held):
    _, _, angle = held
    assert angle == pytest.approx(_equilibrium(), abs=1e-3)


@pytest.mark.parametrize("engine", ["physx", "newton"])
def test_physx_and_newton_hold_the_usd_drive_as_mujoco_holds_the_mjcf(held, engine):
    """The USD's drive (gains per degree, target in degrees) holds the joint where MuJoCo's
    actuator holds the MJCF's: both at the balance of the drive and gravity."""
    import importlib

    from real2code_export.dynamics import EngineUnavailable

    written, experiment, reference = held
    module = importlib.import_module(f"real2code_export.dynamics.{engine}")
    try:
        trajectory = module.simulate(written["usd"], experiment)
    except EngineUnavailable as e:
        pytest.skip(str(e))
    assert float(trajectory.q[-1, 0]) == pytest.approx(reference, abs=1e-4)


def test_check_compares_drives_between_exports_and_with_the_source(arm, tmp_path):
    """``check`` reads each file's drives in its own tool (MuJoCo's compiled actuators,
    UsdPhysics' drives) and compares them with the source's: equal after an export; a
    drive whose gain changed in the USD is a mismatch naming the joint."""
    from pxr import Usd

    from real2code_export.check import check_files

    obj, _ = _load(arm)
    written = export(obj, tmp_path / "out", ["mjcf", "usd"])
    files = list(written.values())
    report = check_files(files, source=arm, n_configurations=3, validate=False, warned=[])
    assert not [m for m in report.mismatches if m.kind == "drive"], report.mismatches
    stage = Usd.Stage.Open(str(written["usd"]))
    elbow = next(p for p in stage.Traverse() if p.GetName() == "elbow")
    elbow.GetAttribute("drive:angular:physics:damping").Set(1.0)
    stage.GetRootLayer().Save()
    report = check_files(files, source=arm, n_configurations=3, validate=False, warned=[])
    (drive,) = [m for m in report.mismatches if m.kind == "drive"]
    assert drive.name == "elbow" and "damping 12.0 !=" in drive.message, drive.message
    assert not report.ok


def test_mjcf_drives_out_of_joint_order_keep_their_order(tmp_path):
    """Actuators that are all drives, listed in another order than their joints: their
    places are marked, so the MJCF export lists them as the file did (ctrl indices); in
    joint order, nothing is kept."""
    import mujoco

    body = ('<body name="b{k}" pos="0.1 0 0"><joint name="j{k}" axis="0 1 0"/>'
            '<geom type="sphere" size="0.02"/>')
    tree = "".join(body.format(k=k) for k in range(3)) + "</body>" * 3
    for order, kept in (((2, 0, 1), True), ((0, 1, 2), False)):
        motors = "".join(f'<motor name="m{k}" joint="j{k}"/>' for k in order)
        path = tmp_path / f"chain{''.join(map(str, order))}.xml"
        path.write_text(f'<mujoco><worldbody>{tree}</worldbody><actuator>{motors}</actuator>'
                        '</mujoco>')
        obj, _ = _load(path)
        assert ("mjcf_elements" in obj.metadata) == kept
        out = export(obj, tmp_path / path.stem, ["mjcf"])["mjcf"]
        model = mujoco.MjModel.from_xml_path(str(out))
        assert [model.actuator(i).name for i in range(model.nu)] == [f"m{k}" for k in order]


def test_a_drive_that_is_not_its_kind_is_refused_naming_file_and_joint(arm, tmp_path):
    """object.json and URDF: a drive that is not one of the model's laws is refused with the
    file and the joint."""
    import json

    from real2code_export.errors import FormatError

    obj, _ = _load(arm)
    written = export(obj, tmp_path / "out", ["json", "urdf"])
    doc = json.loads(written["json"].read_text())
    joint = next(j for j in doc["joints"] if j["name"] == "elbow")
    joint["drive"]["stiffness"] = 5.0  # a velocity drive with a stiffness
    written["json"].write_text(json.dumps(doc))
    with pytest.raises(FormatError, match=r"object.json.*joint 'elbow' drive.*velocity drive"):
        load(written["json"])
    text = written["urdf"].read_text().replace('kind="velocity"', 'kind="torque"')
    written["urdf"].write_text(text)
    with pytest.raises(FormatError, match=r"arm.urdf.*joint name='elbow'.*kind 'torque'"):
        _load(written["urdf"])
