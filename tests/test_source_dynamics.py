"""A source file's dynamics in its own tools against an export's
(``real2code_export.probes.dynamics``): equal after an export, a changed mass, damping or
limit found and named, a reader's repair told apart from a loss by the warning naming it."""

from __future__ import annotations

import warnings

import pytest

from real2code_export.formats import export, load
from real2code_export.probes import dynamics

URDF = """<robot name="arm">
  <link name="base">
    <inertial><origin xyz="0 0 0.05"/><mass value="2"/>
      <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.01"/></inertial>
  </link>
  <link name="upper">
    <inertial><origin xyz="0.1 0 0" rpy="0.3 0 0"/><mass value="1"/>
      <inertia ixx="0.001" ixy="0.0001" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
  </link>
  <link name="tool">
    <inertial><origin xyz="0 0 0.02"/><mass value="0.2"/>
      <inertia ixx="0.0001" ixy="0" ixz="0" iyy="0.0001" iyz="0" izz="0.0001"/></inertial>
  </link>
  <link name="lower">
    <inertial><mass value="0.5"/>
      <inertia ixx="0.002" ixy="0" ixz="0" iyy="0.0015" iyz="0" izz="0.001"/></inertial>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/><origin xyz="0 0 0.1" rpy="0 0.2 0"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1.5" effort="20" velocity="3"/>
    <dynamics damping="0.4" friction="0.1"/>
  </joint>
  <joint name="tool_mount" type="fixed">
    <parent link="upper"/><child link="tool"/><origin xyz="0.2 0 0"/>
  </joint>
  <joint name="elbow" type="prismatic">
    <parent link="upper"/><child link="lower"/><origin xyz="0.25 0 0"/>
    <axis xyz="1 0 0"/><limit lower="0" upper="0.1" effort="50" velocity="0.5"/>
    <dynamics damping="2"/>
  </joint>
</robot>
"""


@pytest.fixture()
def exported(tmp_path):
    source = tmp_path / "arm.urdf"
    source.write_text(URDF)
    written = export(load(source), tmp_path / "out", ["urdf", "mjcf"])
    return source, written


def test_an_export_has_its_urdf_sources_dynamics_in_pinocchio_and_mujoco(exported):
    source, written = exported
    assert dynamics.urdf_differences(source, written["urdf"]) == []
    assert dynamics.urdf_mujoco_differences(source, written["mjcf"]) == []


def test_a_changed_mass_damping_or_limit_is_found_and_named(exported, tmp_path):
    source, written = exported
    changed = tmp_path / "changed.urdf"
    changed.write_text(URDF.replace('<mass value="0.2"/>', '<mass value="0.25"/>')
                       .replace('damping="2"', 'damping="1"')
                       .replace('effort="20"', 'effort="10"'))
    found = dynamics.urdf_differences(source, changed)
    said = "\n".join(map(str, found))
    # the tool's mass counts in the joint that carries it (Pinocchio merges fixed links)
    assert "the links of joint 'shoulder': mass 1.2 != 1.25" in said
    assert "joint 'elbow': damping" in said and "joint 'shoulder': effortLimit" in said
    by_name = {n for d in found for n in d.names}
    assert {"upper", "tool", "elbow", "shoulder"} <= by_name
    # a warning naming one of the elements and saying what of it changed explains the
    # difference; one about something else (its collision) does not
    mass = [d for d in found if "tool" in d.names]
    assert mass and dynamics.unexplained(found, ["<link name='tool'>: mass repaired"]) == [
        d for d in found if d not in mass]
    assert dynamics.unexplained(found, ["no <collision> in links 'tool'"]) == found
    assert dynamics.unexplained(found, []) == found


def test_a_warning_explains_only_the_quantity_it_says_changed(exported, tmp_path):
    """A warning naming the element explains a difference only in what it says, in its own
    words, it changed: a link read as massless (its <mass value='0'> quoted) explains its
    group's moments and centre of mass, not its mass (which a USD export left to the
    simulator once, hidden so); a joint's limit repair explains no damping or effort."""
    source, _ = exported
    changed = tmp_path / "changed.urdf"
    changed.write_text(URDF.replace('<mass value="0.2"/>', '<mass value="0.25"/>')
                       .replace('damping="2"', 'damping="1"')
                       .replace('effort="50"', 'effort="10"'))
    found = dynamics.urdf_differences(source, changed)
    mass = [d for d in found if "tool" in d.names]
    assert any(": mass " in str(d) for d in mass)
    massless = "<link name='tool'>: <mass value='0'>: the link is treated as massless (no inertial)"
    assert [str(d) for d in dynamics.unexplained(mass, [massless])] == [
        str(d) for d in mass if ": mass " in str(d)]
    assert dynamics.unexplained(mass, ["<link name='tool'>: no <inertial>: mass properties "
                                       "computed from its visuals"]) == []
    elbow = [d for d in found if d.names == ("elbow",)]
    assert {str(d).split(":")[1].split()[0] for d in elbow} == {"damping", "effortLimit"}
    limit = "<joint name='elbow'>: <limit> lower == upper: an empty range, imported as continuous"
    assert dynamics.unexplained(elbow, [limit]) == elbow
    damping = "<joint name='elbow'>: <dynamics damping='-1'> is negative: 0 used"
    assert [str(d) for d in dynamics.unexplained(elbow, [damping])] == [
        str(d) for d in elbow if "effortLimit" in str(d)]


def test_mujoco_where_it_loads_the_urdf_as_it_is(tmp_path):
    """MuJoCo refuses a moving link without mass as it is: nothing to compare there (None);
    Pinocchio loads it and compares."""
    massless = tmp_path / "massless.urdf"
    massless.write_text(URDF.replace('<inertial><mass value="0.5"/>\n      <inertia ixx="0.002" '
                                     'ixy="0" ixz="0" iyy="0.0015" iyz="0" izz="0.001"/>'
                                     '</inertial>', ''))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = export(load(massless), tmp_path / "massless", ["urdf", "mjcf"])
    said = "\n".join(str(w.message) for w in caught)
    assert "moves part 'lower', which has no mass" in said
    assert dynamics.urdf_mujoco_differences(massless, out["mjcf"]) is None
    # the negligible mass given (1e-6 kg) is within the tolerance
    assert dynamics.urdf_differences(massless, out["urdf"]) == []


def test_a_massless_body_with_several_joints_compares_its_mass_only(tmp_path):
    """A body with no mass and several joints (a mobile base's x, y and yaw) is split at its
    joints and written back with its frame at the joints' anchor: MuJoCo puts the centre of
    mass of nothing at the body's origin, which has moved; only the mass (0 = 0) compares."""
    source = tmp_path / "cart.xml"
    source.write_text("""<mujoco model="cart"><worldbody>
      <body name="cart">
        <joint name="forward" type="slide" axis="1 0 0" pos="-0.2 0 0"/>
        <joint name="yaw" type="hinge" axis="0 0 1" pos="-0.2 0 0"/>
        <body name="chassis" pos="0.1 0 0.2"><geom type="box" size="0.3 0.2 0.1"/></body>
      </body></worldbody></mujoco>""")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # (the split parts' boundmass)
        out = export(load(source), tmp_path / "out", ["mjcf"])
    assert dynamics.mjcf_differences(source, out["mjcf"]) == []
    # a mass the export gains is still found
    heavy = tmp_path / "heavy.xml"
    heavy.write_text(out["mjcf"].read_text().replace(
        '<body name="cart" pos="-0.2 0 0">',
        '<body name="cart" pos="-0.2 0 0"><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>'))
    said = "\n".join(map(str, dynamics.mjcf_differences(source, heavy)))
    assert "body 'cart': mass 0.0 != 1.0" in said


def test_a_warning_naming_the_part_as_our_importer_names_it_explains():
    """A link ``fl.hip`` is part ``fl_hip``: the reader's warning that computed its mass
    names it so, and explains the source tool's difference for ``fl.hip``; a warning about
    another part does not."""
    found = [dynamics.Difference(("fl.hx", "fl.hip"), "the links of joint 'fl.hx': mass 0.0 "
                                 "!= 0.32", dynamics.MASS_WORDS["mass"], prose=True)]
    computed = "no <inertial> in links 'fl_hip': mass properties computed from their visuals"
    assert dynamics.unexplained(found, [computed]) == []
    assert dynamics.unexplained(found, [computed.replace("fl_hip", "fl_uleg")]) == found
