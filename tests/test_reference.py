"""``check --reference`` / ``export --check``: every export compared with the user's own
file loaded in its own tools; a moved base is caught."""

from __future__ import annotations

from pathlib import Path

from real2code_export.check import check_files
from real2code_export.cli import EXIT_DISAGREE, EXIT_OK, run

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
