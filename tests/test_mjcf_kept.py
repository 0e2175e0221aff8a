"""MJCF actuators, tendons, sensors and equality constraints (and the default classes they
use) kept by the reader are written back by the MJCF writer, as MuJoCo compiles them; what
MuJoCo refuses stays in the metadata, warned about; other formats say they carry them as
metadata only."""

from __future__ import annotations

import warnings

import mujoco
import numpy as np

from real2code_export.formats import export
from real2code_export.formats import load as load_any
from real2code_export.model import differences

ACTUATED = """<mujoco model="act">
  <default>
    <joint damping="0.1"/>
    <position kp="20" ctrlrange="-1 1"/>
    <default class="strong">
      <position kp="100"/>
      <geom rgba="1 0 0 1"/>
    </default>
  </default>
  <worldbody>
    <body name="base">
      <geom type="box" size="0.1 0.1 0.1"/>
      <geom type="cylinder" size="0.02 0.05" name="pulley" pos="0 0.1 0.2"/>
      <site name="anchor" pos="0 0 0.1"/>
      <body name="arm" pos="0 0 0.3">
        <joint name="j1" axis="0 1 0" range="-1 1"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.02"/>
        <site name="tip" pos="0 0 0.3"/>
        <body name="hand" pos="0 0 0.3">
          <joint name="j2" axis="0 1 0" range="-1 1"/>
          <geom type="sphere" size="0.03"/>
        </body>
      </body>
    </body>
  </worldbody>
  <tendon>
    <spatial name="rope" width="0.002"><site site="anchor"/><site site="tip"/></spatial>
    <spatial name="around"><site site="anchor"/><geom geom="pulley"/><site site="tip"/>
    </spatial>
    <fixed name="couple"><joint joint="j1" coef="1"/><joint joint="j2" coef="-1"/></fixed>
  </tendon>
  <equality>
    <connect body1="hand" body2="base" anchor="0 0 0"/>
  </equality>
  <actuator>
    <position name="a1" joint="j1"/>
    <position name="a2" joint="j2" class="strong"/>
    <motor name="m" tendon="couple" gear="2"/>
    <general name="wrapped" tendon="rope"/>
  </actuator>
  <sensor>
    <jointpos joint="j1"/>
    <framepos objtype="site" objname="tip"/>
    <touch site="tip" name="touchy"/>
  </sensor>
</mujoco>
"""


def _said(fn, *args):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = fn(*args)
    return out, "\n".join(str(w.message) for w in caught)


def test_kept_sections_written_back(tmp_path):
    source = tmp_path / "act.xml"
    source.write_text(ACTUATED)
    obj, said = _said(load_any, source)
    assert "the MJCF writer writes them back" in said
    assert set(obj.metadata["mjcf_elements"]) == {"actuator", "tendon", "sensor", "equality",
                                                 "default"}
    assert "rgba" not in obj.metadata["mjcf_elements"]["default"]  # only what they use
    written, said = _said(export, obj, tmp_path / "out", ["mjcf", "urdf", "usd", "gltf"])
    # the wrapping tendon names a geom the export names otherwise: left out, said, kept
    assert "<tendon> <spatial name='around'>" in said and "not written back" in said
    for label in ("URDF", "USD", "glTF"):
        assert f"{label}: 'act': the MJCF elements kept in the metadata" in said
    a = mujoco.MjModel.from_xml_path(str(source))
    b = mujoco.MjModel.from_xml_path(str(written["mjcf"]))
    assert (b.nu, b.ntendon, b.nsensor, b.neq) == (a.nu, a.ntendon - 1, a.nsensor, a.neq)
    for field in ("actuator_gainprm", "actuator_biasprm", "actuator_ctrlrange", "actuator_gear",
                  "actuator_trntype", "sensor_type", "eq_type", "eq_data"):
        np.testing.assert_allclose(getattr(a, field), getattr(b, field), err_msg=field)
    assert [b.actuator(k).name for k in range(b.nu)] == ["a1", "a2", "m", "wrapped"]
    # read back: the file's sections and the one left in the metadata, all kept again
    back, _ = _said(load_any, written["mjcf"])
    assert not differences(obj, back)
    assert "around" in back.metadata["mjcf_elements"]["tendon"]
    assert "rope" in back.metadata["mjcf_elements"]["tendon"]
    again, _ = _said(export, back, tmp_path / "again", ["mjcf"])
    assert again["mjcf"].read_text() == written["mjcf"].read_text()
    # the other formats carry them to MJCF
    for fmt in ("usd", "gltf"):
        other, _ = _said(load_any, written[fmt])
        through, _ = _said(export, other, tmp_path / f"via_{fmt}", ["mjcf"])
        c = mujoco.MjModel.from_xml_path(str(through["mjcf"]))
        assert (c.nu, c.nsensor) == (a.nu, a.nsensor), fmt


LOOP = """<mujoco model="loop">
  <worldbody>
    <body name="base">
      <geom type="box" size="0.1 0.1 0.1"/>
      <body name="crank-arm" pos="0 0 0.2">
        <joint name="crank-joint" axis="0 1 0" pos="0 0 0.05" range="-1 1"/>
        <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.01"/>
      </body>
      <body name="rocker" pos="0.3 0 0.2">
        <joint name="rocker-joint" axis="0 1 0" range="-1 1"/>
        <geom type="capsule" fromto="0 0 0 -0.1 0 0" size="0.01"/>
      </body>
    </body>
  </worldbody>
  <equality>
    <connect body1="crank-arm" body2="rocker" anchor="0.2 0 0"/>
  </equality>
  <actuator>
    <motor name="drive" joint="crank-joint" gear="3"/>
  </actuator>
  <sensor>
    <framepos objtype="body" objname="crank-arm"/>
  </sensor>
</mujoco>
"""


def test_kept_elements_follow_renamed_and_moved_bodies(tmp_path):
    """References to names the reader changed use the new names; a connect anchor in a body
    whose part frame moved to its joint moves with it (the same point in the world); a sensor
    of such a body's frame is said."""
    source = tmp_path / "loop.xml"
    source.write_text(LOOP)
    obj, said = _said(load_any, source)
    assert "<framepos> of body 'crank-arm'" in said
    written, said = _said(export, obj, tmp_path / "out", ["mjcf"])
    assert "not written back" not in said
    a = mujoco.MjModel.from_xml_path(str(source))
    b = mujoco.MjModel.from_xml_path(str(written["mjcf"]))
    assert b.nu == 1 and b.joint(int(b.actuator_trnid[0, 0])).name == "crank_joint"
    eq = next(e for e in range(b.neq) if b.eq_type[e] == mujoco.mjtEq.mjEQ_CONNECT)

    def anchor_in_world(m, e):
        d = mujoco.MjData(m)
        mujoco.mj_kinematics(m, d)
        body = int(m.eq_obj1id[e])
        return d.xpos[body] + d.xmat[body].reshape(3, 3) @ m.eq_data[e, :3]

    np.testing.assert_allclose(anchor_in_world(b, eq), anchor_in_world(a, 0), atol=1e-12)
