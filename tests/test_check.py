"""``real2code check``: files loaded in MuJoCo and Pinocchio, posed by joint name, compared.

The cabinet below is written by hand three times (object.json through the model, URDF and
MJCF text), so the check is tested against tools, not against our own exporters. Planted
errors are made by editing one line of one file.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from real2code_export import transforms as tf
from real2code_export.check import check_files, format_table, rotation_angles
from real2code_export.errors import CheckError
from real2code_export.formats import object_json
from real2code_export.model import (
    ArticulatedObject,
    Inertial,
    Joint,
    Limits,
    Part,
    forward_kinematics,
)
from real2code_export.probes import open_probes

from conftest import partnet_objects
from helpers import small_cabinet

# Joints declared child-first and out of tree order: Pinocchio reorders them depth first.
URDF = """<?xml version="1.0"?>
<robot name="cabinet">
  <link name="body"><inertial><origin xyz="0 0 0.4"/><mass value="10"/>
    <inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="knob"><inertial><mass value="0.05"/>
    <inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="door"><inertial><mass value="2"/>
    <inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="handle"/>
  <link name="drawer"><inertial><mass value="1.5"/>
    <inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="top"/>
  <joint name="knob_turn" type="continuous">
    <parent link="door"/><child link="knob"/>
    <origin xyz="0.02 0.25 0.1" rpy="0.3 -0.2 0.5"/><axis xyz="1 0 0"/>
  </joint>
  <joint name="handle_mount" type="fixed">
    <parent link="drawer"/><child link="handle"/><origin xyz="0.22 0 0" rpy="0.1 0.2 0.3"/>
  </joint>
  <joint name="drawer_slide" type="prismatic">
    <parent link="body"/><child link="drawer"/>
    <origin xyz="0.05 0.1 0.2" rpy="0 0 0.3"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.35" effort="10" velocity="1"/>
  </joint>
  <joint name="door_hinge" type="revolute">
    <parent link="body"/><child link="door"/>
    <origin xyz="0.25 -0.3 0.4" rpy="0 0 0.1"/><axis xyz="0 0.1 1"/>
    <limit lower="0" upper="1.6" effort="10" velocity="1"/>
  </joint>
  <joint name="top_mount" type="fixed">
    <parent link="body"/><child link="top"/><origin xyz="0 0 0.8"/>
  </joint>
</robot>
"""

# The same cabinet nested as MJCF, drawer before door; eulerseq XYZ (extrinsic) is URDF's rpy.
MJCF = """<mujoco model="cabinet">
  <compiler angle="radian" eulerseq="XYZ"/>
  <worldbody>
    <body name="body">
      <inertial pos="0 0 0.4" mass="10" diaginertia="1 1 1"/>
      <body name="top" pos="0 0 0.8"/>
      <body name="drawer" pos="0.05 0.1 0.2" euler="0 0 0.3">
        <joint name="drawer_slide" type="slide" axis="1 0 0" range="0 0.35"/>
        <inertial pos="0 0 0" mass="1.5" diaginertia="0.1 0.1 0.1"/>
        <body name="handle" pos="0.22 0 0" euler="0.1 0.2 0.3"/>
      </body>
      <body name="door" pos="0.25 -0.3 0.4" euler="0 0 0.1">
        <joint name="door_hinge" type="hinge" axis="0 0.1 1" range="0 1.6"/>
        <inertial pos="0 0 0" mass="2" diaginertia="0.1 0.1 0.1"/>
        <body name="knob" pos="0.02 0.25 0.1" euler="0.3 -0.2 0.5">
          <joint name="knob_turn" type="hinge" axis="1 0 0"/>
          <inertial pos="0 0 0" mass="0.05" diaginertia="1e-4 1e-4 1e-4"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

STATE = {"door_hinge": 0.4, "drawer_slide": 0.12, "knob_turn": -0.7}
LABELS = ["model (object.json)", "MuJoCo (MJCF)", "MuJoCo (URDF)", "Pinocchio (URDF)"]


def cabinet_model() -> ArticulatedObject:
    def pose(xyz, rpy=(0, 0, 0)):
        return tf.make(tf.rpy_to_matrix(rpy), xyz)

    mass = {"body": 10.0, "knob": 0.05, "door": 2.0, "drawer": 1.5}
    parts = [Part(n, inertial=Inertial(mass[n]) if n in mass else None)
             for n in ("body", "door", "knob", "drawer", "handle", "top")]
    hinge_axis = np.array([0.0, 0.1, 1.0]) / math.sqrt(1.01)
    joints = [
        Joint("door_hinge", "revolute", "body", "door", pose([0.25, -0.3, 0.4], [0, 0, 0.1]),
              hinge_axis, Limits(0.0, 1.6), state=STATE["door_hinge"]),
        Joint("knob_turn", "continuous", "door", "knob",
              pose([0.02, 0.25, 0.1], [0.3, -0.2, 0.5]), [1, 0, 0], state=STATE["knob_turn"]),
        Joint("drawer_slide", "prismatic", "body", "drawer", pose([0.05, 0.1, 0.2], [0, 0, 0.3]), [1, 0, 0],
              Limits(0.0, 0.35), state=STATE["drawer_slide"]),
        Joint("handle_mount", "fixed", "drawer", "handle", pose([0.22, 0, 0], [0.1, 0.2, 0.3])),
        Joint("top_mount", "fixed", "body", "top", pose([0, 0, 0.8])),
    ]
    return ArticulatedObject("cabinet", parts, joints)


def write_files(tmp_path, urdf=URDF, mjcf=MJCF):
    json_path = object_json.save(cabinet_model(), tmp_path / "model")
    (tmp_path / "cabinet.urdf").write_text(urdf)
    (tmp_path / "cabinet.xml").write_text(mjcf)
    return [json_path, tmp_path / "cabinet.xml", tmp_path / "cabinet.urdf"]


def plant(text: str, old: str, new: str) -> str:
    assert text.count(old) == 1, f"{old!r} must occur once"
    return text.replace(old, new)


# -- agreement -------------------------------------------------------------------------------
def test_consistent_files_agree(tmp_path):
    report = check_files(write_files(tmp_path), n_configurations=100, seed=3)
    assert report.ok, format_table(report)
    assert [p.label for p in report.probes] == LABELS
    assert report.reference.startswith("model (object.json)")
    assert len(report.configurations) == 100
    assert report.configurations[0] == {"door_hinge": 0.0, "knob_turn": 0.0, "drawer_slide": 0.0}
    assert report.configurations[1] == STATE
    for p in report.probes:
        assert sorted(p.parts) == ["body", "door", "drawer", "handle", "knob", "top"], p.label
        assert sorted(j.name for j in p.joints) == ["door_hinge", "drawer_slide", "knob_turn"]
    # Three tools agree to float rounding, not merely within the tolerance.
    assert report.max_position_error < 1e-12
    assert report.max_rotation_error < 1e-12
    table = format_table(report)
    assert "AGREE" in table and "DISAGREE" not in table
    assert all(label in table for label in LABELS)
    data = json.loads(json.dumps(report.to_json()))
    assert data["ok"] is True and data["mismatches"] == []
    assert {"files", "probes", "configurations", "tolerance", "max_position_error",
            "max_rotation_error", "parts", "mismatches", "ok"} <= set(data)
    assert data["tolerance"] == {"position": 1e-6, "rotation": 1e-6}
    assert len(data["parts"]) == 6


def test_configurations_stay_within_agreed_limits(tmp_path):
    report = check_files(write_files(tmp_path), n_configurations=200, seed=1)
    values = {name: np.array([c[name] for c in report.configurations[2:]])
              for name in STATE}
    assert values["door_hinge"].min() >= 0.0 and values["door_hinge"].max() <= 1.6
    assert values["drawer_slide"].min() >= 0.0 and values["drawer_slide"].max() <= 0.35
    # continuous: the whole turn, both signs
    assert values["knob_turn"].min() < -2.5 and values["knob_turn"].max() > 2.5
    assert values["knob_turn"].min() >= -math.pi and values["knob_turn"].max() <= math.pi
    again = check_files(write_files(tmp_path), n_configurations=200, seed=1)
    assert again.configurations == report.configurations  # seeded: reproducible


def test_limits_that_differ_are_sampled_where_all_agree(tmp_path):
    mjcf = plant(MJCF, 'range="0 0.35"', 'range="0.05 0.4"')
    report = check_files(write_files(tmp_path, mjcf=mjcf), n_configurations=100)
    assert [m.kind for m in report.mismatches] == ["joint_limits"]  # only that: poses agree
    slide = np.array([c["drawer_slide"] for c in report.configurations[2:]])
    assert slide.min() >= 0.05 and slide.max() <= 0.35


def test_urdf_fixed_links_are_parts_in_mujoco_and_pinocchio(tmp_path):
    urdf = tmp_path / "cabinet.urdf"
    urdf.write_text(URDF)
    mujoco_probe, pinocchio_probe = open_probes(urdf)
    assert (mujoco_probe.label, pinocchio_probe.label) == ("MuJoCo (URDF)", "Pinocchio (URDF)")
    for probe in (mujoco_probe, pinocchio_probe):
        assert {"handle", "top", "body"} <= set(probe.parts), probe.label
        assert "handle_mount" not in {j.name for j in probe.joints}
    # the fixed links move with their parent: the handle rides on the drawer
    for probe in (mujoco_probe, pinocchio_probe):
        shut, open_ = probe.poses({}), probe.poses({"drawer_slide": 0.3})
        slide_direction = tf.rpy_to_matrix([0, 0, 0.3]) @ [1.0, 0.0, 0.0]
        np.testing.assert_allclose(open_["handle"][:3, 3] - shut["handle"][:3, 3],
                                   0.3 * slide_direction, atol=1e-12)
        np.testing.assert_allclose(open_["top"], shut["top"], atol=1e-15)


def test_pinocchio_depth_first_order_does_not_matter(tmp_path):
    urdf = tmp_path / "cabinet.urdf"
    urdf.write_text(URDF)
    pinocchio_probe = open_probes(urdf)[1]
    order = [j.name for j in pinocchio_probe.joints]
    declared = ["knob_turn", "drawer_slide", "door_hinge"]
    assert sorted(order) == sorted(declared)
    assert order != declared  # Pinocchio did reorder: the test exercises mapping by name
    assert order.index("door_hinge") < order.index("knob_turn")  # parent before child
    report = check_files(write_files(tmp_path), n_configurations=50)
    assert report.ok, format_table(report)


def test_joints_map_by_name_not_order(tmp_path):
    probes = [p for path in write_files(tmp_path) for p in open_probes(path)]
    orders = {tuple(j.name for j in p.joints) for p in probes}
    assert len(orders) > 1  # the tools list the same joints in different orders
    q = {"knob_turn": 1.0, "door_hinge": 0.5}  # any order; the drawer stays at 0
    expected = forward_kinematics(cabinet_model(), q)
    for p in probes:
        poses = p.poses(q)
        for part, pose in expected.items():
            np.testing.assert_allclose(poses[part], pose, atol=1e-12, err_msg=f"{p.label} {part}")


def test_continuous_joint_in_every_tool(tmp_path):
    probes = [p for path in write_files(tmp_path) for p in open_probes(path)]
    for p in probes:
        knob = next(j for j in p.joints if j.name == "knob_turn")
        assert (knob.kind, knob.lower, knob.upper) == ("continuous", None, None), p.label
    # beyond one turn: Pinocchio's (cos, sin) coordinates and MuJoCo's angle agree
    expected = forward_kinematics(cabinet_model(), {"knob_turn": 4.0})["knob"]
    for p in probes:
        np.testing.assert_allclose(p.poses({"knob_turn": 4.0})["knob"], expected, atol=1e-12)


ODD_AXES_URDF = """<?xml version="1.0"?>
<robot name="odd">
  <link name="world"/>
  <link name="base"/>
  <link name="a"><inertial><mass value="1"/>
    <inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="b"><inertial><mass value="1"/>
    <inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="c"><inertial><mass value="1"/>
    <inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="anchor" type="fixed"><parent link="world"/><child link="base"/>
    <origin xyz="0 0 1" rpy="0 0.5 0"/></joint>
  <joint name="spin" type="continuous"><parent link="base"/><child link="a"/>
    <origin xyz="0.1 0 0"/><axis xyz="0.6 0 0.8"/></joint>
  <joint name="push" type="prismatic"><parent link="a"/><child link="b"/>
    <origin xyz="0 0.2 0" rpy="0.3 0 0"/><axis xyz="0 0 -2"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="tilt" type="revolute"><parent link="b"/><child link="c"/>
    <axis xyz="0 0.70710678 0.70710678"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
"""


def test_unaligned_and_non_unit_axes_and_a_world_link(tmp_path):
    """Axes off the coordinate axes (Pinocchio's *Unaligned joints) and not of unit length
    (normalised by both tools); a link named world (MuJoCo merges it into its world body)."""
    urdf = tmp_path / "odd.urdf"
    urdf.write_text(ODD_AXES_URDF)
    report = check_files([urdf], n_configurations=100)
    assert report.ok, format_table(report)
    for p in report.probes:
        assert sorted(p.parts) == ["a", "b", "base", "c", "world"], p.label
    pin_probe = report.probes[1]
    assert {j.name: j.kind for j in pin_probe.joints} == {
        "spin": "continuous", "push": "prismatic", "tilt": "revolute"}
    # the prismatic axis is normalised: 0.5 of travel moves the part 0.5 m
    probe = open_probes(urdf)[1]
    moved = probe.poses({"push": 0.5})["b"][:3, 3] - probe.poses({})["b"][:3, 3]
    assert np.linalg.norm(moved) == pytest.approx(0.5, abs=1e-12)


# -- planted errors --------------------------------------------------------------------------
PLANTED = {
    # name: (file, old text, new text, mismatch kind, joint/part named, probes that disagree)
    "door origin 1 mm off": (
        "urdf", 'xyz="0.25 -0.3 0.4"', 'xyz="0.251 -0.3 0.4"', "pose", "door",
        {"MuJoCo (URDF)", "Pinocchio (URDF)"}),
    "door origin 10 um off": (
        "urdf", 'xyz="0.25 -0.3 0.4"', 'xyz="0.25001 -0.3 0.4"', "pose", "door",
        {"MuJoCo (URDF)", "Pinocchio (URDF)"}),
    "hinge axis sign flipped": (
        "mjcf", 'axis="0 0.1 1"', 'axis="0 -0.1 -1"', "pose", "door", {"MuJoCo (MJCF)"}),
    "continuous axis sign flipped": (
        "urdf", '<axis xyz="1 0 0"/>\n  </joint>\n  <joint name="handle_mount"',
        '<axis xyz="-1 0 0"/>\n  </joint>\n  <joint name="handle_mount"', "pose", "knob",
        {"MuJoCo (URDF)", "Pinocchio (URDF)"}),
    "joint renamed": (
        "urdf", 'joint name="door_hinge"', 'joint name="door_joint"', "missing_joint",
        "door_hinge", {"MuJoCo (URDF)", "Pinocchio (URDF)"}),
    "part missing": (
        "mjcf", '<body name="top" pos="0 0 0.8"/>', "", "missing_part", "top",
        {"MuJoCo (MJCF)"}),
    "part renamed": (
        "mjcf", 'body name="handle"', 'body name="grip"', "missing_part", "handle",
        {"MuJoCo (MJCF)"}),
    "limit differs": (
        "mjcf", 'range="0 0.35"', 'range="0 0.36"', "joint_limits", "drawer_slide",
        {"MuJoCo (MJCF)"}),
    "kind differs": (
        "urdf", 'name="knob_turn" type="continuous"', 'name="knob_turn" type="revolute"',
        "joint_kind", "knob_turn", {"MuJoCo (URDF)", "Pinocchio (URDF)"}),
}


@pytest.mark.parametrize("case", list(PLANTED))
def test_planted_error_is_detected_and_named(tmp_path, case):
    which, old, new, kind, name, culprits = PLANTED[case]
    urdf, mjcf = URDF, MJCF
    if which == "urdf":
        urdf = plant(URDF, old, new)
        if kind == "joint_kind":  # a revolute joint needs limits to load at all
            urdf = plant(urdf, '<axis xyz="1 0 0"/>\n  </joint>\n  <joint name="handle_mount"',
                         '<axis xyz="1 0 0"/><limit lower="-3" upper="3" effort="1" '
                         'velocity="1"/>\n  </joint>\n  <joint name="handle_mount"')
    else:
        mjcf = plant(MJCF, old, new)
    report = check_files(write_files(tmp_path, urdf, mjcf), n_configurations=100)

    assert not report.ok  # the CLI exits 1
    named = [m for m in report.mismatches if m.kind == kind and m.name == name]
    assert {m.probe.rsplit(" ", 1)[0] for m in named} == culprits, report.mismatches
    flagged = set(culprits)
    if kind == "missing_joint":  # a rename: the others lack the new name
        flagged |= {"model (object.json)", "MuJoCo (MJCF)"}
        assert {m.probe.rsplit(" ", 1)[0] for m in report.mismatches
                if m.kind == kind and m.name == "door_joint"} == set(LABELS) - culprits
    assert {p.label for p in report.probes if not p.ok} == flagged
    table = format_table(report)
    assert "DISAGREE" in table and f"{name!r}" in table
    data = report.to_json()
    assert data["ok"] is False
    assert any(m["kind"] == kind and m["name"] == name for m in data["mismatches"])
    if kind == "pose":  # the error is measured, not just flagged
        worst = next(p for p in data["parts"] if p["part"] == name)
        by = "position" if worst["position_error"] > worst["rotation_error"] else "rotation"
        assert worst[f"{by}_error"] > 1e-6
        assert worst[f"{by}_probe"].rsplit(" ", 1)[0] in culprits


def test_one_millimetre_is_measured_as_one_millimetre(tmp_path):
    urdf = plant(URDF, 'xyz="0.25 -0.3 0.4"', 'xyz="0.251 -0.3 0.4"')
    report = check_files(write_files(tmp_path, urdf=urdf), n_configurations=20)
    by_label = {p.label: p for p in report.probes}
    for label in ("MuJoCo (URDF)", "Pinocchio (URDF)"):
        # the hinge origin moves the door, and the knob on it, by exactly 1 mm
        assert by_label[label].max_position_error == pytest.approx(1e-3, rel=1e-9)
        assert by_label[label].max_rotation_error < 1e-12
    assert by_label["MuJoCo (MJCF)"].max_position_error < 1e-12


# -- refusals, reference, helpers ------------------------------------------------------------
def test_file_mujoco_refuses_names_file_and_reason(tmp_path):
    bad = tmp_path / "bad.xml"
    bad.write_text(plant(MJCF, '<inertial pos="0 0 0" mass="1.5" diaginertia="0.1 0.1 0.1"/>',
                         ""))
    with pytest.raises(CheckError, match=r"bad\.xml: MuJoCo refused it: .*mass"):
        check_files([bad])


def test_file_pinocchio_refuses_names_file_and_reason(tmp_path):
    bad = tmp_path / "bad.urdf"  # urdfdom insists on an effort limit; MuJoCo does not
    bad.write_text(plant(URDF, '<limit lower="0" upper="0.35" effort="10" velocity="1"/>',
                         '<limit lower="0" upper="0.35" velocity="1"/>'))
    with pytest.raises(CheckError, match=r"bad\.urdf: Pinocchio refused it: .*effort"):
        check_files([bad])


def test_unknown_file_type_and_missing_file(tmp_path):
    with pytest.raises(CheckError, match="no such file"):
        check_files([tmp_path / "nothing.urdf"])
    odd = tmp_path / "model.stl"
    odd.write_text("solid x\nendsolid x\n")
    with pytest.raises(CheckError, match="cannot check"):
        check_files([odd])


def test_explicit_reference(tmp_path):
    files = write_files(tmp_path, mjcf=plant(MJCF, 'axis="0 0.1 1"', 'axis="0 -0.1 -1"'))
    report = check_files(files, n_configurations=30, reference="MuJoCo (MJCF)")
    assert report.reference.startswith("MuJoCo (MJCF)")
    # against the broken file, every other probe disagrees about the door
    assert {m.probe.rsplit(" ", 1)[0] for m in report.mismatches if m.name == "door"} == {
        "model (object.json)", "MuJoCo (URDF)", "Pinocchio (URDF)"}
    report = check_files(files, n_configurations=5, reference=files[2])
    assert report.reference == "MuJoCo (URDF) cabinet.urdf"
    with pytest.raises(CheckError, match="reference"):
        check_files(files, reference="Gazebo")


def test_model_probe_batch_matches_forward_kinematics(tmp_path):
    obj = small_cabinet()
    obj.joint("drawer_slide").origin[:3, :3] = tf.rpy_to_matrix([0.2, 0.1, -0.4])
    probe = open_probes(object_json.save(obj, tmp_path))[0]
    rng = np.random.default_rng(0)
    values = rng.uniform(-2, 2, size=(7, len(probe.joints)))
    batch = probe.pose_array(values)
    for row, poses in zip(values, batch, strict=True):
        expected = forward_kinematics(obj, {j.name: v for j, v in zip(probe.joints, row,
                                                                     strict=True)})
        for k, part in enumerate(probe.parts):
            np.testing.assert_allclose(poses[k], expected[part], atol=1e-14)


def test_rotation_angle_is_accurate_near_zero_and_at_pi():
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    for angle in (1e-9, 1e-6, 0.3, 3.0, math.pi):
        a = tf.rpy_to_matrix([0.2, -0.4, 1.0])
        b = a @ tf.axis_angle_matrix(axis, angle)
        got = rotation_angles(a[None], b[None])[0]
        assert got == pytest.approx(angle, rel=1e-7, abs=1e-15)


@pytest.mark.partnet
@pytest.mark.filterwarnings("ignore:obj_dec:UserWarning")  # MuJoCo on PartNet OBJ texcoords
def test_partnet_urdfs_mujoco_and_pinocchio_agree_where_both_load():
    """Raw PartNet-Mobility URDFs (non-unit axes, fixed links): most are refused by one
    tool (degenerate meshes in MuJoCo, limits without effort in urdfdom), and the refusal
    must name the file; those both tools load must agree."""
    compared = 0
    for folder in partnet_objects():
        urdf = folder / "mobility.urdf"
        try:
            report = check_files([urdf], n_configurations=50)
        except CheckError as e:
            assert str(urdf) in str(e) and "refused it" in str(e)
            continue
        assert report.ok, format_table(report)
        assert len(report.probes) == 2 and len(report.joints) >= 1
        compared += 1
    assert compared >= 1, "no PartNet URDF loaded in both MuJoCo and Pinocchio"


# -- the exporters, once they exist ---------------------------------------------------------
def _exporter_or_skip(name: str) -> None:
    module = pytest.importorskip(f"real2code_export.formats.{name}",
                                 reason=f"{name} exporter not written yet")
    if not hasattr(module, "save"):
        pytest.skip(f"{name} exporter not written yet")


@pytest.mark.parametrize("formats", [["json", "urdf"], ["json", "mjcf", "urdf"]],
                         ids=["urdf", "mjcf+urdf"])
def test_exported_files_agree_with_the_model(tmp_path, formats):
    for name in formats[1:]:
        _exporter_or_skip(name)
    from real2code_export.formats import export

    obj = small_cabinet()
    written = export(obj, tmp_path, formats)
    report = check_files([written[f] for f in formats], n_configurations=100,
                         tol_position=1e-6, tol_rotation=1e-6)
    expected = {"json": ["model (object.json)"], "mjcf": ["MuJoCo (MJCF)"],
                "urdf": ["MuJoCo (URDF)", "Pinocchio (URDF)"]}
    assert [p.label for p in report.probes] == [lab for f in formats for lab in expected[f]]
    assert all(sorted(p.parts) == sorted(q.name for q in obj.parts) for p in report.probes)
    assert report.configurations[1] == obj.observed_configuration()
    assert report.ok, format_table(report)


def test_a_urdf_of_more_dofs_than_pinocchio_holds_is_checked_in_mujoco(tmp_path, monkeypatch):
    """Pinocchio's data grows as the cube of the degrees of freedom (a flex's 1153 vertex
    slides asked for more than 21 GB): beyond ``MAX_DOFS`` the file is not loaded in
    Pinocchio, with a warning naming it, and MuJoCo's probe checks it alone, as an export
    and as the source."""
    from real2code_export.probes import pinocchio

    links = "".join(f'<link name="l{i}"><inertial><mass value="0.1"/><inertia ixx="1e-4" '
                    f'iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial></link>'
                    for i in range(4))
    joints = "".join(f'<joint name="s{i}" type="prismatic"><parent link="l{i - 1}"/>'
                     f'<child link="l{i}"/><axis xyz="1 0 0"/>'
                     f'<limit lower="0" upper="0.1" effort="1" velocity="1"/></joint>'
                     for i in range(1, 4))
    path = tmp_path / "chain.urdf"
    path.write_text(f'<robot name="chain">{links}{joints}</robot>')
    monkeypatch.setattr(pinocchio, "MAX_DOFS", 2)
    with pytest.warns(UserWarning, match="not loaded in Pinocchio: 3 degrees of freedom"):
        report = check_files([path], source=path, n_configurations=3, validate=False)
    assert [p.label for p in report.probes] == ["source MuJoCo (URDF)", "MuJoCo (URDF)"]
    assert report.ok, report.mismatches
