"""URDF export and import: round trips proven in Pinocchio and MuJoCo, real PartNet files,
and one small fixture per kind of broken input (message names file, element and line)."""

from __future__ import annotations

import re
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh

from real2code_export import transforms as tf
from real2code_export.errors import FormatError, Real2CodeWarning
from real2code_export.formats import urdf
from real2code_export.formats.urdf.write import stable_rpy
from real2code_export.meshfiles import MeshLayout, obj_bytes
from real2code_export.model import (
    ArticulatedObject,
    DriveLimits,
    Dynamics,
    Inertial,
    Joint,
    JointType,
    Limits,
    Mesh,
    Part,
    differences,
    forward_kinematics,
    sample_configuration,
    validate,
)

from conftest import partnet_dir, partnet_ids

FIXTURES = Path(__file__).parent / "fixtures" / "urdf"


# -- objects built here ---------------------------------------------------------------------------
def box(extents, center=(0.0, 0.0, 0.0)) -> Mesh:
    return Mesh.from_trimesh(trimesh.creation.box(extents=extents,
                                                  transform=tf.make(translation=center)))


def box_inertial(mass, extents, rotation=None, com=(0.0, 0.0, 0.0)) -> Inertial:
    x2, y2, z2 = np.square(extents)
    inertia = mass / 12 * np.diag([y2 + z2, x2 + z2, x2 + y2])
    rotation = np.eye(3) if rotation is None else rotation
    return Inertial(mass, com, rotation @ inertia @ rotation.T)


def cabinet() -> ArticulatedObject:
    """Every joint type, every dynamics field, unknown effort/velocity, rotated origins (one
    in gimbal lock), a full inertia tensor, and a root with a visual but no mass/collision."""
    tilted = tf.rpy_to_matrix([0.3, -0.2, 0.5])
    parts = [
        Part("body", visual=box([0.6, 0.4, 0.8], [0, 0, 0.4]), color=(0.8, 0.7, 0.5, 1.0)),
        Part("door", visual=box([0.02, 0.4, 0.7]),
             collision=[box([0.02, 0.4, 0.7]), box([0.05, 0.05, 0.1], [0.03, 0.1, 0])],
             inertial=box_inertial(2.0, [0.02, 0.4, 0.7], tilted, [0.001, -0.002, 0.003]),
             color=(0.2, 0.4, 0.6, 0.5)),
        Part("drawer", visual=box([0.5, 0.3, 0.1]), collision=[box([0.5, 0.3, 0.1])],
             inertial=box_inertial(1.5, [0.5, 0.3, 0.1])),
        Part("knob", visual=box([0.03, 0.03, 0.03]), collision=[box([0.03, 0.03, 0.03])],
             inertial=box_inertial(0.05, [0.03, 0.03, 0.03])),
        Part("handle", visual=box([0.02, 0.15, 0.02]), inertial=box_inertial(0.1, [0.02, 0.15, 0.02])),
    ]
    joints = [
        Joint("door_hinge", JointType.REVOLUTE, "body", "door",
              origin=tf.make(tilted, [0.31, -0.2, 0.45]), axis=np.array([0.6, 0.0, 0.8]),
              limits=Limits(-1.0, 2.0, effort=5.0, velocity=None),
              dynamics=Dynamics(damping=0.5, friction=0.1, stiffness=2.0, spring_ref=0.3,
                                armature=0.01),
              state=0.4),
        Joint("drawer_slide", JointType.PRISMATIC, "body", "drawer",
              origin=tf.make(tf.rpy_to_matrix([0.2, np.pi / 2, -0.7]), [0.0, 0.0, 0.1]),
              axis=np.array([1.0, 0.0, 0.0]), limits=Limits(0.0, 0.4), state=0.1),
        Joint("knob_spin", JointType.CONTINUOUS, "door", "knob",
              origin=tf.make(translation=[0.02, 0.15, 0.0]), axis=np.array([0.0, 1.0, 0.0]),
              dynamics=Dynamics(damping=0.01), state=-2.5),
        Joint("handle_mount", JointType.FIXED, "drawer", "handle",
              origin=tf.make(tf.rpy_to_matrix([0.0, 0.0, np.pi]), [0.26, 0.0, 0.0])),
    ]
    return validate(ArticulatedObject("cabinet", parts, joints,
                                      metadata={"category": "StorageFurniture", "seed": 3}))


def single_part() -> ArticulatedObject:
    return validate(ArticulatedObject("brick", [Part("brick", visual=box([0.1, 0.2, 0.3]))]))


# -- what the simulators see ----------------------------------------------------------------------
def pinocchio_matches(obj: ArticulatedObject, path: Path, rng, samples: int = 4) -> float:
    """Largest difference between Pinocchio's link placements and the model's kinematics."""
    pin = pytest.importorskip("pinocchio")
    model = pin.buildModelFromUrdf(str(path))
    data = model.createData()
    # Fixed links' inertias are lumped into their joint's body: the total must survive.
    assert sum(i.mass for i in model.inertias) == pytest.approx(obj.total_mass(), rel=1e-12)
    worst = 0.0
    for _ in range(samples):
        q = sample_configuration(obj, rng)
        qv = pin.neutral(model)
        for j in obj.movable_joints:
            pj = model.joints[model.getJointId(j.name)]
            if j.type is JointType.CONTINUOUS:  # nq = 2: (cos, sin)
                qv[pj.idx_q:pj.idx_q + 2] = np.cos(q[j.name]), np.sin(q[j.name])
            else:
                qv[pj.idx_q] = q[j.name]
        pin.framesForwardKinematics(model, data, qv)
        for part, pose in forward_kinematics(obj, q).items():
            assert model.existBodyName(part), f"Pinocchio has no body {part!r}"
            placed = data.oMf[model.getFrameId(part, pin.BODY)].homogeneous
            worst = max(worst, float(np.abs(placed - pose).max()))
    return worst


def mujoco_matches(obj: ArticulatedObject, path: Path, rng, samples: int = 4) -> float:
    """Largest difference between MuJoCo's body poses and the model's kinematics; also
    checks that every link is a body and every visual and collision piece a geom."""
    mujoco = pytest.importorskip("mujoco")
    spec = mujoco.MjSpec.from_file(str(path))
    try:
        model = spec.compile()
    except ValueError:  # a flat visual piece (a decal of its own colour): as the probe does
        for mesh in spec.meshes:
            mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
        model = spec.compile()
    data = mujoco.MjData(model)
    assert model.nbody == len(obj.parts) + 1  # fusestatic="false": one body per part
    # a visual is a geom per colour and per shape
    layout = MeshLayout(obj)  # (or per placement of a mesh file placed several times)
    geoms = sum(len(layout.visuals[p.name]) + len(p.visual.primitives if p.visual else ())
                + len(p.collision) for p in obj.parts)
    assert model.ngeom == geoms  # discardvisual="false": the visuals are there too
    for part in obj.parts:  # mass properties as MuJoCo read them (principal axes in body)
        if part.inertial is not None:
            body = model.body(part.name).id
            axes = tf.quat_to_matrix(model.body_iquat[body])
            tensor = axes @ np.diag(model.body_inertia[body]) @ axes.T
            assert model.body_mass[body] == pytest.approx(part.inertial.mass, rel=1e-12)
            np.testing.assert_allclose(model.body_ipos[body], part.inertial.com, atol=1e-9)
            np.testing.assert_allclose(tensor, part.inertial.inertia,
                                       atol=1e-9 * np.abs(part.inertial.inertia).max())
    worst = 0.0
    for _ in range(samples):
        q = sample_configuration(obj, rng)
        for name, value in q.items():
            data.qpos[model.jnt_qposadr[model.joint(name).id]] = value
        mujoco.mj_kinematics(model, data)
        for part, pose in forward_kinematics(obj, q).items():
            body = model.body(part).id
            worst = max(worst, float(np.abs(data.xpos[body] - pose[:3, 3]).max()),
                        float(np.abs(data.xmat[body].reshape(3, 3) - pose[:3, :3]).max()))
    return worst


def exported_files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


def assert_round_trip(obj: ArticulatedObject, tmp_path: Path) -> Path:
    """import(export(obj)) equals obj without any repair warning, and
    export(import(export(obj))) is byte-identical, URDF and meshes."""
    first = urdf.save(obj, tmp_path / "first")
    with warnings.catch_warnings():
        warnings.simplefilter("error", Real2CodeWarning)
        back = urdf.load(first)
    assert differences(obj, back) == []
    assert back.metadata == obj.metadata
    urdf.save(back, tmp_path / "second")
    assert exported_files(tmp_path / "first") == exported_files(tmp_path / "second")
    return first


# -- round trips ----------------------------------------------------------------------------------
@pytest.mark.parametrize("build", [cabinet, single_part])
def test_round_trip_small_objects(build, tmp_path):
    obj = build()
    path = assert_round_trip(obj, tmp_path)
    rng = np.random.default_rng(7)
    assert pinocchio_matches(obj, path, rng) < 1e-6
    assert mujoco_matches(obj, path, rng) < 1e-6


def test_export_text(tmp_path):
    obj = cabinet()
    path = urdf.save(obj, tmp_path)
    text = path.read_text()
    assert path.name == "cabinet.urdf"
    assert 'xmlns:real2code="urn:real2code-export:urdf:1"' in text
    assert '<compiler angle="radian" discardvisual="false" fusestatic="false" strippath="false"/>' in text
    # URDF requires effort and velocity: the unknown velocity is a documented default, marked.
    assert f'velocity="{urdf.DEFAULT_VELOCITY!r}" real2code:velocity="none"' in text
    assert 'real2code:stiffness="2.0" real2code:springref="0.3" real2code:armature="0.01"' in text
    named = re.findall(r'filename="(meshes/[^"]+)"', text)
    assert named and all((tmp_path / rel).is_file() for rel in named)
    for part in obj.parts:  # (a piece equal to a mesh before it names that one's file)
        assert f'filename="meshes/{part.name}.obj"' in text
    assert urdf.save(obj, tmp_path).read_bytes() == text.encode()  # deterministic


@pytest.mark.parametrize("rpy", [
    (0.3, -0.2, 0.5), (np.pi, 0.0, -np.pi), (1e-17, 3.0, -3.1),
    (0.2, np.pi / 2, -0.7), (1.0, -np.pi / 2, 2.0),  # gimbal lock
    (0.2, np.pi / 2 - 1e-7, -0.7), (-2.0, 1e-5 - np.pi / 2, 3.0),  # next to it
])
def test_rpy_is_exact_and_stable(rpy):
    rotation = tf.rpy_to_matrix(rpy)
    written = stable_rpy(rotation)
    assert np.abs(tf.rpy_to_matrix(written) - rotation).max() <= 1e-12
    assert stable_rpy(tf.rpy_to_matrix(written)).tolist() == written.tolist()


# -- PartNet-Mobility: real files -----------------------------------------------------------------
@pytest.mark.partnet
@pytest.mark.parametrize("object_id", partnet_ids())
def test_partnet_round_trip(object_id, tmp_path):
    source = partnet_dir() / object_id / "mobility.urdf"
    with pytest.warns(Real2CodeWarning):  # repaired (no inertials, no effort...), not refused
        obj = urdf.load(source)
    validate(obj)
    assert obj.movable_joints
    path = assert_round_trip(obj, tmp_path)
    rng = np.random.default_rng(int(object_id))
    assert pinocchio_matches(obj, path, rng) < 1e-6
    assert mujoco_matches(obj, path, rng) < 1e-6


# -- broken input: one fixture each ---------------------------------------------------------------
def line_of(path: Path, needle: str) -> int:
    lines = path.read_text().splitlines()
    return next(i for i, text in enumerate(lines, start=1) if needle in text)


@pytest.mark.parametrize(("fixture", "element", "needle", "what"), [
    ("malformed_xml.urdf", "limit", "</joint>", "malformed XML"),
    ("missing_mesh.urdf", "<link name='door'>", "not_there.obj", "not found"),
    ("joint_cycle.urdf", "<joint name='a_to_c'>", '<joint name="a_to_c"', "cycle"),
    ("two_parents.urdf", "<joint name='b_to_a'>", '<joint name="b_to_a"', "already has parent"),
    ("two_roots.urdf", "<link name='stray'>", '<link name="stray">', "root"),
    ("nan_origin.urdf", "<joint name='hinge'>", 'xyz="0 nan 0"', "not finite"),
    ("zero_axis.urdf", "<joint name='hinge'>", "<axis", "zero length"),
    ("unknown_joint_type.urdf", "<joint name='hinge'>", 'type="hinge"', "unknown joint type"),
    ("unknown_parent.urdf", "<joint name='hinge'>", '<parent link="frame"', "not a link"),
    ("duplicate_link.urdf", "<link name='door'>", '<link name="door"/>', "duplicate"),
    ("not_collada_mesh.urdf", "<link name='base'>", "not_collada.dae", "not a Collada file"),
    ("unresolved_package.urdf", "<link name='base'>", "package://no_such_package",
     "cannot resolve 'package://no_such_package/meshes/base.stl'"),
    ("negative_largest_moment.urdf", "<link name='base'>", 'ixx="-0.01"',
     "no positive principal"),
])
def test_bad_input_names_file_element_and_line(fixture, element, needle, what):
    path = FIXTURES / fixture
    with pytest.raises(FormatError) as info:
        urdf.load(path)
    message = str(info.value)
    assert message.startswith(f"{path}:{line_of(path, needle)}: "), message
    assert element in message and what in message, message


# -- repairs of foreign files ---------------------------------------------------------------------
def write_obj(path: Path, mesh: Mesh) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(obj_bytes(mesh, exact=True))


INERTIAL = ('<inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" '
            'iyz="0" izz="0.01"/></inertial>')


def test_limit_without_effort_and_axis_are_repaired_mimic_carried(tmp_path):
    path = tmp_path / "repairs.urdf"
    path.write_text(f"""<robot name="repairs">
  <link name="base"/>
  <link name="door">{INERTIAL}</link>
  <link name="flap">{INERTIAL}</link>
  <joint name="hinge" type="revolute">
    <parent link="base"/><child link="door"/><axis xyz="0 0 2"/>
    <limit lower="0.2" upper="1"/>
  </joint>
  <joint name="flap hinge" type="revolute">
    <parent link="door"/><child link="flap"/>
    <limit lower="0" upper="1" effort="3" velocity="4"/>
    <mimic joint="hinge" multiplier="2"/>
  </joint>
</robot>""")
    with pytest.warns(Real2CodeWarning) as record:
        obj = urdf.load(path)
    messages = "\n".join(str(w.message) for w in record)
    assert "without effort and/or velocity" in messages and "'hinge'" in messages
    assert "normalised" in messages
    assert "'flap hinge' -> 'flap_hinge'" in messages
    hinge = obj.joint("hinge")
    assert hinge.axis.tolist() == [0.0, 0.0, 1.0]
    assert hinge.limits.effort is None and hinge.limits.velocity is None
    assert hinge.state == 0.2  # URDF has no observed state: q = 0, or the nearest limit
    assert obj.joint("flap_hinge").limits.effort == 3.0
    assert obj.joint("flap_hinge").mimic.joint == "hinge"  # carried, no longer ignored
    assert_round_trip(obj, tmp_path)  # the unknowns stay unknown through our own file


def test_inertia_limit_and_mass_repairs_are_warned_and_load_in_the_tools(tmp_path):
    """What real robot files carry and Pinocchio / MuJoCo load: a tensor negative by rounding,
    a zero tensor (a sensor frame), one off the triangle inequality, a moving massless link, a
    revolute joint without <limit>, one with only effort and velocity (lower == upper == 0), a
    slide with lower == upper, a tensor with a moment of zero up to rounding (a rod's, rotated
    and written to 4 digits, which MuJoCo refuses)."""
    zero = ('<inertial><mass value="0.1"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" '
            'izz="0"/></inertial>')
    rounding = ('<inertial><mass value="1"/><inertia ixx="-2e-22" ixy="0" ixz="0" iyy="1e-22" '
                'iyz="0" izz="3e-6"/></inertial>')
    triangle = ('<inertial><mass value="1"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" '
                'iyz="0" izz="0.01"/></inertial>')
    rod = ('<inertial><mass value="0.01"/><inertia ixx="0.2125" ixy="-0.005" ixz="0.0225" '
           'iyy="0.205" iyz="0.045" izz="0.0125"/></inertial>')
    path = tmp_path / "repairs.urdf"
    path.write_text(f"""<robot name="repairs">
  <link name="base">{rounding}</link>
  <link name="camera">{zero}</link>
  <link name="arm">{triangle}</link>
  <link name="virtual"/>
  <link name="hand">{INERTIAL}</link>
  <link name="finger">{INERTIAL}</link>
  <joint name="mount" type="fixed"><parent link="base"/><child link="camera"/></joint>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
  </joint>
  <joint name="virtual_z" type="revolute">
    <parent link="arm"/><child link="virtual"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="wrist" type="revolute">
    <parent link="virtual"/><child link="hand"/><axis xyz="0 1 0"/>
    <origin xyz="0 0 0.5"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="locked" type="prismatic">
    <parent link="hand"/><child link="finger"/><axis xyz="1 0 0"/><origin xyz="0.1 0 0"/>
    <limit lower="0.5" upper="0.5" effort="1" velocity="1"/>
  </joint>
  <link name="wheel">{INERTIAL}</link>
  <joint name="wheel" type="revolute">
    <parent link="base"/><child link="wheel"/><axis xyz="0 1 0"/><origin xyz="0 0.2 0"/>
    <limit effort="35" velocity="20"/>
  </joint>
  <link name="rod">{rod}</link>
  <joint name="slide" type="prismatic">
    <parent link="base"/><child link="rod"/><axis xyz="1 0 0"/><origin xyz="0 -0.2 0"/>
    <limit effort="1" lower="-1" upper="1" velocity="1"/>
  </joint>
</robot>""")
    with pytest.warns(Real2CodeWarning) as record:
        obj = urdf.load(path)
    messages = "\n".join(str(w.message) for w in record)
    for needle in ("<link name='base'>: inertia tensor is not positive definite",
                   "<link name='camera'>: inertia tensor is zero",
                   "<link name='arm'>: inertia tensor violates the triangle",
                   "<joint name='virtual_z'>: moves part 'virtual', which has no mass",
                   "<joint name='shoulder'>: a revolute joint without <limit>: imported as "
                   "continuous",
                   "<joint name='locked'>: <limit> lower == upper == 0.5: the slide cannot "
                   "move; imported as a fixed joint at q = 0.5",
                   "<joint name='wheel'>: <limit> lower == upper == 0: an empty range, which "
                   "MuJoCo loads unlimited; imported as continuous",
                   "<link name='rod'>: inertia tensor has a principal moment of zero up to "
                   "rounding"):
        assert needle in messages, messages
    np.testing.assert_allclose(np.linalg.eigvalsh(obj.part("arm").inertial.inertia),
                               [0.005, 0.005, 0.01], rtol=1e-5)
    np.testing.assert_allclose(np.linalg.eigvalsh(obj.part("base").inertial.inertia),
                               [1.5e-6, 1.5e-6, 3e-6], rtol=1e-5)
    assert obj.joint("shoulder").type is JointType.CONTINUOUS
    locked = obj.joint("locked")
    assert locked.type is JointType.FIXED
    np.testing.assert_allclose(locked.origin[:3, 3], [0.6, 0, 0])  # 0.1 + 0.5 along x
    assert obj.joint("wheel").type is JointType.CONTINUOUS
    assert obj.joint("wheel").drive_limits == DriveLimits(35.0, 20.0)  # kept, not dropped
    assert min(np.linalg.eigvalsh(obj.part("rod").inertial.inertia)) > 1e-12
    path = assert_round_trip(obj, tmp_path)  # the repaired model is what every tool loads
    rng = np.random.default_rng(0)
    assert pinocchio_matches(obj, path, rng) < 1e-6
    assert mujoco_matches(obj, path, rng) < 1e-6


def test_collada_scene_graph_and_unit(tmp_path):
    """A .dae in millimetres whose geometry sits under a translated, scaled node."""
    (tmp_path / "part.dae").write_text(COLLADA_MM)
    path = tmp_path / "robot.urdf"
    path.write_text('<robot name="dae"><link name="base"><visual><geometry>'
                    '<mesh filename="part.dae"/></geometry></visual></link></robot>')
    with pytest.warns(Real2CodeWarning):  # mass and collision made from the visual
        obj = urdf.load(path)
    # vertices 0..10 units, node: scale 2 then translate 100 units; 1 unit = 1 mm
    np.testing.assert_allclose(obj.part("base").visual.bounds(),
                               [[0.1, 0.0, 0.0], [0.12, 0.02, 0.0]], atol=1e-12)


@pytest.mark.parametrize("normals", ["numbers", "not numbers"])
def test_collada_with_normals_and_texture_coordinates_interleaved(tmp_path, normals):
    """A primitive's index list interleaves each corner's position, normal and texture
    coordinate (stride 3): the triangles are read from the positions at their offset, as
    pycollada reads them with every source read. The shading sources are not
    read at all: a normal array that is not numbers costs nothing."""
    from real2code_export.meshfiles import read_mesh

    normal_text = "0 0 1 " * 4 if normals == "numbers" else "up " * 12
    accessor = ('<technique_common><accessor source="#{0}-array" count="{1}" stride="{2}">'
                + "{3}</accessor></technique_common>")
    xyz = '<param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>'
    st = '<param name="S" type="float"/><param name="T" type="float"/>'
    (tmp_path / "quad.dae").write_text(f"""<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <library_geometries><geometry id="quad"><mesh>
    <source id="pos"><float_array id="pos-array" count="12">0 0 0 1 0 0 1 2 0 0 2 0</float_array>
      {accessor.format("pos", 4, 3, xyz)}</source>
    <source id="nrm"><float_array id="nrm-array" count="12">{normal_text}</float_array>
      {accessor.format("nrm", 4, 3, xyz)}</source>
    <source id="uv"><float_array id="uv-array" count="8">0 0 1 0 1 1 0 1</float_array>
      {accessor.format("uv", 4, 2, st)}</source>
    <vertices id="verts"><input semantic="POSITION" source="#pos"/>
      <input semantic="NORMAL" source="#nrm"/></vertices>
    <triangles count="2"><input semantic="VERTEX" source="#verts" offset="0"/>
      <input semantic="NORMAL" source="#nrm" offset="1"/>
      <input semantic="TEXCOORD" source="#uv" offset="2" set="0"/>
      <p>0 0 0 1 1 1 2 0 2  0 1 0 2 0 2 3 1 3</p></triangles>
  </mesh></geometry></library_geometries>
</COLLADA>
""")
    mesh = read_mesh(tmp_path / "quad.dae")
    corners = [[0, 0, 0], [1, 0, 0], [1, 2, 0], [0, 0, 0], [1, 2, 0], [0, 2, 0]]
    np.testing.assert_array_equal(mesh.vertices[mesh.faces].reshape(-1, 3), corners)
    if normals == "numbers":
        import collada

        whole = collada.Collada(str(tmp_path / "quad.dae")).geometries[0].primitives[0]
        np.testing.assert_array_equal(mesh.vertices[mesh.faces],
                                      whole.vertex[whole.vertex_index])


@pytest.mark.parametrize("kind", ["binary", "ascii", "ascii, two solids"])
def test_stl_is_read_as_trimesh_reads_it(tmp_path, kind):
    """STL is read without trimesh (its import costs more than a robot's USD export): the
    same triangles as trimesh.load(process=False), binary and ASCII, each corner met again
    the same vertex, as MuJoCo keeps them (a box: 8 vertices, not 36)."""
    import mujoco

    from real2code_export.meshfiles import read_mesh

    box = trimesh.creation.box((0.1, 0.2, 0.3))
    path = tmp_path / "part.stl"
    if kind == "binary":
        box.export(path, file_type="stl")
    else:
        text = trimesh.exchange.stl.export_stl_ascii(box)
        if kind == "ascii, two solids":
            moved = box.copy().apply_translation((1, 2, 3))
            text += trimesh.exchange.stl.export_stl_ascii(moved).replace("solid ", "solid b", 1)
        path.write_text(text)
    expected = trimesh.load(str(path), force="mesh", process=False)
    got = read_mesh(path)
    np.testing.assert_array_equal(got.vertices[got.faces], expected.triangles)  # same triangles
    assert len(got.vertices) == (16 if kind == "ascii, two solids" else 8)
    if kind == "binary":  # (MuJoCo reads binary STL only)
        spec = mujoco.MjSpec()
        spec.add_mesh(name="m", file=str(path))
        spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname="m")
        assert spec.compile().mesh_vertnum[0] == 8
    path.write_bytes(b"solid nothing\nendsolid nothing\n")
    with pytest.raises(FormatError, match="no triangles"):
        read_mesh(path, source=tmp_path / "robot.urdf", element="<link name='base'>")


@pytest.mark.parametrize("kind", ["binary", "ascii"])
def test_stl_corners_equal_in_value_are_one_vertex(tmp_path, kind):
    """Corners are welded by value, as MuJoCo and float comparison see them, in the order
    first met: -0.0 and 0.0 are one vertex (the sort runs on the coordinates' bits), in a
    binary STL's float32 and in ASCII numbers no float32 holds."""
    from real2code_export.meshfiles import read_mesh

    c = 0.1 if kind == "ascii" else 0.5  # 0.1: not a float32, the other sorting keys
    triangles = [[[0.0, 0.0, 0.0], [c, 0.0, 0.0], [0.0, c, 0.0]],
                 [[c, 0.0, -0.0], [c, c, 0.0], [-0.0, c, 0.0]]]
    path = tmp_path / "part.stl"
    if kind == "binary":
        path.write_bytes(trimesh.exchange.stl.export_stl(
            trimesh.Trimesh(np.reshape(triangles, (-1, 3)), np.arange(6).reshape(2, 3),
                            process=False)))
    else:
        path.write_text("solid s\n" + "".join(
            "facet normal 0 0 1\nouter loop\n" + "".join(f"vertex {x} {y} {z}\n"
                                                         for x, y, z in t)
            + "endloop\nendfacet\n" for t in triangles) + "endsolid s\n")
    got = read_mesh(path)
    np.testing.assert_array_equal(got.vertices, [[0, 0, 0], [c, 0, 0], [0, c, 0], [c, c, 0]])
    assert not np.signbit(got.vertices).any()  # each vertex as first met
    np.testing.assert_array_equal(got.faces, [[0, 1, 2], [1, 3, 2]])


def test_stl_welding_by_one_key_is_welding_by_value(monkeypatch):
    """A binary STL's float32 corners are welded through one 64-bit key each: the same
    vertices and faces as sorting by the coordinates' bits, NaN corners each a vertex of its
    own (unequal to themselves), and corners sharing a key without being equal (forced here:
    z left out of the key) told apart."""
    from real2code_export import meshfiles

    rng = np.random.default_rng(7)
    corners = (rng.integers(-2, 3, size=(3000, 3)) * 0.25).astype(np.float32)
    corners[::7, 1] = -0.0
    corners[5] = corners[6] = np.nan

    def same(a, b):
        return a.vertices.tobytes() == b.vertices.tobytes() and np.array_equal(a.faces, b.faces)

    plain = corners[9:]  # (no NaN; whole triangles)
    assert meshfiles._float32_runs(plain) is not None
    welded = meshfiles._welded(plain)
    assert len(welded.vertices) == len(np.unique(plain + 0.0, axis=0)) < len(plain)
    monkeypatch.setattr(meshfiles, "_float32_runs", lambda c: None)
    reference = meshfiles._welded(plain)
    monkeypatch.undo()
    assert same(welded, reference)
    with_nan = meshfiles._welded(corners[:2997])
    assert np.isnan(with_nan.vertices).any(axis=1).sum() == 2
    monkeypatch.setattr(meshfiles, "_KEY_MIX", np.uint64(0))
    assert meshfiles._float32_runs(plain) is None
    assert same(meshfiles._welded(plain), reference)


def test_obj_vertices_are_the_numbers_written(tmp_path):
    """An OBJ's vertices are the nearest float64 to each number in its ``v`` lines (the file's
    first line a ``v`` line, tabs, a w component, many digits), whatever tinyobjloader's own
    parser rounds them to."""
    from real2code_export.meshfiles import read_mesh

    numbers = ["0.1", "-2.718281828459045", "3.0000000000000004", "1e-7", "123456.789012345",
               "-0.30000000000000004", "7", "8.5", "9.25"]
    path = tmp_path / "part.obj"
    path.write_text(f"v {numbers[0]} {numbers[1]}\t{numbers[2]} 1.0\n"
                    f"# a comment\nv\t{numbers[3]} {numbers[4]} {numbers[5]}\n"
                    f"vn 0 0 1\nv {' '.join(numbers[6:])}\nf 1 2 3\n")
    mesh = read_mesh(path)
    np.testing.assert_array_equal(mesh.vertices.ravel(), [float(x) for x in numbers])
    np.testing.assert_array_equal(mesh.faces, [[0, 1, 2]])


COLLADA_MM = """<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="millimeter" meter="0.001"/><up_axis>Y_UP</up_axis></asset>
  <library_geometries><geometry id="tri" name="tri"><mesh>
    <source id="pos"><float_array id="pos-array" count="9">0 0 0 10 0 0 0 10 0</float_array>
      <technique_common><accessor source="#pos-array" count="3" stride="3">
        <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
      </accessor></technique_common></source>
    <vertices id="verts"><input semantic="POSITION" source="#pos"/></vertices>
    <triangles count="1"><input semantic="VERTEX" source="#verts" offset="0"/><p>0 1 2</p>
    </triangles>
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="scene"><node id="n">
    <translate>100 0 0</translate><scale>2 2 2</scale>
    <instance_geometry url="#tri"><bind_material><technique_common>
      <instance_material symbol="m" target="#missing-material"/>
    </technique_common></bind_material></instance_geometry>
  </node></visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#scene"/></scene>
</COLLADA>
"""


def test_primitives_materials_inertial_frame_and_packages(tmp_path):
    package = tmp_path / "my_robot"
    write_obj(package / "meshes" / "panel.obj", box([0.1, 0.2, 0.3]))
    path = package / "urdf" / "robot.urdf"
    path.parent.mkdir(parents=True)
    path.write_text("""<robot name="prims">
  <material name="red"><color rgba="1 0 0 1"/></material>
  <link name="base">
    <visual><geometry><box size="0.2 0.2 0.2"/></geometry><material name="red"/></visual>
  </link>
  <link name="arm">
    <inertial>
      <origin xyz="0 0 0.1" rpy="0 0 1.5707963267948966"/>
      <mass value="2"/><inertia ixx="1" ixy="0" ixz="0" iyy="2" iyz="0" izz="2.5"/>
    </inertial>
    <visual><origin xyz="0 0 0.5"/><geometry><cylinder radius="0.05" length="1"/></geometry></visual>
    <visual><geometry><sphere radius="0.1"/></geometry></visual>
    <collision>
      <geometry><mesh filename="package://my_robot/meshes/panel.obj" scale="2 2 2"/></geometry>
    </collision>
  </link>
  <joint name="shoulder" type="continuous">
    <parent link="base"/><child link="arm"/><axis xyz="0 1 0"/>
  </joint>
</robot>""")
    with pytest.warns(Real2CodeWarning) as record:
        obj = urdf.load(path)
    messages = "\n".join(str(w.message) for w in record)
    assert "no <collision> in links 'base'" in messages
    assert "no <inertial> in links 'base'" in messages
    base, arm = obj.part("base"), obj.part("arm")
    assert base.color == (1.0, 0.0, 0.0, 1.0)
    assert base.inertial is not None  # computed from the box: the root has a visual
    assert base.collision  # made from the visual, with the warning above
    np.testing.assert_allclose(np.ptp(arm.collision[0].vertices, axis=0), [0.2, 0.4, 0.6])
    np.testing.assert_allclose(arm.inertial.com, [0.0, 0.0, 0.1])
    # The tensor was given in axes turned 90 degrees about z: in link axes ixx and iyy swap.
    np.testing.assert_allclose(arm.inertial.inertia, np.diag([2.0, 1.0, 2.5]), atol=1e-12)
    z = arm.visual.vertices[:, 2]
    assert z.min() == pytest.approx(-0.1) and z.max() == pytest.approx(1.0)  # cylinder moved up


COLLADA_TWO_COLOURS = """<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <library_effects>
    <effect id="red-fx"><profile_COMMON><technique sid="t"><phong>
      <diffuse><color>1 0 0 1</color></diffuse></phong></technique></profile_COMMON></effect>
    <effect id="blue-fx"><profile_COMMON><technique sid="t"><phong>
      <diffuse><color>0 0 1 1</color></diffuse></phong></technique></profile_COMMON></effect>
  </library_effects>
  <library_materials>
    <material id="red"><instance_effect url="#red-fx"/></material>
    <material id="blue"><instance_effect url="#blue-fx"/></material>
  </library_materials>
  <library_geometries><geometry id="g"><mesh>
    <source id="pos"><float_array id="pos-array" count="15">0 0 0 2 0 0 2 1 0 0 1 0 4 0 0
      </float_array><technique_common><accessor source="#pos-array" count="5" stride="3">
        <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
      </accessor></technique_common></source>
    <vertices id="verts"><input semantic="POSITION" source="#pos"/></vertices>
    <triangles count="2" material="r"><input semantic="VERTEX" source="#verts" offset="0"/>
      <p>0 1 2 0 2 3</p></triangles>
    <triangles count="1" material="b"><input semantic="VERTEX" source="#verts" offset="0"/>
      <p>1 4 2</p></triangles>
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="scene"><node id="n">
    <instance_geometry url="#g"><bind_material><technique_common>
      <instance_material symbol="r" target="#red"/><instance_material symbol="b" target="#blue"/>
    </technique_common></bind_material></instance_geometry>
  </node></visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#scene"/></scene>
</COLLADA>
"""


@pytest.mark.parametrize("suffix", [".obj", ".dae"])
def test_a_mesh_files_colours_are_kept_per_face_in_every_format(tmp_path, suffix):
    """A visual without a <material> shows its mesh file's own colours (an OBJ's MTL ``Kd``,
    a Collada material's diffuse, read by tinyobjloader and pycollada): each triangle keeps
    its own, and the part's one colour (what the renderer draws) is their area-weighted
    mean, as before the file's colours were kept; every format's export reads back the same
    colours, per face and the part's (the blue piece, one triangle, a mesh file MuJoCo
    loads: it refuses fewer than 4 vertices; exported from the OBJ only)."""
    from real2code_export import formats
    from real2code_export.meshfiles import read_mesh_file

    # Red: a 2 x 1 rectangle (area 2); blue: a triangle of area 1 beside it.
    if suffix == ".obj":
        (tmp_path / "two.mtl").write_text("newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n")
        (tmp_path / "two.obj").write_text(
            "mtllib two.mtl\nv 0 0 0\nv 2 0 0\nv 2 1 0\nv 0 1 0\nv 4 0 0\n"
            "usemtl red\nf 1 2 3\nf 1 3 4\nusemtl blue\nf 2 5 3\n")
    else:
        (tmp_path / "two.dae").write_text(COLLADA_TWO_COLOURS)
    red, blue = (1.0, 0.0, 0.0, 1.0), (0.0, 0.0, 1.0, 1.0)
    read = read_mesh_file(tmp_path / f"two{suffix}")
    assert read.runs == ((2, red), (1, blue))
    np.testing.assert_allclose(read.color, [2 / 3, 0.0, 1 / 3, 1.0], atol=1e-9)
    (tmp_path / "lamp.urdf").write_text(f"""<robot name="lamp">
  <link name="shade">{INERTIAL}
    <visual><geometry><mesh filename="two{suffix}"/></geometry></visual>
    <collision><geometry><box size="1 1 1"/></geometry></collision>
  </link>
</robot>""")
    obj = urdf.load(tmp_path / "lamp.urdf")
    shade = obj.part("shade")
    assert shade.visual.colors == ((2, red), (1, blue))
    assert shade.color == read.color
    if suffix == ".dae":
        return  # (the exports hold the same runs and colour whichever reader made them)
    exported = formats.export(obj, tmp_path / "out", formats=["mjcf", "urdf", "usd", "gltf"])
    for name, path in exported.items():
        back = formats.load(path)
        assert back.part("shade").visual.colors == shade.visual.colors, name
        np.testing.assert_allclose(back.part("shade").color, shade.color, atol=1e-7,
                                   err_msg=name)


def test_exported_mesh_missing_is_reported(tmp_path):
    path = urdf.save(cabinet(), tmp_path / "out")
    shutil.rmtree(tmp_path / "out" / "meshes")
    with pytest.raises(FormatError, match=r"cabinet\.urdf:\d+: <link name='body'>: mesh file not"):
        urdf.load(path)


def test_a_default_xml_namespace_on_robot_is_read_as_urdfdom_reads_it(tmp_path):
    """A real file (Drake-style `<robot xmlns="...">`): ROS's urdfdom ignores the namespace,
    so we read it the same, with a warning naming it; a foreign root is still refused."""
    text = """<robot name="arm" xmlns="https://drake.mit.edu">
  <link name="base"/>
  <link name="arm"><inertial><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <transmission name="t"><joint name="elbow"/></transmission>
</robot>"""
    path = tmp_path / "ns.urdf"
    path.write_text(text)
    with pytest.warns(Real2CodeWarning) as record:
        obj = urdf.load(path)
    said = " ".join(str(w.message) for w in record)
    assert "drake.mit.edu" in said and "<transmission> (line 7)" in said
    assert obj.joint("shoulder").limits.upper == 1.0
    assert np.allclose(obj.joint("shoulder").axis, [0, 1, 0])
    (tmp_path / "other.urdf").write_text('<model xmlns="https://example.org"/>')
    with pytest.raises(FormatError, match="root element must be <robot>"):
        urdf.load(tmp_path / "other.urdf")


def test_floating_base_through_every_format(tmp_path):
    """A URDF floating joint (from the ``world`` link, the one MuJoCo's URDF import takes) is
    a floating joint: every export reads back equal and agrees with the source; a floating
    base hanging from a root named otherwise keeps that name through MJCF's world body."""
    from real2code_export.check import check_files
    from real2code_export.formats import export, load, mjcf

    source = FIXTURES / "floating_base.urdf"
    obj = urdf.load(source)
    assert obj.joint("free").type.value == "floating" and obj.root.name == "world"
    np.testing.assert_allclose(forward_kinematics(obj)["body"][:3, 3], [0.1, 0.2, 0.5])
    # An MJCF free joint's damping and armature (a USD free body has no joint prim for them).
    obj.joint("free").dynamics = Dynamics(damping=0.1, armature=0.04)
    written = export(obj, tmp_path / "out")
    for fmt, path in written.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Real2CodeWarning)
            back = load(path)
        assert not [d for d in differences(obj, back) if "object name" not in d], fmt
    report = check_files(list(written.values()), source=source, n_configurations=5,
                         validate=False)
    # the free joint's dynamics given above are not the source's: check names them, only them
    assert {m.kind for m in report.mismatches} == {"dynamics"}, report.mismatches
    assert all("joint 'free'" in m.message for m in report.mismatches), report.mismatches

    odom = tmp_path / "odom.urdf"
    odom.write_text(source.read_text().replace('"world"', '"odom"'))
    obj = urdf.load(odom)
    back = mjcf.load(mjcf.save(obj, tmp_path / "odom_mjcf"))
    assert back.root.name == "odom" and not differences(obj, back)


def test_free_bodies_below_a_root_of_another_name_hang_from_an_added_world_link(tmp_path):
    """A floating joint from a root part not named ``world`` (a USD scene's body the world
    holds, with free bodies beside it): MuJoCo's URDF import allows a free joint only from
    a link named ``world`` ("free joint can only be used on top level"), so the writer adds
    one, fixed to the root part at the origin, both marked real2code:added. MuJoCo and
    Pinocchio load the export, which agrees with the MJCF one; our reader takes the link out
    again. A marked link that is not what the writer adds is read as it stands, warned; a
    part named ``world`` below the root is refused, named."""
    import mujoco

    from real2code_export.check import check_files
    from real2code_export.errors import ModelError
    from real2code_export.formats import export

    source = tmp_path / "scene.urdf"
    source.write_text((FIXTURES / "floating_base.urdf").read_text().replace(
        '<link name="world"/>', '<link name="anchor"><inertial><mass value="2.0"/><inertia '
        'ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>').replace(
        '<parent link="world"/>', '<parent link="anchor"/>'))
    obj = urdf.load(source)
    assert obj.root.name == "anchor" and obj.joint("free").parent == "anchor"
    written = export(obj, tmp_path / "out", formats=["mjcf", "urdf"])
    text = written["urdf"].read_text()
    assert '<link name="world" real2code:added="true"/>' in text
    assert '<joint name="world_to_anchor" type="fixed" real2code:added="true">' in text
    model = mujoco.MjModel.from_xml_path(str(written["urdf"]))
    free = model.joint("free")
    assert int(free.type[0]) == mujoco.mjtJoint.mjJNT_FREE
    assert int(model.body_parentid[int(free.bodyid[0])]) == 0  # a top-level body
    assert pinocchio_matches(obj, written["urdf"], np.random.default_rng(0)) < 1e-6
    assert not differences(obj, urdf.load(written["urdf"]))
    report = check_files(list(written.values()), n_configurations=5, validate=False)
    assert report.ok, report.mismatches

    edited = tmp_path / "edited.urdf"
    edited.write_text(text.replace('<origin xyz="0.0 0.0 0.0" rpy="0.0 0.0 0.0"/>\n'
                                   '    <parent link="world"/>',
                                   '<origin xyz="0.0 0.0 1.0" rpy="0.0 0.0 0.0"/>\n'
                                   '    <parent link="world"/>', 1))
    assert edited.read_text() != text
    with pytest.warns(Real2CodeWarning, match="<link name='world'>: marked real2code:added "
                                              "but not as our writer adds it"):
        back = urdf.load(edited)
    assert back.root.name == "world" and back.joint("world_to_anchor").type.value == "fixed"

    obj.parts[-1].name = "world"
    obj.joints[-1].child = "world"
    with pytest.raises(ModelError, match="part 'world'.*only from a link named 'world'"):
        urdf.save(obj, tmp_path / "refused", write_meshes=False)


def test_mimic_joints_through_every_format(tmp_path):
    """<mimic> is carried: MJCF as a joint equality (MuJoCo applies it), URDF as <mimic>, USD
    as NewtonMimicAPI, glTF and object.json in our metadata; a mimic of a joint that does not
    exist is dropped with a warning naming both."""
    import mujoco

    from real2code_export.formats import export, load

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        obj = urdf.load(FIXTURES / "mimic_gripper.urdf")
    said = "\n".join(str(w.message) for w in caught)
    assert "<joint name='tip_bend'>" in said and "'no_such_joint' dropped" in said
    mimic = obj.joint("right_finger").mimic
    assert (mimic.joint, mimic.multiplier, mimic.offset) == ("left_finger", -1.0, 0.001)
    assert obj.joint("tip_bend").mimic is None
    written = export(obj, tmp_path / "out", formats=["mjcf", "urdf", "usd", "gltf", "json"])
    for fmt, path in written.items():
        back = load(path)
        assert not [d for d in differences(obj, back) if "object name" not in d], fmt
    model = mujoco.MjModel.from_xml_path(str(written["mjcf"]))
    assert int(model.eq_type[0]) == mujoco.mjtEq.mjEQ_JOINT
    assert model.joint(int(model.eq_obj1id[0])).name == "right_finger"
    np.testing.assert_allclose(model.eq_data[0][:5], [0.001, -1.0, 0, 0, 0])
    assert 'newton:mimicJoint = </mimic_gripper/Physics/left_finger>' in written["usd"].read_text()


def test_unread_elements_are_kept_and_written_back(tmp_path):
    """<transmission> and <gazebo> have no place in the model: kept (warned) in the metadata,
    carried by every format, and written back as they were by the URDF writer."""
    from real2code_export.formats import export, load

    text = (FIXTURES / "floating_base.urdf").read_text().replace("</robot>", """
  <transmission name="elbow_tx"><type>transmission_interface/SimpleTransmission</type>
    <joint name="elbow"><hardwareInterface>EffortJointInterface</hardwareInterface></joint>
  </transmission>
  <gazebo reference="arm"><material>Gazebo/Grey</material></gazebo>
</robot>""")
    source = tmp_path / "tx.urdf"
    source.write_text(text)
    with pytest.warns(Real2CodeWarning, match=r"kept as metadata 'urdf_elements'.*<transmission>"):
        obj = urdf.load(source)
    kept = obj.metadata["urdf_elements"]
    assert [k.split(" ", 1)[0] for k in kept] == ["<transmission", "<gazebo"]
    written = export(obj, tmp_path / "out", formats=["mjcf", "usd", "gltf"])
    for path in written.values():
        again = urdf.load(urdf.save(load(path), tmp_path / path.suffix[1:]))
        assert again.metadata == obj.metadata
    out = (tmp_path / "xml" / "floating_base.urdf").read_text()
    assert "<hardwareInterface>EffortJointInterface</hardwareInterface>" in out
    assert "urdf_elements" not in out  # the elements themselves, not their text twice


def test_an_unexpanded_xacro_is_refused_saying_so(tmp_path):
    """A .urdf that is still a xacro (``${...}``, ``$(arg ...)``): refused, naming the
    element and what to do."""
    source = tmp_path / "arm.urdf"
    source.write_text((FIXTURES / "floating_base.urdf").read_text().replace(
        '<joint name="elbow" type="revolute">', '<joint name="elbow" type="revolute">'
        '<origin xyz="${arm_length} 0 0"/>', 1))
    with pytest.raises(FormatError, match=r"<joint name='elbow'>: <origin> xyz='\$\{arm_length"
                       r"\} 0 0' is not a list of numbers \(unexpanded xacro: expand"):
        urdf.load(source)


@pytest.mark.parametrize("declared", [True, False])
def test_a_robot_of_xacro_macro_calls_is_refused_saying_so(tmp_path, declared):
    """A .xacro saved as .urdf whose links all come from macros (``<xacro:make_pelvis/>``):
    urdfdom and MuJoCo refuse a robot without links; so do we, saying what it holds."""
    xmlns = ' xmlns:xacro="http://ros.org/wiki/xacro"' if declared else ""
    source = tmp_path / "pelvis.urdf"
    source.write_text(f'<robot name="val"{xmlns}>\n  <!-- yaw -->\n  <xacro:make_pelvis/>\n'
                      '  <xacro:include_sensors port="/dev/usb0"/>\n</robot>\n')
    with pytest.raises(FormatError, match=r"pelvis.urdf:1: <robot name='val'>: has no <link> "
                       r"\(it holds 2 unexpanded xacro element\(s\), the first "
                       r"<xacro:make_pelvis> at line 3: expand the file with xacro first\)"):
        urdf.load(source)


def test_children_of_links_and_joints_no_format_holds_are_kept(tmp_path):
    """A joint's <safety_controller> and <calibration> and a link's <contact> (ROS's soft
    limits and homing references, Bullet's contact) have no place in the model: kept in the
    metadata, warned, and written back into their element by the URDF writer, also after a
    trip through MJCF (they were named and dropped). (A <material>'s <texture> is read where
    a visual uses it: tests/test_textures.py.)"""
    text = (FIXTURES / "floating_base.urdf").read_text().replace(
        "</robot>", '<material name="skin"><texture filename="skin.png"/></material>'
        '<material name="bare"><color rgba="1 0 0 1"/><texture/></material></robot>'
    ).replace(
        '<joint name="elbow" type="revolute">', '<joint name="elbow" type="revolute">'
        '<safety_controller soft_lower_limit="-1" k_position="10" k_velocity="1"/><calibration rising="0"/>'
        ).replace('<link name="arm">', '<link name="arm"><contact><lateral_friction '
                  'value="1"/></contact>')
    assert text.count("safety_controller") == 1 and text.count("<contact>") == 1
    source = tmp_path / "extra.urdf"
    source.write_text(text)
    with pytest.warns(Real2CodeWarning) as said:
        obj = urdf.load(source)
    said = " ".join(str(w.message) for w in said)
    assert re.search(r"kept as metadata 'urdf_elements' \(the URDF writer writes them back "
                     r"into their element; no other format acts on them\): <contact> in "
                     r"<link name='arm'> \(line \d+\), <safety_controller> in <joint "
                     r"name='elbow'> \(line \d+\), <calibration> in <joint name='elbow'>",
                     said), said
    assert "<material name='bare'>" not in said  # an empty <texture/> holds nothing to read
    from lxml import etree

    from real2code_export.formats import mjcf

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        via_mjcf = urdf.load(urdf.save(mjcf.load(mjcf.save(obj, tmp_path / "mjcf")),
                                       tmp_path / "via_mjcf"))
    with warnings.catch_warnings(record=True) as again:
        warnings.simplefilter("always")
        back = urdf.load(urdf.save(obj, tmp_path / "out"))
    assert not [w for w in again if "kept as metadata" in str(w.message)]  # (ours, marked)
    for read in (back, via_mjcf):
        assert read.metadata["urdf_elements"] == obj.metadata["urdf_elements"]
    robot = etree.parse(str(tmp_path / "via_mjcf" / f"{obj.name}.urdf")).getroot()
    elbow = robot.find("joint[@name='elbow']")
    assert elbow.find("safety_controller").get("soft_lower_limit") == "-1"
    assert elbow.find("calibration").get("rising") == "0"
    assert robot.find("link[@name='arm']/contact/lateral_friction").get("value") == "1"


def test_visuals_of_several_colours_are_kept_in_every_format(tmp_path):
    """A link whose visuals differ in colour (a box, two meshes) keeps each visual's colour
    per face, its own triangles grouped by colour: MJCF a geom per colour, URDF a <visual>
    per colour (here per placement of the one mesh file, each of one colour), USD GeomSubsets bound to a material per colour, glTF a primitive per
    colour; every export reads back equal. Where one visual has no colour, the part's is the
    coloured ones' area-weighted mean, said (as where a colour comes from a mesh file's
    own materials)."""
    import json
    import struct

    from real2code_export.formats import export
    from real2code_export.formats import load as load_any
    from real2code_export.model import differences

    tetra = trimesh.Trimesh([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]],
                            [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], process=False)
    tetra.export(tmp_path / "tetra.obj")

    def visual(geometry, colour, z):
        material = "" if colour is None else f'<material name="m{z}"><color rgba="{colour}"/>' \
                                                 '</material>'
        return f'<visual><origin xyz="0 0 {z}"/><geometry>{geometry}</geometry>{material}</visual>'

    mesh = '<mesh filename="tetra.obj"/>'
    links = (visual(mesh, "1 0 0 1", 0) + visual('<box size="0.1 0.1 0.1"/>', "0 0 1 1", 1)
             + visual(mesh, "0 1 0 1", 2) + visual(mesh, "1 0 0 1", 3))
    source = tmp_path / "three.urdf"
    source.write_text(f'<robot name="three"><link name="base">{links}</link></robot>')
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        obj = urdf.load(source)
    assert not [w for w in said if "several colours" in str(w.message)], [str(w.message) for w in said]
    base = obj.parts[0]
    red, green, blue = (1.0, 0.0, 0.0, 1.0), (0.0, 1.0, 0.0, 1.0), (0.0, 0.0, 1.0, 1.0)
    assert base.color == red
    assert base.visual.colors == ((8, red), (4, green), (12, blue))  # the box last: a shape
    written = export(obj, tmp_path / "out", formats=["mjcf", "urdf", "usd", "gltf", "json"])
    for fmt, path in written.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Real2CodeWarning)
            back = load_any(path)
        assert [d for d in differences(obj, back) if "collision" not in d] == [], fmt
    xml = written["mjcf"].read_text()
    assert xml.count('rgba="1 0 0 1"') >= 1 and 'rgba="0 1 0 1"' in xml \
        and 'rgba="0 0 1 1"' in xml, xml
    # (the one mesh file placed three times: a <visual> per placement naming one file, each
    # at its origin and of its colour; the box a shape)
    urdf_text = written["urdf"].read_text()
    assert urdf_text.count("<visual") == 4 and urdf_text.count('filename="meshes/base_mesh_0.obj"') == 3
    assert not list((tmp_path / "out" / "meshes").glob("base_colour_*.obj"))
    usda = written["usd"].read_text()
    # (the one mesh file placed three times: its data once, a prim per placement bound to
    # its colour's material; the box a shape)
    assert usda.count("references = </three/MeshAssets/mesh_0>") == 3 and "base_colour_1" in usda
    data = written["gltf"].read_bytes()
    doc = json.loads(data[20:20 + struct.unpack_from("<I", data, 12)[0]])
    assert [len(m["primitives"]) for m in doc["meshes"] if m["name"] == "base"] == [3]

    source.write_text('<robot name="three"><link name="base">' + links.replace(
        '<material name="m2"><color rgba="0 1 0 1"/></material>', "") + "</link></robot>")
    with pytest.warns(Real2CodeWarning, match=r"visuals of several colours, some faces of no "
                      r"stated colour .*, in links 'base' \(2\): the part's colour is their "
                      r"area-weighted mean"):
        obj = urdf.load(source)
    assert obj.parts[0].visual.colors == () and obj.parts[0].color != red


def test_what_urdfdom_reads_past_is_repaired_and_loads_in_the_tools(tmp_path):
    """pybullet's URDFs: an XML declaration saying version "0.0" after a blank line, a
    <material> inside <geometry> after the shape, a zero-radius sphere (a contact point), NUL
    bytes after the document, a slide "limited" at SDF's +-1e16. urdfdom (Pinocchio) and
    MuJoCo load them; so do we, each repair warned with its element and line."""
    path = tmp_path / "bullet.urdf"
    path.write_bytes(f"""
<?xml version="0.0" ?>
<robot name="bullet">
  <link name="base">{INERTIAL}
    <visual><geometry><box size="0.1 0.1 0.1"/><material name="grey"/></geometry></visual>
  </link>
  <link name="toe">{INERTIAL}
    <collision><geometry><sphere radius="0.0"/></geometry></collision>
  </link>
  <joint name="ankle" type="revolute"><parent link="base"/><child link="toe"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <link name="cart">{INERTIAL}</link>
  <joint name="rail" type="prismatic"><parent link="base"/><child link="cart"/>
    <axis xyz="1 0 0"/><limit lower="-1e16" upper="1e16" effort="0" velocity="0"/></joint>
</robot>
""".encode() + b"\x00\x00")
    with pytest.warns(Real2CodeWarning) as record:
        obj = urdf.load(path)
    messages = "\n".join(str(w.message) for w in record)
    for needle in ("""XML declaration '<?xml version="0.0" ?>' is not at the start""",
                   "NUL bytes after the document: ignored",
                   "bullet.urdf:5: <link name='base'>: <geometry> holds <material> after its "
                   "<box>: ignored",
                   "bullet.urdf:8: <link name='toe'>: <sphere> of zero size (radius='0.0') has "
                   "no surface: left out"):
        assert needle in messages, messages
    assert obj.part("toe").collision == [] and obj.part("base").visual is not None
    # +-1e16 is no limit: a slide without a range, its effort and velocity kept
    assert obj.joint("rail").type is JointType.PRISMATIC and obj.joint("rail").limits is None
    assert obj.joint("rail").drive_limits == DriveLimits(0.0, 0.0)
    path = assert_round_trip(obj, tmp_path)
    rng = np.random.default_rng(0)
    assert pinocchio_matches(obj, path, rng) < 1e-6
    assert mujoco_matches(obj, path, rng) < 1e-6


def test_a_tiny_links_singular_tensor_is_raised_enough_for_mujoco(tmp_path):
    """A 4 g finger's CAD tensor, singular (one moment -2e-24 beside 6e-9): raised by 1e-6 of
    its largest moment alone (6e-15), MuJoCo's diagonalisation of the rotated fullinertia
    found it not positive and refused the MJCF export; the raise now keeps it positive. A
    1e-7 kg "virtual" link's 3e-22, under mjMINVAL, is raised too."""
    mujoco = pytest.importorskip("mujoco")
    from real2code_export.formats import mjcf

    path = tmp_path / "finger.urdf"
    path.write_text(f"""<robot name="finger"><link name="base">{INERTIAL}</link>
  <link name="tip"><inertial><mass value="0.00402906255365732"/>
    <inertia ixx="5.16879700036578E-09" ixy="5.29580863145471E-10" ixz="-1.8902693040652E-09"
      iyy="5.53816725297636E-09" iyz="1.3427085224947E-09" izz="1.12172097508837E-09"/>
  </inertial></link>
  <joint name="j" type="revolute"><parent link="base"/><child link="tip"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <link name="virtual"><inertial><mass value="1e-07"/>
    <inertia ixx="3.3e-22" ixy="0" ixz="0" iyy="3.3e-22" iyz="0" izz="5e-22"/></inertial></link>
  <joint name="mount" type="fixed"><parent link="base"/><child link="virtual"/></joint>
</robot>""")
    with pytest.warns(Real2CodeWarning) as record:
        obj = urdf.load(path)
    messages = "\n".join(str(w.message) for w in record)
    for needle in ("<link name='tip'>: inertia tensor is not positive definite",
                   "<link name='virtual'>: inertia tensor is zero"):  # under mjMINVAL
        assert needle in messages, messages
    assert mujoco.MjSpec.from_file(str(mjcf.save(obj, tmp_path / "out"))).compile().nbody == 4


def test_a_plate_on_the_triangle_boundary_by_rounding_is_balanced_for_mujoco(tmp_path):
    """A CAD exporter's thin plate: A + B = C up to 6e-16 of C, with products of inertia.
    Pinocchio loads it, MuJoCo refuses it ("inertia must satisfy A + B >= C"), and so it
    refused our URDF and MJCF exports while our looser test let it through: it is balanced,
    warned, and both exports load in MuJoCo."""
    mujoco = pytest.importorskip("mujoco")
    from real2code_export.formats import mjcf

    path = tmp_path / "plate.urdf"
    path.write_text(f"""<robot name="plate"><link name="base">{INERTIAL}</link>
  <link name="knee"><inertial><mass value="37.4804521490049"/>
    <inertia ixx="0.211387187948835" ixy="0.00352813969999868" ixz="-0.000112168416437373"
      iyy="0.000322803193524901" iyz="0.00721821701372064" izz="0.211201747394794"/>
  </inertial></link>
  <joint name="j" type="revolute"><parent link="base"/><child link="knee"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>""")
    with pytest.raises(ValueError, match="A [+] B >= C"):
        mujoco.MjSpec.from_file(str(path)).compile()
    with pytest.warns(Real2CodeWarning, match="<link name='knee'>: inertia tensor violates the "
                      "triangle inequality"):
        obj = urdf.load(path)
    for exported in (urdf.save(obj, tmp_path / "urdf"), mjcf.save(obj, tmp_path / "mjcf")):
        assert mujoco.MjSpec.from_file(str(exported)).compile().nbody == 3


def test_an_undeclared_namespace_prefix_is_declared_and_loads_in_the_tools(tmp_path):
    """Old Gazebo extensions (``<sensor:camera>``) use XML prefixes they never declare:
    libxml2 refuses the file, urdfdom (Pinocchio) and MuJoCo read past it. So do we, warned
    with the prefix and line; the <gazebo> element is kept as any unread tag, written back
    declared, and the source is compared in both its tools."""
    import mujoco
    import pinocchio

    from real2code_export.probes.mujoco import urdf_kinematics

    path = tmp_path / "gazebo.urdf"
    path.write_text(f"""<robot name="gazebo">
  <link name="base">{INERTIAL}</link>
  <link name="head">{INERTIAL}</link>
  <joint name="pan" type="revolute"><parent link="base"/><child link="head"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <gazebo reference="head">
    <sensor:camera name="rgb"><controller:plugin name="p"/></sensor:camera>
  </gazebo>
</robot>
""")
    with pytest.warns(Real2CodeWarning) as record:
        obj = urdf.load(path)
    messages = "\n".join(str(w.message) for w in record)
    for prefix in ("sensor", "controller"):
        assert f"gazebo.urdf:7: the XML namespace prefix '{prefix}'" in messages, messages
    assert [j.name for j in obj.joints] == ["pan"]
    pinocchio.buildModelFromUrdf(str(path))
    assert mujoco.MjSpec.from_string(urdf_kinematics(path)).compile().njnt == 1
    path = urdf.save(obj, tmp_path / "export")  # the <gazebo> written back, declared
    with pytest.warns(Real2CodeWarning) as record:
        back = urdf.load(path)
    assert "namespace prefix" not in "\n".join(str(w.message) for w in record)
    assert differences(obj, back) == [] and back.metadata == obj.metadata
    rng = np.random.default_rng(0)
    assert pinocchio_matches(obj, path, rng) < 1e-6
    assert mujoco_matches(obj, path, rng) < 1e-6


def test_continuous_joints_keep_their_effort_and_velocity_in_every_format(tmp_path):
    """A continuous joint's <limit effort velocity> (its range ignored, as urdfdom does) and
    a slide without a range's effort and velocity: carried by every format (URDF <limit> on
    the continuous joint, MJCF actuatorfrcrange, USD real2code:effort and
    newton:velocityLimit, glTF and object.json extras), read back equal; Pinocchio reads the
    source's and the export's limits alike."""
    from real2code_export.formats import export, load
    from real2code_export.model import differences
    from real2code_export.probes import dynamics

    path = tmp_path / "wheels.urdf"
    path.write_text(f"""<robot name="wheels">
  <link name="base">{INERTIAL}</link>
  <link name="wheel">{INERTIAL}</link>
  <link name="spinner">{INERTIAL}</link>
  <link name="cart">{INERTIAL}</link>
  <joint name="wheel" type="continuous">
    <parent link="base"/><child link="wheel"/><axis xyz="0 1 0"/><origin xyz="0 0.2 0"/>
    <limit lower="-1" upper="1" effort="12.5" velocity="3"/>
  </joint>
  <joint name="spinner" type="continuous">
    <parent link="base"/><child link="spinner"/><axis xyz="0 0 1"/><origin xyz="0 -0.2 0"/>
    <limit effort="4"/>
  </joint>
  <joint name="rail" type="prismatic">
    <parent link="base"/><child link="cart"/><axis xyz="1 0 0"/><origin xyz="0.3 0 0"/>
    <limit lower="-1e16" upper="1e16" effort="7" velocity="0.5"/>
  </joint>
</robot>""")
    with pytest.warns(Real2CodeWarning) as record:
        obj = load(path)
    said = "\n".join(str(w.message) for w in record)
    assert "<limit> lower and upper ignored on continuous joints 'wheel'" in said, said
    assert obj.joint("wheel").drive_limits == DriveLimits(12.5, 3.0)
    assert obj.joint("spinner").drive_limits == DriveLimits(4.0, None)  # velocity unknown
    assert obj.joint("rail").drive_limits == DriveLimits(7.0, 0.5)
    written = export(obj, tmp_path / "out", ["json", "urdf", "mjcf", "usd", "gltf"])
    for fmt, file in written.items():
        back = load(file)
        assert [d for d in differences(obj, back) if "limit" in d] == [], fmt
        assert back.joint("wheel").drive_limits == DriveLimits(12.5, 3.0), fmt
        assert back.joint("spinner").effort_limit == 4.0, fmt
        assert back.joint("spinner").velocity_limit is None, fmt
    text = written["urdf"].read_text()
    assert '<limit effort="12.5" velocity="3.0"/>' in text, text
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(written["mjcf"]))
    wheel = model.joint("wheel")
    assert not model.jnt_limited[wheel.id] and model.jnt_actfrclimited[wheel.id]
    assert tuple(model.jnt_actfrcrange[wheel.id]) == (-12.5, 12.5)
    # Pinocchio (urdfdom) wants both effort and velocity: the source with both given
    pytest.importorskip("pinocchio")
    both = tmp_path / "both" / "wheels.urdf"
    both.parent.mkdir()
    both.write_text(path.read_text().replace('<limit effort="4"/>',
                                             '<limit effort="4" velocity="9"/>'))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        out = export(load(both), tmp_path / "both_out", ["urdf"])
    assert dynamics.urdf_differences(both, out["urdf"]) == []


def test_an_inverted_range_is_bullets_no_limit(tmp_path):
    """``lower > upper`` (pybullet's planar bases): Bullet simulates the joint without a
    range, urdfdom loads it as written, MuJoCo refuses it: read without a range, warned,
    effort and velocity kept; the export agrees with the source in Pinocchio."""
    from real2code_export.check import check_files
    from real2code_export.formats import export

    path = tmp_path / "planar.urdf"
    path.write_text(f"""<robot name="planar">
  <link name="world"/>
  <link name="x_link">{INERTIAL}</link>
  <link name="body">{INERTIAL}</link>
  <joint name="x_to_world" type="prismatic">
    <parent link="world"/><child link="x_link"/><axis xyz="1 0 0"/>
    <limit effort="0.0" lower="1" upper="-1" velocity="1000.0"/>
  </joint>
  <joint name="pitch" type="revolute">
    <parent link="x_link"/><child link="body"/><axis xyz="0 1 0"/>
    <limit effort="2" lower="0.5" upper="-0.5" velocity="3"/>
  </joint>
</robot>""")
    with pytest.warns(Real2CodeWarning) as record:
        obj = urdf.load(path)
    said = "\n".join(str(w.message) for w in record)
    assert ("planar.urdf:7: <joint name='x_to_world'>: <limit> lower=1 > upper=-1: Bullet's "
            "\"no limit\"; imported as a slide without limits") in said, said
    assert "<joint name='pitch'>: <limit> lower=0.5 > upper=-0.5" in said, said
    rail, pitch = obj.joint("x_to_world"), obj.joint("pitch")
    assert rail.type is JointType.PRISMATIC and rail.limits is None
    assert rail.drive_limits == DriveLimits(0.0, 1000.0)
    assert pitch.type is JointType.CONTINUOUS and pitch.drive_limits == DriveLimits(2.0, 3.0)
    written = export(obj, tmp_path / "out", ["urdf", "mjcf"])
    pytest.importorskip("pinocchio")
    report = check_files(list(written.values()), source=path, n_configurations=10,
                         validate=False, warned=said.splitlines())
    assert report.ok, [m.message for m in report.mismatches]
    assert any(d.repaired for d in report.dynamics if d.tool == "Pinocchio")


def test_an_inertial_without_mass_is_read_as_none_as_urdfdom_drops_it(tmp_path):
    """``<inertial>`` with an ``<inertia>`` but no ``<mass>``: urdfdom (Pinocchio, ROS) drops
    it and loads the link, MuJoCo refuses the file. Read as a link without ``<inertial>``
    (mass from its visual geometry, as for any such link), each step warned with the link."""
    source = tmp_path / "puck.urdf"
    source.write_text("""<robot name="puck">
      <link name="world"/>
      <joint name="slide" type="prismatic"><parent link="world"/><child link="puck"/>
        <axis xyz="1 0 0"/><limit lower="0" upper="1" effort="1" velocity="1"/></joint>
      <link name="puck">
        <inertial><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial>
        <visual><geometry><box size="0.2 0.1 0.1"/></geometry></visual>
      </link>
    </robot>""")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        obj = urdf.load(source)
    said = "\n".join(str(w.message) for w in caught)
    assert "<link name='puck'>: <inertial> has no <mass>: read as a link without" in said
    assert "no <inertial> in links 'puck'" in said
    assert obj.part("puck").inertial.mass == pytest.approx(0.2 * 0.1 * 0.1 * 500.0)


def test_a_package_not_found_is_resolved_where_its_path_lies_above_the_urdf(tmp_path):
    """``package://NAME/REST`` where no package NAME is found, but REST lies under a folder
    above the URDF (the meshes shipped in the description package, the URI naming another
    package): the nearest such folder, as yourdfpy resolves it, with a warning naming the
    link and the URI. A REST found nowhere is still refused."""
    root = tmp_path / "arm_description"
    write_obj(root / "meshes" / "visual" / "base.obj", box((0.1, 0.2, 0.3)))
    source = root / "urdf" / "arm.urdf"
    source.parent.mkdir(parents=True)
    uri = "package://arm_support/meshes/visual/base.obj"
    source.write_text(f"""<robot name="arm"><link name="base">{INERTIAL}
      <visual><geometry><mesh filename="{uri}"/></geometry></visual></link></robot>""")
    with pytest.warns(Real2CodeWarning, match=r"<link name='base'>: 'package://arm_support/"
                      r"meshes/visual/base.obj': no package 'arm_support' found"):
        obj = urdf.load(source)
    assert len(obj.part("base").visual.faces) == 12
    source.write_text(source.read_text().replace("visual/base.obj", "visual/other.obj"))
    with pytest.raises(FormatError, match="cannot resolve 'package://arm_support/"):
        urdf.load(source)


def test_mesh_paths_written_from_an_asset_root_above_the_urdf(tmp_path):
    """Asset collections name meshes from the folder their loader is given, not from the
    URDF ('arm_description/meshes/base.obj' in arm_description/arm.urdf): a relative path
    not beside the URDF is taken from the nearest folder above it holding it, said once
    with that folder; a path climbing out with '..' is not searched, and a path found
    nowhere is refused naming the link, as before."""
    root = tmp_path / "assets"
    write_obj(root / "arm_description" / "meshes" / "base.obj", box((0.1, 0.2, 0.3)))
    write_obj(root / "arm_description" / "meshes" / "tip.obj", box((0.05, 0.05, 0.2)))
    source = root / "arm_description" / "arm.urdf"
    links = "".join(f"""<link name="{name}">{INERTIAL}<visual><geometry><mesh
      filename="arm_description/meshes/{name}.obj"/></geometry></visual></link>"""
                    for name in ("base", "tip"))
    source.write_text(f"""<robot name="arm">{links}<joint name="j" type="fixed">
      <parent link="base"/><child link="tip"/></joint></robot>""")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        obj = urdf.load(source)
    said = [str(w.message) for w in caught if "not found beside the URDF" in str(w.message)]
    assert len(said) == 1, said
    assert "'arm_description/meshes/base.obj', 'arm_description/meshes/tip.obj'" in said[0]
    assert f"taken from {root.resolve()}," in said[0]
    assert [len(obj.part(n).visual.faces) for n in ("base", "tip")] == [12, 12]
    # '../meshes/tip.obj' lies under assets/.. (from the folder above the URDF's), not beside
    write_obj(tmp_path / "meshes" / "tip.obj", box((0.05, 0.05, 0.2)))
    for missing in ("arm_description/meshes/other.obj", "../meshes/tip.obj"):
        source.write_text(f"""<robot name="arm"><link name="base">{INERTIAL}<visual><geometry>
          <mesh filename="{missing}"/></geometry></visual></link></robot>""")
        with pytest.raises(FormatError, match="<link name='base'>: mesh file not found"):
            urdf.load(source)


def test_an_inertial_without_inertia_is_a_zero_tensor_repaired(tmp_path):
    """``<inertial>`` with a ``<mass>`` and no ``<inertia>``: urdfdom logs an error and keeps
    the mass (Pinocchio loads the link with no rotational inertia), MuJoCo refuses the file.
    Read as a zero tensor, repaired as every zero tensor is (a tiny solid sphere), the mass
    kept, both steps warned with the link."""
    source = tmp_path / "cart.urdf"
    source.write_text("""<robot name="cart"><link name="world"/>
      <joint name="slide" type="prismatic"><parent link="world"/><child link="cart"/>
        <axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <link name="cart"><inertial><origin xyz="0 0 0.1"/><mass value="2"/></inertial>
        <visual><geometry><box size="0.2 0.1 0.1"/></geometry></visual></link>
    </robot>""")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        obj = urdf.load(source)
    said = "\n".join(str(w.message) for w in caught)
    assert "<link name='cart'>: <inertial> has no <inertia>: read as a zero tensor" in said
    assert "<link name='cart'>: inertia tensor is zero" in said
    inertial = obj.part("cart").inertial
    assert inertial.mass == 2.0 and np.allclose(inertial.com, [0, 0, 0.1])
    assert np.all(np.linalg.eigvalsh(inertial.inertia) > 0)


def test_a_urdfs_stl_files_are_read_ahead_and_warnings_said_once(tmp_path, monkeypatch):
    """The STL files a URDF's links name are parsed two at a time before the links are read
    (``meshfiles.read_ahead``): none is parsed again as its link is read, and a filename
    resolved with a warning (a package found nowhere, its path above the URDF) is left to
    the link, which says it once."""
    from real2code_export import meshfiles

    root = tmp_path / "arm_description"
    (root / "meshes").mkdir(parents=True)
    for name, extents in (("base", (0.1, 0.2, 0.3)), ("arm", (0.3, 0.1, 0.1)),
                          ("tip", (0.05, 0.05, 0.2))):
        trimesh.creation.box(extents).export(root / "meshes" / f"{name}.stl")
    source = root / "urdf" / "arm.urdf"
    source.parent.mkdir()
    links = "".join(f"""<link name="{name}">{INERTIAL}<visual><geometry><mesh
      filename="{uri}"/></geometry></visual></link>""" for name, uri in (
        ("base", "package://arm_description/meshes/base.stl"),
        ("arm", "../meshes/arm.stl"), ("tip", "package://elsewhere/meshes/tip.stl")))
    joints = "".join(f"""<joint name="{child}_joint" type="fixed"><parent link="{parent}"/>
      <child link="{child}"/></joint>""" for parent, child in (("base", "arm"), ("arm", "tip")))
    source.write_text(f'<robot name="arm">{links}{joints}</robot>')
    meshfiles._READ.entries.clear()
    meshfiles._READ.used = 0
    parsed = []
    parse = meshfiles._read_unscaled
    monkeypatch.setattr(meshfiles, "_read_unscaled", lambda *a: parsed.append(a[0].name)
                        or parse(*a))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        obj = urdf.load(source)
    assert parsed == ["tip.stl"]  # base and arm read ahead; tip resolved with a warning
    said = [str(w.message) for w in caught if "no package 'elsewhere'" in str(w.message)]
    assert len(said) == 1, said
    assert [len(obj.part(n).visual.faces) for n in ("base", "arm", "tip")] == [12, 12, 12]


def test_meshes_in_the_folder_a_mujoco_compiler_meshdir_names(tmp_path):
    """A URDF prepared for MuJoCo names its meshes relative to ``<mujoco><compiler
    meshdir>``, where MuJoCo looks for them: found there, said in a warning; a mesh in
    neither place is still refused, naming the link."""
    (tmp_path / "assets" / "meshes").mkdir(parents=True)
    trimesh.creation.box((0.1, 0.2, 0.3)).export(tmp_path / "assets" / "meshes" / "box.stl")
    text = """<robot name="mj"><mujoco><compiler meshdir="assets/meshes/"/></mujoco>
      <link name="base"><visual><geometry><mesh filename="{}"/></geometry></visual></link>
    </robot>"""
    path = tmp_path / "mj.urdf"
    path.write_text(text.format("box.stl"))
    with pytest.warns(Real2CodeWarning, match=r"meshdir='assets/meshes/'>: mesh files 'box.stl'"):
        obj = urdf.load(path)
    assert np.allclose(np.ptp(obj.parts[0].visual.vertices, axis=0), [0.1, 0.2, 0.3])
    path.write_text(text.format("other.stl"))
    with pytest.raises(FormatError, match="<link name='base'>: mesh file not found"):
        urdf.load(path)


def test_a_mesh_file_named_by_several_links_is_one_placed_asset(tmp_path):
    """A mesh file several <visual>s name at different origins (a robot's wheels) reads as
    one asset placed at each (Mesh.placements), which the USD export writes once."""
    import trimesh

    from real2code_export.formats import export

    (tmp_path / "wheel.obj").write_text(trimesh.exchange.obj.export_obj(
        trimesh.creation.cylinder(radius=0.05, height=0.02, sections=12), include_normals=False))
    links = "".join(f"""
  <link name="wheel_{k}"><visual><origin xyz="0 0 0" rpy="{k} 0 0"/>
    <geometry><mesh filename="wheel.obj"/></geometry></visual></link>
  <joint name="axle_{k}" type="continuous"><parent link="base"/><child link="wheel_{k}"/>
    <origin xyz="{0.1 * k} 0 0"/><axis xyz="0 1 0"/></joint>""" for k in range(3))
    path = tmp_path / "cart.urdf"
    path.write_text(f'<robot name="cart"><link name="base"/>{links}</robot>')
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        obj = urdf.load(path)
    placements = [obj.part(f"wheel_{k}").visual.placements[0] for k in range(3)]
    assert all(p.asset is placements[0].asset for p in placements)
    written = export(obj, tmp_path / "out", ["usd"])
    assert written["usd"].read_text().count("references = </cart/MeshAssets/mesh_0>") == 3


def test_a_mesh_files_one_colour_needs_a_face_with_area_not_the_first():
    """A file's colour (meshfiles._face_colours): one colour over its faces is that colour
    where some face, not only the first few, has an area; none without any; two colours
    weighed by their faces' areas."""
    from real2code_export.meshfiles import _face_colours

    red, blue = (1.0, 0.0, 0.0, 1.0), (0.0, 0.0, 1.0, 1.0)
    flat = [[0, 0, 0]] * 20  # degenerate: no area
    vertices = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 3]])
    mesh = Mesh(vertices, np.array(flat + [[0, 1, 2]]))
    assert _face_colours(mesh, np.zeros(21, np.int64), [red])["color"] == red
    assert _face_colours(Mesh(vertices, np.array(flat)), np.zeros(20, np.int64),
                         [red])["color"] is None
    two = Mesh(vertices, np.array([[0, 1, 2], [0, 1, 3]]))  # areas 0.5 and 1.5
    assert _face_colours(two, np.array([0, 1]), [red, blue])["color"] == (0.25, 0.0, 0.75, 1.0)


XACRO_MACROS = """<?xml version="1.0"?>
<robot xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:macro name="segment" params="name parent z">
    <link name="${name}">
      <inertial><origin xyz="0 0 ${link_len / 2}"/><mass value="0.5"/>
        <inertia ixx="0.007" ixy="0" ixz="0" iyy="0.007" iyz="0" izz="0.001"/></inertial>
      <visual><origin xyz="0 0 ${link_len / 2}"/>
        <geometry><cylinder radius="0.03" length="${link_len}"/></geometry></visual>
    </link>
    <joint name="${name}_joint" type="revolute">
      <parent link="${parent}"/><child link="${name}"/>
      <origin xyz="0 0 ${z}"/><axis xyz="0 1 0"/>
      <limit lower="-1.5" upper="1.5" effort="10" velocity="2"/>
    </joint>
  </xacro:macro>
</robot>
"""

XACRO_ROBOT = """<?xml version="1.0"?>
<robot name="arm" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:property name="link_len" value="0.4"/>
  <xacro:arg name="with_tip" default="true"/>
  <xacro:include filename="$(find arm_description)/urdf/macros.xacro"/>
  <link name="base">""" + INERTIAL + """
    <visual><geometry><mesh filename="package://arm_description/meshes/base.stl"/></geometry>
    </visual>
  </link>
  <xacro:segment name="upper" parent="base" z="0.15"/>
  <xacro:segment name="lower" parent="upper" z="${link_len}"/>
  <xacro:if value="$(arg with_tip)">
    <xacro:segment name="tip" parent="lower" z="${link_len / 2}"/>
  </xacro:if>
</robot>
"""


def test_a_xacro_file_is_read_as_the_urdf_it_expands_to(tmp_path):
    """``robot.urdf.xacro`` (ROS's macros: properties, args, an include found by ``$(find
    PKG)``, macros, conditionals): expanded by ROS's xacro package, ``$(find)`` resolved as
    ``package://`` is (a folder of that name above the file), and read as that URDF; the
    check against the xacro source expands it too (MuJoCo and Pinocchio read no xacro)."""
    from real2code_export.check import check_files
    from real2code_export.formats import export

    pytest.importorskip("xacro")
    root = tmp_path / "arm_description"
    (root / "urdf").mkdir(parents=True)
    (root / "meshes").mkdir()
    trimesh.creation.box((0.1, 0.2, 0.3)).export(root / "meshes" / "base.stl")
    (root / "urdf" / "macros.xacro").write_text(XACRO_MACROS)
    source = root / "urdf" / "arm.urdf.xacro"
    source.write_text(XACRO_ROBOT)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        obj = urdf.load(source)
        written = export(obj, tmp_path / "out", ["urdf", "mjcf"])
    assert [p.name for p in obj.parts] == ["base", "upper", "lower", "tip"]
    tip = obj.joint("tip_joint")
    np.testing.assert_allclose(tip.origin[:3, 3], [0, 0, 0.2])
    assert obj.part("tip").inertial.mass == 0.5
    pytest.importorskip("pinocchio")
    report = check_files(list(written.values()), source=source, n_configurations=10,
                         validate=False)
    assert report.ok, [m.message for m in report.mismatches]


def test_a_xacro_expansion_is_reused_while_no_file_it_read_changes(tmp_path):
    """An export with its check reads the source three or four times (the reader, MuJoCo's
    and Pinocchio's probes): the expansion is made once, and made again when the xacro file
    or a file it includes changes, or the arguments do."""
    import xacro

    from real2code_export.formats.urdf import xacro_file
    from real2code_export.formats.urdf.packages import XACRO_ARGS_VARIABLE

    root = tmp_path / "arm_description"
    (root / "urdf").mkdir(parents=True)
    (root / "meshes").mkdir()
    trimesh.creation.box((0.1, 0.2, 0.3)).export(root / "meshes" / "base.stl")
    macros = root / "urdf" / "macros.xacro"
    macros.write_text(XACRO_MACROS)
    source = root / "urdf" / "arm.urdf.xacro"
    source.write_text(XACRO_ROBOT)
    calls = []
    real = xacro.process_file

    def counted(*args, **kwargs):
        calls.append(args)
        return real(*args, **kwargs)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(xacro, "process_file", counted)
        patch.delenv(XACRO_ARGS_VARIABLE, raising=False)
        first = xacro_file.expand(source)
        assert xacro_file.expand(source) is first and len(calls) == 1
        macros.write_text(XACRO_MACROS.replace('mass value="0.5"', 'mass value="0.7"'))
        changed = xacro_file.expand(source)
        assert len(calls) == 2 and b'value="0.7"' in changed
        patch.setenv(XACRO_ARGS_VARIABLE, "with_tip:=false")
        without_tip = xacro_file.expand(source)
        assert len(calls) == 3 and b'"tip"' not in without_tip


def test_a_xacro_file_that_does_not_expand_is_refused_naming_it(tmp_path):
    """A property never defined, a package ``$(find)`` finds nowhere: refused with the file
    and xacro's own message; an error in the URDF it expands to names the line of that URDF
    (as ``xacro FILE`` prints it), not of the xacro file."""
    pytest.importorskip("xacro")
    source = tmp_path / "bad.urdf.xacro"
    source.write_text(XACRO_ROBOT.replace('<xacro:include filename="$(find arm_description)'
                                          '/urdf/macros.xacro"/>', ""))
    with pytest.raises(FormatError, match=r"bad\.urdf\.xacro.*xacro cannot expand it"):
        urdf.load(source)
    source.write_text(XACRO_ROBOT.replace("arm_description)", "no_such_package)"))
    with pytest.raises(FormatError, match=r"\$\(find no_such_package\): no folder named"):
        urdf.load(source)
    source.write_text("""<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">
      <link name="$(arg with_tip)"/></robot>""")
    with pytest.raises(FormatError, match=r"undefined argument with_tip \(an argument without"):
        urdf.load(source)
    source.write_text("""<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">
      <xacro:property name="lower" value="-1"/>
      <link name="a"/><link name="b"/>
      <joint name="j" type="revolute"><parent link="a"/><child link="b"/>
        <limit lower="${lower}" upper="oops" effort="1" velocity="1"/></joint></robot>""")
    with pytest.raises(FormatError, match=r"upper='oops'.*\(line \d+ of the URDF `xacro "
                       r"bad\.urdf\.xacro` prints\)") as err:
        urdf.load(source)
    assert err.value.line is None


def test_xacro_arguments_are_given_on_the_command_line(tmp_path, monkeypatch, capsys):
    """``--xacro-arg NAME:=VALUE`` (as the xacro command takes them): an argument without a
    default is refused naming the option, given it expands, and the check of the exports
    against the xacro source expands it with the same arguments."""
    from real2code_export.cli import EXIT_ERROR, EXIT_OK, run
    from real2code_export.formats.urdf.packages import XACRO_ARGS_VARIABLE

    pytest.importorskip("xacro")
    pytest.importorskip("pinocchio")
    monkeypatch.delenv(XACRO_ARGS_VARIABLE, raising=False)
    source = tmp_path / "two.urdf.xacro"
    source.write_text("""<robot name="two" xmlns:xacro="http://www.ros.org/wiki/xacro">
      <link name="base">""" + INERTIAL + """</link><link name="tip">""" + INERTIAL + """</link>
      <joint name="slide" type="prismatic"><parent link="base"/><child link="tip"/>
        <axis xyz="1 0 0"/><limit lower="0" upper="$(arg reach)" effort="1" velocity="1"/>
      </joint></robot>""")
    out = tmp_path / "out"
    assert run(["export", str(source), "--to", "mjcf", "--out", str(out)]) == EXIT_ERROR
    assert "give it with --xacro-arg reach:=VALUE" in capsys.readouterr().err
    assert run(["export", str(source), "--to", "mjcf,urdf", "--out", str(out), "--check",
                "--xacro-arg", "reach:=0.25"]) == EXIT_OK
    back = urdf.load(out / "two.urdf")
    assert back.joint("slide").limits.upper == pytest.approx(0.25)


def _manifest(folder: Path, name: str) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "package.xml").write_text(f"""<?xml version="1.0"?>
<package format="3"><name>{name}</name><version>1.0.0</version></package>""")


def test_a_package_is_found_by_the_name_its_package_xml_gives(tmp_path):
    """ROS finds a package by its manifest's <name>, not its folder's (moveit_resources
    keeps ``moveit_resources_panda_description`` in ``panda_description/``): ``package://``
    and xacro's ``$(find)`` find the folder beside the URDF's own package whose package.xml
    names it, with no warning (it is ROS's own rule); a file the package lacks is refused
    naming the package's folder."""
    repo = tmp_path / "acme_resources"
    _manifest(repo / "arm_description", "acme_arm_description")
    _manifest(repo / "arm_config", "acme_arm_config")
    write_obj(repo / "arm_description" / "meshes" / "base.obj", box((0.1, 0.2, 0.3)))
    (repo / "arm_config" / "config").mkdir()
    source = repo / "arm_config" / "config" / "arm.urdf"
    source.write_text(f"""<robot name="arm"><link name="base">{INERTIAL}<visual><geometry>
      <mesh filename="package://acme_arm_description/meshes/base.obj"/></geometry></visual>
      </link></robot>""")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        obj = urdf.load(source)
    assert len(obj.part("base").visual.faces) == 12
    assert not [w for w in caught if "no package" in str(w.message)]
    source.write_text(source.read_text().replace("base.obj", "other.obj"))
    with pytest.raises(FormatError, match=r"package 'acme_arm_description' is .*arm_description,"
                       r" which holds no 'meshes/other.obj' \(mesh file not found\)"):
        urdf.load(source)
    pytest.importorskip("xacro")
    (repo / "arm_description" / "urdf").mkdir()
    (repo / "arm_description" / "urdf" / "macros.xacro").write_text(XACRO_MACROS)
    xacro_source = repo / "arm_config" / "config" / "arm.urdf.xacro"
    xacro_source.write_text(XACRO_ROBOT.replace("$(find arm_description)",
                                                "$(find acme_arm_description)")
                            .replace("package://arm_description/meshes/base.stl",
                                     "package://acme_arm_description/meshes/base.obj"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        obj = urdf.load(xacro_source)
    assert [p.name for p in obj.parts] == ["base", "upper", "lower", "tip"]


def test_a_urdf_named_xml_is_read_as_urdf(tmp_path):
    """An ``.xml`` file whose root element is <robot> (older ROS packages' ``robot.xml``,
    pr2_description's): a URDF, as ROS's tools and MuJoCo's loader take it, read by the URDF
    reader and checked against in MuJoCo and Pinocchio; an MJCF ``.xml`` stays MJCF."""
    from real2code_export.check import check_files
    from real2code_export.formats import export, format_for_path, is_format, load

    source = tmp_path / "robot.xml"
    source.write_text(f"""<?xml version="1.0"?>
<!-- generated by xacro: <mujoco> is not the root -->
<robot name="arm"><link name="base">{INERTIAL}</link><link name="tip">{INERTIAL}</link>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="tip"/>
    <origin xyz="0 0 0.2"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>""")
    assert format_for_path(source).name == "urdf" and is_format(source, "urdf")
    assert not is_format(source, "mjcf")
    assert format_for_path(tmp_path / "not_yet_written.xml").name == "mjcf"
    obj = load(source)
    assert obj.joint("hinge").limits.upper == 1
    written = export(obj, tmp_path / "out", ["mjcf", "urdf"])
    assert format_for_path(written["mjcf"]).name == "mjcf"
    pytest.importorskip("pinocchio")
    report = check_files(list(written.values()), source=source, n_configurations=5,
                         validate=False)
    assert report.ok, [m.message for m in report.mismatches]
    assert {p.label for p in report.probes if p.label.startswith("source")} == {
        "source MuJoCo (URDF)", "source Pinocchio (URDF)"}


def test_a_link_weighed_from_a_flat_visual_mesh_loads_in_mujoco(tmp_path):
    """A link without <inertial> whose visual is one flat triangle off the axes (a decal, a
    Collada test asset): its mass properties are a thin shell's, whose largest moment is
    the sum of the other two; written as text with products of inertia, MuJoCo's URDF
    import found that 1e-16 short of A + B = C and refused the URDF export. The two smaller
    moments now keep a margin, and every export loads in MuJoCo."""
    from real2code_export.formats import export
    from real2code_export.probes.mujoco import open_probes

    (tmp_path / "decal.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    source = tmp_path / "decal.urdf"
    source.write_text("""<robot name="decal"><link name="base"/><link name="decal">
      <visual><geometry><mesh filename="decal.obj"/></geometry></visual></link>
      <joint name="hinge" type="continuous"><parent link="base"/><child link="decal"/>
        <axis xyz="0 0 1"/></joint></robot>""")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        obj = urdf.load(source)
        written = export(obj, tmp_path / "out", ["urdf", "mjcf"])
    moments = np.linalg.eigvalsh(obj.part("decal").inertial.inertia)
    assert moments[0] + moments[1] > moments[2] * (1 + 1e-7)
    for path in written.values():  # (a flat mesh compiled as a shell, as check does)
        assert open_probes(path)[0].parts


def test_a_limit_with_one_bound_is_read_as_the_urdf_specification_reads_it(tmp_path):
    """``<limit upper="0.5" effort velocity>`` (lower omitted): the URDF specification,
    urdfdom (ROS, Pinocchio) and urdf-usd-converter take the missing bound as 0, MuJoCo's
    import leaves the joint unlimited. Read as the specification says, warned; the check
    against the source compares MuJoCo's import with the same bound, so the exports agree
    with the source in both tools (they disagreed: "revolute, continuous in source MuJoCo")."""
    from real2code_export.check import check_files
    from real2code_export.formats import export

    source = tmp_path / "half.urdf"
    source.write_text(f"""<robot name="half"><link name="base">{INERTIAL}</link>
      <link name="arm">{INERTIAL}</link><link name="tip">{INERTIAL}</link>
      <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/>
        <axis xyz="0 1 0"/><limit upper="0.5" effort="1" velocity="1"/></joint>
      <joint name="slide" type="prismatic"><parent link="arm"/><child link="tip"/>
        <origin xyz="0.3 0 0"/><limit lower="-0.2" effort="1" velocity="1"/></joint>
      </robot>""")
    with pytest.warns(Real2CodeWarning, match=r"<limit> with one bound in joints 'shoulder' "
                      r"\(lower 0\), 'slide' \(upper 0\): the other is 0"):
        obj = urdf.load(source)
    assert (obj.joint("shoulder").limits.lower, obj.joint("shoulder").limits.upper) == (0, 0.5)
    assert (obj.joint("slide").limits.lower, obj.joint("slide").limits.upper) == (-0.2, 0)
    written = export(obj, tmp_path / "out", ["mjcf", "urdf"])
    pytest.importorskip("pinocchio")
    report = check_files(list(written.values()), source=source, n_configurations=10,
                         validate=False)
    assert {p.label for p in report.probes if p.label.startswith("source")} == {
        "source MuJoCo (URDF)", "source Pinocchio (URDF)"}
    assert report.ok, [m.message for m in report.mismatches]


def test_a_relative_file_uri_is_read_beside_the_urdf_and_a_url_refused(tmp_path, monkeypatch):
    """``file://meshes/box.obj`` (no file URI: its path does not start with '/'), which
    urdf-usd-converter reads relative to the URDF: read so, warned (the working folder
    decided before); ``https://...`` is refused naming the URL (it was "mesh file not found"
    of a path made of it)."""
    write_obj(tmp_path / "robot" / "meshes" / "box.obj", box((0.1, 0.2, 0.3)))
    source = tmp_path / "robot" / "box.urdf"
    source.write_text(f"""<robot name="box"><link name="base">{INERTIAL}<visual><geometry>
      <mesh filename="file://meshes/box.obj"/></geometry></visual></link></robot>""")
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    with pytest.warns(Real2CodeWarning, match=r"<link name='base'>: 'file://meshes/box.obj': "
                      "a file:// URI with a relative path; read relative to the URDF"):
        obj = urdf.load(source)
    assert len(obj.part("base").visual.faces) == 12
    source.write_text(source.read_text().replace("file://meshes/box.obj",
                                                 "https://example.com/meshes/box.obj"))
    with pytest.raises(FormatError, match=r"box.urdf:\d+: <link name='base'>: mesh filename "
                       r"'https://example.com/meshes/box.obj' is a URL"):
        urdf.load(source)


def test_a_floating_joint_below_a_welded_link_hangs_from_the_root(tmp_path):
    """A floating body below a link the base holds by fixed joints (a cup on a table welded
    to the base): Pinocchio loads it, MuJoCo refuses a free joint below the top level,
    urdf-usd-converter makes the body free. Hung from the root at the same pose (the
    origins composed), warned; the exports load in MuJoCo and agree with the source. Below
    a link that moves it is still refused (its coordinates would change)."""
    from real2code_export.check import check_files
    from real2code_export.formats import export

    source = tmp_path / "table.urdf"
    source.write_text(f"""<robot name="table"><link name="base">{INERTIAL}</link>
      <link name="top">{INERTIAL}</link><link name="cup">{INERTIAL}</link>
      <joint name="legs" type="fixed"><parent link="base"/><child link="top"/>
        <origin xyz="0 0 0.7" rpy="0 0 0.5"/></joint>
      <joint name="cup_free" type="floating"><parent link="top"/><child link="cup"/>
        <origin xyz="0.2 0 0.05"/></joint></robot>""")
    with pytest.warns(Real2CodeWarning, match=r"<joint name='cup_free'>: a floating joint "
                      r"below 'top', which the root part 'base' holds by fixed joints "
                      r"\('legs'\): hung from 'base' at the same pose"):
        obj = urdf.load(source)
    cup = obj.joint("cup_free")
    assert cup.parent == "base"
    np.testing.assert_allclose(cup.origin[:3, 3],
                               [0.2 * np.cos(0.5), 0.2 * np.sin(0.5), 0.75], atol=1e-12)
    written = export(obj, tmp_path / "out", ["mjcf", "urdf"])
    pytest.importorskip("pinocchio")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)  # (MuJoCo refuses the source)
        report = check_files(list(written.values()), source=source, n_configurations=5,
                             validate=False)
    assert report.ok, [m.message for m in report.mismatches]
    assert {p.label for p in report.probes} >= {"MuJoCo (MJCF)", "MuJoCo (URDF)"}
    source.write_text(source.read_text().replace('type="fixed"', 'type="continuous"'))
    with pytest.raises(FormatError, match=r"<joint name='cup_free'>: a floating joint must "
                       "hang from the root part"):
        urdf.load(source)


def test_an_srdf_is_refused_saying_what_it_is(tmp_path):
    """MoveIt's SRDF has a <robot> root too (pr2_description's ``srdf/robot.xml`` beside its
    URDF ``urdf/robot.xml``): refused naming it an SRDF, not only "has no <link>"."""
    from real2code_export.formats import load

    source = tmp_path / "robot.xml"
    source.write_text("""<?xml version="1.0"?>
<robot name="arm"><virtual_joint name="world_joint" type="fixed" parent_frame="world"
    child_link="base"/>
  <group name="arm"><chain base_link="base" tip_link="tip"/></group>
  <disable_collisions link1="base" link2="tip" reason="Adjacent"/></robot>""")
    with pytest.raises(FormatError, match=r"robot.xml:2: <robot name='arm'>: has no <link> "
                       r"\(it holds <disable_collisions>, <group>, <virtual_joint>: an SRDF"):
        load(source)


def test_collada_lines_are_named_not_dropped_in_silence(tmp_path):
    """A Collada mesh with a <lines> primitive beside its triangles (edges a CAD exporter
    left in: moveit's panda link5-7): the triangles are read, the lines (no surface to show
    or collide) are named in a warning with the file (they were skipped in silence;
    urdf-usd-converter warns too)."""
    with_lines = COLLADA_MM.replace("</triangles>", """</triangles>
    <lines count="1"><input semantic="VERTEX" source="#verts" offset="0"/><p>0 1</p></lines>""")
    (tmp_path / "part.dae").write_text(with_lines)
    path = tmp_path / "robot.urdf"
    path.write_text(f'<robot name="dae"><link name="base">{INERTIAL}<visual><geometry>'
                    '<mesh filename="part.dae"/></geometry></visual></link></robot>')
    with pytest.warns(Real2CodeWarning, match=r"part\.dae: 1 Collada <lines>/<linestrips> "
                      r"primitive\(s\), edges with no surface: not read"):
        obj = urdf.load(path)
    assert len(obj.part("base").visual.faces) == 1


def test_children_of_visuals_no_reader_reads_are_named(tmp_path):
    """Custom data inside a <visual> or <collision> (urdf-usd-converter's
    verifying_elements.urdf: <custom>, <verbose>): the model merges a link's visuals into its
    part, so there is no element to keep them in; named in a warning, not dropped in
    silence. Our own namespace's elements are ours, not named."""
    source = tmp_path / "custom.urdf"
    source.write_text(f"""<robot name="custom" xmlns:real2code="urn:real2code-export:urdf:1">
      <link name="base">{INERTIAL}
        <visual><custom><item value="1"/></custom><geometry><box size="1 1 1"/></geometry>
        </visual>
        <collision><geometry><box size="1 1 1"/></geometry><verbose value="v"/>
          <real2code:note/></collision></link></robot>""")
    with pytest.warns(Real2CodeWarning) as said:
        urdf.load(source)
    said = " ".join(str(w.message) for w in said)
    assert re.search(r"not read \(in a visual, collision or inertial, which the model merges "
                     r"into its part: no element to keep them in\): <custom> in the <visual> "
                     r"of <link name='base'> \(line 3\), <verbose> in the <collision> of "
                     r"<link name='base'> \(line 5\)", said), said
    assert "<note>" not in said


def test_a_kept_element_urdfdom_refuses_is_written_back_beside_the_joints(tmp_path):
    """A <safety_controller> without k_velocity (urdf-usd-converter's
    warning_no_joint_k_velocity.urdf): urdfdom refuses the whole file for it. Kept and
    warned, but written back wrapped beside the joints, not into its joint, so that
    Pinocchio loads the URDF export (it refused it once such elements were written back)."""
    pinocchio = pytest.importorskip("pinocchio")
    source = tmp_path / "soft.urdf"
    source.write_text(f"""<robot name="soft"><link name="base">{INERTIAL}</link>
      <link name="arm">{INERTIAL}</link>
      <joint name="hinge" type="revolute"><parent link="base"/><child link="arm"/>
        <limit lower="-1" upper="1" effort="1" velocity="1"/>
        <safety_controller k_position="3"/></joint></robot>""")
    with pytest.warns(Real2CodeWarning, match=r"<joint name='hinge'>: <safety_controller> "
                      r"without k_velocity \(urdfdom refuses the file for it\): kept"):
        obj = urdf.load(source)
    out = urdf.save(obj, tmp_path / "out")
    model = pinocchio.buildModelFromUrdf(str(out))
    assert model.names[1] == "hinge"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        assert urdf.load(out).metadata["urdf_elements"] == obj.metadata["urdf_elements"]
