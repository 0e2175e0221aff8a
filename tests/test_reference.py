"""``check --reference`` / ``export --check``: every export compared with the user's own
file loaded in its own tools; a moved base is caught."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from real2code_export.check import check_files
from real2code_export.cli import EXIT_DISAGREE, EXIT_OK, run

from helpers import edit_glb

# A robot standing 0.4 m up, turned a quarter turn (as Menagerie robots are placed), with a
# free joint, a named hinge and a name that is not an identifier.
STANDING = """<mujoco model="standing">
  <worldbody>
    <body name="trunk-body" pos="0.1 0 0.4" quat="0.7071068 0 0 0.7071068">
      <freejoint/>
      <geom type="box" size="0.1 0.05 0.02" mass="2"/>
      <body name="leg" pos="0.1 0 0">
        <joint name="hip" axis="0 1 0" range="-1 1"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.02" mass="0.3"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _arm_with_wrist(finger: str = "") -> str:
    """:data:`ARM` with a ball-jointed wrist on its link (``finger``: bodies inside the
    wrist) and a mocap body, which moves on no joint."""
    capsule = '<geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.4"/>'
    return ARM.replace(capsule, capsule + f"""
        <body name="wrist" pos="0.2 0 0">
          <joint name="wrist" type="ball" damping="0.1"/>
          <geom type="sphere" size="0.03" mass="0.2"/>{finger}
        </body>""").replace("<worldbody>", """<worldbody>
    <body name="target" mocap="true" pos="0.3 0 0.3"><geom type="sphere" size="0.02"/></body>""")

URDF_WITH_PACKAGE = """<robot name="pkg">
  <link name="base">
    <inertial><mass value="1"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/>
    </inertial>
    <visual><geometry><mesh filename="package://my_pkg/meshes/part.dae"/></geometry></visual>
  </link>
  <link name="arm">
    <inertial><mass value="0.5"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.01"/></inertial>
    <visual><geometry><mesh filename="package://my_pkg/meshes/part.dae"/></geometry></visual>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="arm"/><origin xyz="0 0 0.3" rpy="0 0.3 0"/>
    <axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="1" velocity="1"/>
  </joint>
</robot>
"""


def test_exports_agree_with_the_source_and_a_moved_base_is_caught(tmp_path, capsys):
    source = tmp_path / "standing.xml"
    source.write_text(STANDING)
    out = tmp_path / "out"
    assert run(["export", str(source), "--out", str(out), "--check",
                "--configurations", "10"]) == EXIT_OK
    said = capsys.readouterr().out
    assert "source MuJoCo (MJCF) standing.xml" in said
    # The same robot with its base dropped to the origin: every other tool agrees with it,
    # only the source shows the move.
    moved = tmp_path / "moved" / "standing.xml"
    moved.parent.mkdir()
    moved.write_text(STANDING.replace('pos="0.1 0 0.4" quat="0.7071068 0 0 0.7071068"', ""))
    assert run(["export", str(moved), "--out", str(tmp_path / "out2")]) == EXIT_OK
    exported = tmp_path / "out2" / "standing.xml"
    assert check_files([exported], n_configurations=5).ok
    report = check_files([exported], source=source, n_configurations=5)
    assert not report.ok
    assert any(m.kind == "pose" and m.name == "trunk_body" for m in report.mismatches), \
        report.mismatches
    assert run(["check", str(exported), "--reference", str(source),
                "--configurations", "5"]) == EXIT_DISAGREE


def test_a_urdf_source_with_package_uris_and_collada_is_a_reference(tmp_path, capsys):
    from test_urdf import COLLADA_MM

    tetrahedron = (COLLADA_MM.replace('count="9">0 0 0 10 0 0 0 10 0', 'count="12">0 0 0 10 0 0 0 10 0 0 0 10')
                   .replace('count="3" stride', 'count="4" stride')
                   .replace('<triangles count="1">', '<triangles count="4">')
                   .replace("<p>0 1 2</p>", "<p>0 2 1 0 1 3 0 3 2 1 2 3</p>"))
    package = tmp_path / "ws" / "my_pkg"
    (package / "meshes").mkdir(parents=True)
    (package / "meshes" / "part.dae").write_text(tetrahedron)
    (tmp_path / "robots").mkdir()
    source = tmp_path / "robots" / "pkg.urdf"  # not inside the package: needs the search path
    source.write_text(URDF_WITH_PACKAGE)
    out = tmp_path / "out"
    assert run(["export", str(source), "--out", str(out), "--check", "--configurations", "10",
                "--package-path", str(tmp_path / "ws")]) == EXIT_OK
    said = capsys.readouterr().out
    # MuJoCo cannot open package:// or Collada: it loads the source's kinematics; Pinocchio
    # loads it as it is.
    assert "source MuJoCo (URDF)" in said and "source Pinocchio (URDF)" in said
    assert said.rstrip().endswith("AGREE")
    assert Path(out / "pkg.urdf").is_file()


# An arm whose joints carry damping, friction and armature, with a mass of its own.
ARM = """<mujoco model="arm">
  <worldbody>
    <body name="base" pos="0 0 0.1">
      <geom type="box" size="0.05 0.05 0.05" mass="1"/>
      <body name="link" pos="0 0 0.1">
        <joint name="elbow" axis="0 1 0" range="-1 1" damping="0.5" frictionloss="0.2"
               armature="0.01"/>
        <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.4"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_an_export_whose_dynamics_differ_from_the_source_is_caught(tmp_path, capsys):
    """The kinematics of an export agree with the source; its mass, damping or armature
    altered (a loss no repair warning names) is a mismatch, and check exits 1."""
    source = tmp_path / "arm.xml"
    source.write_text(ARM)
    out = tmp_path / "out"
    assert run(["export", str(source), "--out", str(out), "--to", "mjcf,urdf",
                "--check", "--configurations", "5"]) == EXIT_OK
    said = capsys.readouterr().out
    assert "dynamics against the source" in said and "equal" in said
    exported = (out / "arm.xml").read_text()
    for old, new, expected in [('mass="0.4"', 'mass="0.5"', "body 'link': mass 0.4 != 0.5"),
                               ('damping="0.5"', 'damping="0.6"', "damping 0.5 != 0.6"),
                               ('armature="0.01"', 'armature="0.02"', "armature 0.01 != 0.02")]:
        assert old in exported, (old, exported)
        altered = tmp_path / f"altered_{expected.split()[0]}" / "arm.xml"
        altered.parent.mkdir(exist_ok=True)
        altered.write_text(exported.replace(old, new))
        report = check_files([altered], source=source, n_configurations=5, validate=False)
        assert not [m for m in report.mismatches if m.kind != "dynamics"], report.mismatches
        found = [m for m in report.mismatches if m.kind == "dynamics"]
        assert any(expected in m.message for m in found), found
        assert run(["check", str(altered), "--reference", str(source),
                    "--configurations", "5"]) == EXIT_DISAGREE
    # beyond the tolerance the user gives only
    report = check_files([altered], source=source, n_configurations=5, validate=False,
                         tol_dynamics=2.0)
    assert report.ok, report.mismatches


def test_an_mjcf_sources_urdf_export_is_compared_as_mujoco_imports_it(tmp_path, capsys):
    """An MJCF source's URDF export, as MuJoCo imports it, has the source's masses, damping,
    friction and ranges (a ball joint, which a URDF has not, fixed at its rest with its mass
    counted in its parent's; a mocap body, which moves on no joint, fixed); its mass,
    damping or friction altered is a mismatch."""
    source = tmp_path / "arm.xml"
    source.write_text(_arm_with_wrist())
    out = tmp_path / "out"
    assert run(["export", str(source), "--out", str(out), "--to", "urdf",
                "--check", "--configurations", "5"]) == EXIT_OK
    said = capsys.readouterr().out
    assert "dynamics against the source" in said, said
    exported = (out / "arm.urdf").read_text()
    for old, new, expected in [('value="0.4"', 'value="0.5"', "mass 0.6"),
                               ('damping="0.5"', 'damping="0.6"', "damping 0.5 != 0.6"),
                               ('friction="0.2"', 'friction="0.3"', "frictionloss 0.2 != 0.3")]:
        assert old in exported, (old, exported)
        altered = out / f"altered_{old.split('=')[0]}.urdf"  # (beside its meshes)
        altered.write_text(exported.replace(old, new))
        report = check_files([altered], source=source, n_configurations=5, validate=False)
        assert not [m for m in report.mismatches if m.kind != "dynamics"], report.mismatches
        found = [m.message for m in report.mismatches if m.kind == "dynamics"]
        assert any(expected in m for m in found), found


URDF_ROUNDED = """<robot name="rounded">
  <link name="base"><inertial><mass value="1"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <link name="arm"><inertial><mass value="0.5"/>
    <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.004" iyz="0" izz="0.0052"/></inertial></link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="arm"/><origin xyz="0 0 0.3"/>
    <axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="3" velocity="4"/>
    <dynamics damping="0.3" friction="0.1"/>
  </joint>
</robot>
"""


def test_a_urdf_source_repaired_by_the_reader_is_told_from_a_loss(tmp_path, capsys):
    """The arm's tensor misses the triangle inequality (0.001 + 0.004 < 0.0052): the reader
    balances it, warned; the export differs from the source there, as a repair, not a
    mismatch. Its damping altered in the URDF export is one (Pinocchio)."""
    source = tmp_path / "rounded.urdf"
    source.write_text(URDF_ROUNDED)
    out = tmp_path / "out"
    assert run(["export", str(source), "--out", str(out), "--to", "urdf,mjcf",
                "--check", "--configurations", "5"]) == EXIT_OK
    said = capsys.readouterr()
    assert "triangle inequality" in said.err
    assert "repaired by the reader" in said.out and said.out.rstrip().endswith("AGREE")
    # check alone reads the source again for the reader's warnings
    files = [out / "rounded.urdf", out / "rounded.xml"]
    report = check_files(files, source=source, n_configurations=5, validate=False)
    assert report.ok, report.mismatches
    assert {d.tool for d in report.dynamics} == {"Pinocchio", "MuJoCo"}
    assert any(d.repaired for d in report.dynamics), report.dynamics
    # the same differences with no warning to explain them are mismatches
    report = check_files(files, source=source, n_configurations=5, validate=False, warned=[])
    assert {m.kind for m in report.mismatches} == {"dynamics"}
    text = (out / "rounded.urdf").read_text()
    assert 'damping="0.3"' in text
    (out / "rounded.urdf").write_text(text.replace('damping="0.3"', 'damping="0.7"'))
    report = check_files(files, source=source, n_configurations=5, validate=False)
    assert [m.message for m in report.mismatches] == [
        "Pinocchio: joint 'shoulder': damping [0.3] != [0.7] (the source's, then the export's)"]


def test_usd_and_gltf_exports_are_compared_with_the_sources_dynamics(tmp_path, capsys):
    """An MJCF source's USD and glTF exports state its masses, damping, friction, armature
    and ranges in their schemas (UsdPhysics' mass and limits, MuJoCo's and Newton's joint
    attributes; KHR_physics_rigid_bodies' motion, limits and drives): equal after an
    export, with a ball joint, a body of two joints and a mocap body; each altered is a
    mismatch, and check exits 1."""
    source = tmp_path / "arm.xml"
    source.write_text(_arm_with_wrist(finger="""
          <body name="finger" pos="0.05 0 0">
            <joint name="slide" type="slide" axis="1 0 0" range="0 0.1" damping="1"/>
            <joint name="spin" axis="0 0 1" armature="0.003"/>
            <geom type="box" size="0.01 0.01 0.02" mass="0.05" pos="0.01 0 0"/>
            <body name="tip" pos="0.02 0 0"><geom type="sphere" size="0.005" mass="0.01"/></body>
          </body>"""))
    out = tmp_path / "out"
    assert run(["export", str(source), "--out", str(out), "--to", "usd,gltf",
                "--check", "--configurations", "5"]) == EXIT_OK
    said = capsys.readouterr().out
    assert "arm.usda  MuJoCo / UsdPhysics" in said and "arm.glb   MuJoCo / KHR" in said, said
    usda = (out / "arm.usda").read_text()
    for old, new, expected in [
            ("float physics:mass = 0.01", "float physics:mass = 0.02",
             "body 'finger' and the bodies fixed to it: mass 0.06"),
            ("uniform double mjc:damping = 0.5", "uniform double mjc:damping = 0.6",
             "joint 'elbow': damping (mjc:damping) 0.5 != 0.6"),
            ("float newton:armature = 0.003", "float newton:armature = 0.004",
             "joint 'spin': armature (newton:armature) 0.003 != 0.004"),
            ("float physics:upperLimit = 0.1", "float physics:upperLimit = 0.2",
             "joint 'slide': range")]:
        assert old in usda, old
        altered = out / "altered.usda"
        altered.write_text(usda.replace(old, new, 1))
        report = check_files([altered], source=source, n_configurations=5, validate=False)
        found = [m.message for m in report.mismatches if m.kind == "dynamics"]
        assert any(expected in m for m in found), (expected, found)
    assert run(["check", str(altered), "--reference", str(source),
                "--configurations", "5"]) == EXIT_DISAGREE

    def heavier(doc):
        next(n for n in doc["nodes"] if n.get("name") == "link")["extensions"][
            "KHR_physics_rigid_bodies"]["motion"]["mass"] = 0.5

    def undamped(doc):
        joints = doc["extensions"]["KHR_physics_rigid_bodies"]["physicsJoints"]
        next(j for j in joints if j["name"] == "wrist")["drives"] = []

    def stiffer(doc):
        node = next(n for n in doc["nodes"] if n.get("name") == "spin")
        node["extras"]["real2code"]["dynamics"]["armature"] = 0.01

    for edit, expected in [(heavier, "body 'link' and the bodies fixed to it: mass 0.4 != 0.5"),
                           (undamped, "joint 'wrist': damping (drive) 0.1 != 0.0"),
                           (stiffer, "joint 'spin': armature (real2code extras) 0.003 != 0.01")]:
        altered = out / "altered.glb"
        altered.write_bytes((out / "arm.glb").read_bytes())
        edit_glb(altered, edit)
        report = check_files([altered], source=source, n_configurations=5, validate=False)
        found = [m.message for m in report.mismatches if m.kind == "dynamics"]
        assert any(expected in m for m in found), (expected, found)
        assert not [m for m in report.mismatches if m.kind != "dynamics"], report.mismatches
    assert run(["check", str(altered), "--reference", str(source),
                "--configurations", "5"]) == EXIT_DISAGREE


# What other people's MJCF files are made of: an <include>, meshes found through assetdir and
# meshdir, angles in degrees turned in "zyx" order, a childclass and nested default classes,
# fromto capsules and cylinders, a <frame>, a <replicate>, gravity compensation, a camera,
# a light, a geom's own friction, a joint's own limit softness, simulation options and a
# mocap body (not imported, said so), a body without joints under fusestatic (kept).
KINDS_MAIN = """<mujoco model="kinds">
  <compiler angle="degree" eulerseq="zyx" assetdir="assets" meshdir="assets/meshes"
            autolimits="true" fusestatic="true"/>
  <option timestep="0.001" integrator="implicitfast"><flag gravity="disable"/></option>
  <default>
    <default class="arm">
      <joint damping="0.3" armature="0.01" axis="0 0 1"/>
      <geom density="800"/>
      <default class="stiff">
        <joint stiffness="2" springref="10" frictionloss="0.05"/>
        <default class="light"><geom density="100"/></default>
      </default>
    </default>
  </default>
  <asset><mesh name="block" file="block.obj" scale="0.001 0.001 0.001"/></asset>
  <include file="parts/arm.xml"/>
</mujoco>
"""
KINDS_ARM = """<mujoco>
  <worldbody>
    <light pos="0 0 2"/><camera name="view" pos="1 0 1"/>
    <body name="target" mocap="true" pos="0.5 0 0.5"><geom size="0.01" contype="0"/></body>
    <frame pos="0 0 0.3" euler="0 0 20">
      <body name="upper" euler="90 0 30" childclass="arm" gravcomp="1">
        <joint name="shoulder" range="-45 90"/>
        <geom type="mesh" mesh="block"/>
        <body name="lower" pos="0.1 0 0" euler="0 30 45">
          <joint name="elbow" class="stiff" range="0 120" solreflimit="0.05 1"/>
          <geom type="capsule" fromto="0 0 0 0.2 0.05 0" size="0.02" friction="0.6"/>
          <geom type="cylinder" fromto="0 0 0 0 0 0.1" size="0.01" class="light"/>
          <body name="tool" pos="0.2 0.05 0"><geom type="box" size="0.01 0.01 0.01"/></body>
        </body>
      </body>
    </frame>
    <replicate count="2" offset="0.3 0 0">
      <body name="bead" pos="0 0.5 0"><joint name="bead" axis="1 0 0"/>
        <geom type="sphere" size="0.02" mass="0.05"/></body>
    </replicate>
  </worldbody>
</mujoco>
"""


def test_mjcf_files_as_people_write_them_agree_with_their_source(tmp_path, capsys):
    import trimesh

    (tmp_path / "assets" / "meshes").mkdir(parents=True)
    trimesh.creation.box((100, 50, 20)).export(tmp_path / "assets" / "meshes" / "block.obj")
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "arm.xml").write_text(KINDS_ARM)
    source = tmp_path / "kinds.xml"
    source.write_text(KINDS_MAIN)
    assert run(["export", str(source), "--out", str(tmp_path / "out"), "--to", "mjcf,usd,gltf",
                "--check", "--configurations", "5"]) == EXIT_OK
    said = capsys.readouterr()
    assert said.out.rstrip().endswith("AGREE") and "differ" not in said.out, said.out
    assert "gravity compensation (gravcomp) not carried" in said.err
    assert "<body name='upper'> (1)" in said.err
    assert "not imported: 1 camera, 1 light, 1 collision geom (its own friction" in said.err
    assert ("<option> settings not carried (the model holds no simulation options; every "
            "export leaves its tool's defaults): flag gravity=disable, integrator=implicitfast, "
            "timestep=0.001") in said.err
    assert "mocap bodies read as parts fixed where they stand" in said.err
    assert "1 joint (its own limit or friction softness" in said.err
    assert "<compiler fusestatic='true'> (MuJoCo merges" in said.err


PLANAR = """<robot name="base_on_floor">
  <link name="floor"><inertial><mass value="5"/>
    <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
  <link name="cart"><inertial><origin xyz="0.02 0 0"/><mass value="2"/>
    <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.04"/></inertial></link>
  <joint name="plane" type="planar"><parent link="floor"/><child link="cart"/>
    <origin xyz="0 0 0.1" rpy="0 0 0.3"/><axis xyz="0 0 1"/><dynamics damping="0.5"/></joint>
</robot>
"""


def test_a_urdf_planar_joint_is_read_as_mujoco_and_pinocchio_move_it(tmp_path, capsys):
    """A planar joint (a mobile base on the floor): two slides and a hinge, as MuJoCo's URDF
    import makes it (``plane_TX``, ``plane_TY``, ``plane_RZ``) and as Pinocchio's planar
    joint moves, warned; every export agrees with the source in both tools."""
    source = tmp_path / "base.urdf"
    source.write_text(PLANAR)
    assert run(["export", str(source), "--out", str(tmp_path / "out"), "--to", "urdf,mjcf",
                "--check", "--configurations", "10"]) == EXIT_OK
    said = capsys.readouterr()
    assert "<joint name='plane'>: a planar joint: read as MuJoCo imports it" in said.err
    assert "source Pinocchio (URDF)" in said.out and said.out.rstrip().endswith("AGREE")


def _usd_body(path, *, axes, collider):
    """A USD of one rigid body on a hinge, its PhysicsMassAPI with or without principal
    axes, with or without a collider, opened by the USD probe."""
    from pxr import Gf, Usd, UsdGeom, UsdPhysics

    from real2code_export.probes.usd import UsdProbe

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    body = UsdGeom.Xform.Define(stage, "/robot/arm").GetPrim()
    UsdPhysics.RigidBodyAPI.Apply(body)
    mass = UsdPhysics.MassAPI.Apply(body)
    mass.CreateMassAttr(2.0)
    mass.CreateCenterOfMassAttr(Gf.Vec3f(0.1, 0.0, 0.0))
    mass.CreateDiagonalInertiaAttr(Gf.Vec3f(0.01, 0.02, 0.03))
    if axes:
        mass.CreatePrincipalAxesAttr(Gf.Quatf(1.0, 0.0, 0.0, 0.0))
    if collider:
        cube = UsdGeom.Cube.Define(stage, "/robot/arm/box").GetPrim()
        UsdPhysics.CollisionAPI.Apply(cube)
    joint = UsdPhysics.RevoluteJoint.Define(stage, "/robot/hinge")
    joint.CreateBody1Rel().SetTargets(["/robot/arm"])
    joint.CreateAxisAttr("Z")
    stage.Save()
    return UsdProbe(path)


def test_a_usd_mass_states_what_a_consumer_reads(tmp_path):
    """PhysicsMassAPI as PhysX reads it: a stated diagonal inertia whose principal axes are
    left at their fallback (0, 0, 0, 0) lies in the body's axes, with or without colliders
    (ovphysx 0.7 reads the body's inertia as diag(0.01, 0.02, 0.03) for both; Newton's
    importer takes the identity too: session 31; this test said "left to the simulator"
    before); the stated mass stands, never read as none."""
    from real2code_export.probes import schema_dynamics

    read = schema_dynamics.usd_dynamics
    for axes, collider in ((True, False), (False, True), (False, False)):
        stated = read(_usd_body(tmp_path / f"{axes}{collider}.usda", axes=axes,
                                collider=collider))
        mass, inertia, com = stated.bodies["arm"]
        assert mass == 2.0 and np.allclose(np.diag(inertia), [0.01, 0.02, 0.03])
        assert np.allclose(com, [0.1, 0, 0], atol=1e-7) and not stated.unstated


def test_an_mjcf_whose_include_names_assets_up_a_folder_is_a_reference_from_anywhere(
        tmp_path, monkeypatch):
    """An included file naming its meshes ``../meshes/...`` (Genesis's franka_sim): MuJoCo
    opens them from the model's folder or by its absolute path, and from another folder
    with a relative path says "Error opening file". The export and its check against the
    source load it as from its folder."""
    import trimesh

    model = tmp_path / "robot"
    (model / "assets").mkdir(parents=True)
    (model / "meshes").mkdir()
    trimesh.creation.box((0.1, 0.1, 0.1)).export(model / "meshes" / "link.stl")
    (model / "assets" / "assets.xml").write_text(
        '<mujocoinclude><asset><mesh name="link" file="../meshes/link.stl"/></asset>'
        "</mujocoinclude>")
    (model / "arm.xml").write_text(
        '<mujoco model="arm"><include file="assets/assets.xml"/><worldbody>'
        '<body name="link"><joint name="hinge" axis="0 0 1"/>'
        '<geom type="mesh" mesh="link"/></body></worldbody></mujoco>')
    monkeypatch.chdir(tmp_path)
    status = run(["export", "robot/arm.xml", "--to", "mjcf,urdf", "--check", "--out", "out"])
    assert status == EXIT_OK
