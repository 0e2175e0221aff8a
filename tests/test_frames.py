"""Frames and MJCF bodies kept through round trips: MJCF sites and URDF frame-only links are
parts without mass or geometry, fixed to their parent, in every format and back (an MJCF
site again in MJCF); a body with several joints comes back as one body with those joints."""

from __future__ import annotations

import warnings

import mujoco
import numpy as np

from real2code_export.check import check_files
from real2code_export.errors import Real2CodeWarning
from real2code_export.formats import export
from real2code_export.formats import load as load_any
from real2code_export.model import differences, forward_kinematics

MULTI = """<mujoco model="multi">
  <worldbody>
    <site name="world_mark" pos="1 0 0"/>
    <body name="base" pos="0 0 0.5">
      <geom type="box" size="0.1 0.1 0.1"/>
      <body name="head" pos="0 0 0.3" euler="0.2 0 0">
        <joint name="yaw" type="hinge" axis="0 0 1" range="-1 1" pos="0 0 0.01"/>
        <joint name="pitch" type="hinge" axis="0 1 0" range="-1 1" pos="0.02 0 0"/>
        <joint name="roll" type="hinge" axis="1 0 0" range="-1 1" damping="0.3"/>
        <geom type="sphere" size="0.05"/>
        <site name="eye" pos="0.05 0 0" euler="0 0.5 0"/>
        <body name="jaw" pos="0.05 0 -0.05">
          <joint name="slide" type="slide" axis="0 0 1" range="0 0.01" pos="0 0.01 0"/>
          <joint name="ball" type="ball" pos="0 0 0.01"/>
          <geom type="box" size="0.02 0.02 0.01"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _quiet(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        return fn(*args, **kwargs)


def _tree(path) -> tuple[list, list]:
    m = mujoco.MjModel.from_xml_path(str(path))
    bodies = [(m.body(b).name, m.body(int(m.body_parentid[b])).name,
               [m.joint(j).name for j in range(m.body_jntadr[b],
                                                m.body_jntadr[b] + m.body_jntnum[b])])
              for b in range(1, m.nbody)]
    sites = [(m.site(s).name, m.body(int(m.site_bodyid[s])).name) for s in range(m.nsite)]
    return bodies, sites


def test_sites_and_multi_joint_bodies_round_trip(tmp_path):
    source = tmp_path / "multi.xml"
    source.write_text(MULTI)
    obj = _quiet(load_any, source)
    assert {p.name for p in obj.parts} >= {"eye", "world_mark", "head_yaw", "head_pitch"}
    eye = obj.parent_joint("eye")
    assert eye.parent == "head" and eye.type.value == "fixed"
    assert obj.part("eye").inertial is None and obj.part("eye").visual is None
    # the site where MuJoCo has it
    model = mujoco.MjModel.from_xml_path(str(source))
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    poses = forward_kinematics(obj)
    np.testing.assert_allclose(poses["eye"][:3, 3], data.site("eye").xpos, atol=1e-12)
    np.testing.assert_allclose(poses["eye"][:3, :3], data.site("eye").xmat.reshape(3, 3),
                               atol=1e-12)
    np.testing.assert_allclose(poses["world_mark"][:3, 3], [1, 0, 0], atol=1e-12)

    written = _quiet(export, obj, tmp_path / "out", ["json", "mjcf", "urdf", "usd", "gltf"])
    for fmt, path in written.items():
        back = _quiet(load_any, path)
        assert not differences(obj, back), (fmt, differences(obj, back))
    # USD: a frame is an Xform in its parent body, no rigid body (PhysX would give it mass)
    from pxr import Usd, UsdPhysics

    stage = Usd.Stage.Open(str(written["usd"]))
    eye = next(p for p in stage.Traverse() if p.GetName() == "eye")
    assert eye.GetTypeName() == "Xform" and eye.GetParent().GetName() == "head"
    assert not eye.HasAPI(UsdPhysics.RigidBodyAPI)
    # MJCF -> model -> MJCF: the same bodies, joints per body, and sites
    bodies, sites = _tree(written["mjcf"])
    src_bodies, src_sites = _tree(source)
    assert sites == src_sites == [("world_mark", "world"), ("eye", "head")]
    assert bodies == src_bodies
    assert ("head", "base", ["yaw", "pitch", "roll"]) in bodies
    again = _quiet(export, _quiet(load_any, written["mjcf"]), tmp_path / "again", ["mjcf"])
    assert _tree(again["mjcf"]) == (bodies, sites)
    report = check_files(list(written.values()), source=source, n_configurations=20,
                         validate=False)
    assert report.ok, [m.message for m in report.mismatches]
    assert "eye" in report.probes[0].parts


URDF_FRAMES = """<robot name="framed">
  <link name="base">
    <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0"
      iyz="0"/></inertial>
    <visual><geometry><box size="0.2 0.2 0.2"/></geometry></visual>
  </link>
  <link name="tool_frame"/>
  <joint name="tool_mount" type="fixed"><parent link="base"/><child link="tool_frame"/>
    <origin xyz="0 0 0.3" rpy="0 1.0 0"/></joint>
</robot>
"""


def test_urdf_frame_link_is_an_mjcf_site(tmp_path):
    source = tmp_path / "framed.urdf"
    source.write_text(URDF_FRAMES)
    obj = _quiet(load_any, source)
    written = _quiet(export, obj, tmp_path / "out", ["mjcf", "urdf", "usd", "gltf"])
    bodies, sites = _tree(written["mjcf"])
    assert sites == [("tool_frame", "base")] and [b[0] for b in bodies] == ["base"]
    back = _quiet(load_any, written["mjcf"])
    assert not differences(obj, back)
    assert back.parent_joint("tool_frame").name == "tool_mount"
    report = check_files(list(written.values()), source=source, n_configurations=3,
                         validate=False)
    assert report.ok, [m.message for m in report.mismatches]
