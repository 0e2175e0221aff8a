"""MJCF export and import through MuJoCo's MjSpec: the files compile from disk, MuJoCo's
kinematics and dynamics parameters are the model's, import(export(obj)) == obj, and
export -> import -> export gives the same bytes. Third-party MJCF (classes, frames, degrees,
fromto, joint anchors and references, primitives) is read as MuJoCo itself reads it."""

from __future__ import annotations

import warnings
from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh

from real2code_export import transforms as tf
from real2code_export.errors import ExportError, FormatError, Real2CodeWarning
from real2code_export.formats import export, mjcf
from real2code_export.formats import load as load_any
from real2code_export.meshfiles import shared_mesh_files
from real2code_export.model import (
    ArticulatedObject,
    Dynamics,
    Inertial,
    Joint,
    JointType,
    Limits,
    Mesh,
    Mimic,
    Part,
    differences,
    forward_kinematics,
    sample_configuration,
)

from conftest import partnet_dir
from helpers import edit_glb


# -- objects built here ----------------------------------------------------------------------
def box(extents, center=(0.0, 0.0, 0.0)) -> Mesh:
    m = trimesh.creation.box(extents=extents)
    m.apply_translation(center)
    return Mesh.from_trimesh(m)


def box_inertial(extents, mass, center=(0.0, 0.0, 0.0)) -> Inertial:
    x, y, z = extents
    return Inertial(mass, center, mass / 12 * np.diag([y * y + z * z, x * x + z * z, x * x + y * y]))


def cabinet() -> ArticulatedObject:
    """A cabinet with a revolute door (rotated, off-axis hinge) carrying a continuous knob, a
    prismatic drawer with a fixed handle, an open flat shelf without collision or mass, and
    a geometry-less marker part: every field set somewhere."""
    body = Part("body", box([0.5, 0.6, 0.8], [0, 0, 0.4]), [box([0.5, 0.6, 0.8], [0, 0, 0.4])],
                box_inertial([0.5, 0.6, 0.8], 20.0, [0, 0, 0.4]), (0.6, 0.4, 0.2, 1.0))
    door = Part("door", box([0.02, 0.3, 0.4], [0, 0.15, 0]),
                [box([0.02, 0.15, 0.4], [0, 0.075, 0]), box([0.02, 0.15, 0.4], [0, 0.225, 0])],
                box_inertial([0.02, 0.3, 0.4], 2.0, [0, 0.15, 0]), (0.8, 0.8, 0.75, 1.0))
    # A tilted inertia (off-diagonal terms) on the drawer.
    tilt = tf.rpy_to_matrix([0.2, -0.1, 0.4])
    drawer_inertial = box_inertial([0.4, 0.28, 0.15], 1.5, [0.01, 0.0, -0.02])
    drawer_inertial.inertia = tilt @ drawer_inertial.inertia @ tilt.T
    drawer = Part("drawer", box([0.4, 0.28, 0.15]), [box([0.4, 0.28, 0.15])], drawer_inertial,
                  (0.2, 0.3, 0.9, 0.5))
    handle = Part("handle", box([0.03, 0.02, 0.1]), [box([0.03, 0.02, 0.1])],
                  box_inertial([0.03, 0.02, 0.1], 0.1))
    knob = Part("knob", box([0.02, 0.03, 0.03]), [box([0.02, 0.03, 0.03])],
                box_inertial([0.02, 0.03, 0.03], 0.05), (0.1, 0.1, 0.1, 1.0))
    # One open, flat quad (a scan fragment): no volume, which MuJoCo must still accept.
    quad = Mesh(np.array([[0, 0, 0], [0.4, 0, 0], [0, 0.5, 0], [0.4, 0.5, 0.0]]),
                np.array([[0, 1, 2], [1, 3, 2]]))
    shelf = Part("shelf", quad, [], None, (0.9, 0.9, 0.9, 1.0))
    marker = Part("marker", None, [], None, (0.25, 0.5, 0.75, 1.0))
    axis = np.array([0.0, 0.1, 1.0]) / np.linalg.norm([0.0, 0.1, 1.0])
    joints = [
        Joint("door_hinge", "revolute", "body", "door",
              origin=tf.make(tf.rpy_to_matrix([0.0, 0.0, 0.1]), [0.26, -0.3, 0.6]), axis=axis,
              limits=Limits(-0.1, 1.6, effort=5.0, velocity=2.0),
              dynamics=Dynamics(damping=0.5, friction=0.1, stiffness=0.2, spring_ref=0.1,
                                armature=0.01), state=0.4),
        Joint("drawer_slide", "prismatic", "body", "drawer", origin=tf.make(None, [0.05, 0.1, 0.2]),
              axis=[1.0, 0.0, 0.0], limits=Limits(0.0, 0.35, effort=0.0),
              dynamics=Dynamics(damping=2.0, friction=0.3, armature=0.05), state=0.12),
        Joint("handle_mount", "fixed", "drawer", "handle", origin=tf.make(None, [0.22, 0.0, 0.0])),
        Joint("knob_turn", "continuous", "door", "knob",
              origin=tf.make(tf.rpy_to_matrix([0.3, -0.2, 2.5]), [0.02, 0.25, 0.1]),
              axis=[0.0, 0.6, -0.8], dynamics=Dynamics(damping=0.01, stiffness=0.02,
                                                      spring_ref=-0.3), state=-0.7),
        Joint("shelf_mount", "fixed", "body", "shelf",
              origin=tf.make(tf.rpy_to_matrix([np.pi, 0.0, 0.0]), [-0.2, -0.25, 0.3])),
        Joint("marker_mount", "fixed", "shelf", "marker", origin=tf.make(None, [0.1, 0.1, 0.0])),
    ]
    metadata = {"category": "storage_furniture", "note": "tricky ]]> <text> & ünïcode",
                "nested": {"a": [1, 2.5, None]}}
    return ArticulatedObject("cabinet", [body, door, drawer, handle, knob, shelf, marker],
                             joints, metadata)


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    obj = cabinet()
    out = tmp_path_factory.mktemp("cabinet")
    return obj, mjcf.save(obj, out)


def mesh_count(obj: ArticulatedObject) -> int:
    """The MJCF's mesh assets: one per distinct mesh file."""
    return len(set(shared_mesh_files(obj).values()))


def qpos_for(model, q: dict[str, float]) -> np.ndarray:
    """MuJoCo's qpos for joint values ``q``; a hinge or slide not named at 0, as the model
    has it (qpos0 is the joints' refs, their states), balls and free joints at qpos0."""
    qpos = model.qpos0.copy()
    for j in range(model.njnt):
        if int(model.jnt_type[j]) in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
            qpos[model.jnt_qposadr[j]] = 0.0
    for name, value in q.items():
        qpos[model.joint(name).qposadr[0]] = value
    return qpos


def world_poses(model, data, qpos) -> dict[str, np.ndarray]:
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    poses = {model.body(b).name: tf.make(data.xmat[b].reshape(3, 3), data.xpos[b])
             for b in range(1, model.nbody)}
    poses.update({model.site(s).name: tf.make(data.site_xmat[s].reshape(3, 3),
                                              data.site_xpos[s]) for s in range(model.nsite)})
    return poses


# -- export ----------------------------------------------------------------------------------
def test_file_compiles_from_disk_and_kinematics_match(exported):
    obj, path = exported
    assert path.name == "cabinet.xml"
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    # every part a body, but frames (no mass, no geometry, no children), which are sites
    assert sorted([model.body(b).name for b in range(1, model.nbody)] + [
        model.site(s).name for s in range(model.nsite)]) == sorted(p.name for p in obj.parts)
    assert [model.site(s).name for s in range(model.nsite)] == ["marker"]
    rng = np.random.default_rng(7)
    configurations = [sample_configuration(obj, rng) for _ in range(100)]
    configurations += [{}, obj.observed_configuration()]
    worst = 0.0
    for q in configurations:
        ours = forward_kinematics(obj, q)
        theirs = world_poses(model, data, qpos_for(model, q))
        for name, pose in ours.items():
            worst = max(worst, float(np.abs(pose - theirs[name]).max()))
    assert worst < 1e-9, worst


def test_structure_dynamics_and_limits_land_in_the_compiled_model(exported):
    obj, path = exported
    model = mujoco.MjModel.from_xml_path(str(path))
    # Root: a jointless child of the world; fixed joints: jointless nested bodies.
    assert model.body("body").parentid[0] == 0 and model.body("body").jntnum[0] == 0
    for fixed in ("handle", "shelf"):
        assert model.body(fixed).jntnum[0] == 0
    assert model.site("marker").bodyid[0] == model.body("shelf").id
    assert model.njnt == len(obj.movable_joints)
    for joint in obj.movable_joints:
        mj = model.joint(joint.name)
        dof, qadr = mj.dofadr[0], mj.qposadr[0]
        kind = mujoco.mjtJoint.mjJNT_HINGE if joint.type.angular else mujoco.mjtJoint.mjJNT_SLIDE
        assert mj.type[0] == kind
        assert model.jnt_bodyid[mj.id] == model.body(joint.child).id
        np.testing.assert_allclose(mj.pos, 0.0, atol=0)
        np.testing.assert_allclose(mj.axis, joint.axis, atol=1e-11)
        d = joint.dynamics
        assert model.dof_damping[dof] == d.damping
        assert model.dof_frictionloss[dof] == d.friction
        assert model.jnt_stiffness[mj.id] == d.stiffness
        assert model.qpos_spring[qadr] == d.spring_ref
        assert model.dof_armature[dof] == d.armature
        assert bool(model.jnt_limited[mj.id]) == (joint.limits is not None)
        if joint.limits is not None:
            assert tuple(model.jnt_range[mj.id]) == (joint.limits.lower, joint.limits.upper)
        has_effort = joint.limits is not None and bool(joint.limits.effort)
        assert bool(model.jnt_actfrclimited[mj.id]) == has_effort
        if has_effort:
            assert tuple(model.jnt_actfrcrange[mj.id]) == (-joint.limits.effort,
                                                           joint.limits.effort)
        assert model.key("observed").qpos[qadr] == joint.state
    # Explicit inertials; the massless shelf has none (the marker is a site).
    for part in (p for p in obj.parts if p.name != "marker"):
        b = model.body(part.name)
        if part.inertial is None:
            assert b.mass[0] == 0.0
            continue
        assert b.mass[0] == part.inertial.mass
        np.testing.assert_array_equal(b.ipos, part.inertial.com)
        rot = tf.quat_to_matrix(b.iquat)
        np.testing.assert_allclose(rot @ np.diag(b.inertia) @ rot.T, part.inertial.inertia,
                                   atol=1e-12)
    # Geoms: one non-colliding visual (group 2, the colour) and colliding pieces (group 3).
    for part in (p for p in obj.parts if p.name != "marker"):
        b = model.body(part.name)
        geoms = range(b.geomadr[0], b.geomadr[0] + b.geomnum[0])
        visual = [g for g in geoms if model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0]
        colliding = [g for g in geoms if g not in visual]
        assert len(visual) == (part.visual is not None)
        assert len(colliding) == len(part.collision)
        assert all(model.geom_group[g] == 2 for g in visual)
        assert all(model.geom_group[g] == 3 for g in colliding)
        for g in geoms:
            assert model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH
            np.testing.assert_allclose(model.geom_rgba[g], part.color, atol=1e-7)
    # No contact between a child and its parent, fixed joints included.
    excluded = {frozenset((model.body(int(s >> 16)).name, model.body(int(s & 0xFFFF)).name))
                for s in model.exclude_signature}
    assert excluded == {frozenset((j.parent, j.child)) for j in obj.joints if j.child != "marker"}


def test_compiler_settings_and_mesh_references(exported):
    _, path = exported
    spec = mujoco.MjSpec.from_file(str(path))
    assert spec.compiler.degree is False
    assert spec.compiler.autolimits is True
    assert spec.compiler.inertiafromgeom == mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    assert spec.meshdir == "meshes"
    files = sorted(m.file for m in spec.meshes)
    shared = shared_mesh_files(exported[0])  # each distinct mesh one file, referenced
    assert sorted({Path(r).name for r in shared.values()}) == sorted(
        p.name for p in (path.parent / "meshes").iterdir())
    assert files == sorted({Path(first).name for first in shared.values()})
    assert len(files) < len(shared)  # (its collision pieces equal to visuals share them)
    assert "shelf.obj" in files and not any("shelf_collision" in f for f in files)


def test_build_spec_compiles_with_nothing_on_disk(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    obj = cabinet()
    model = mjcf.build_spec(obj).compile()
    assert model.nbody + model.nsite == len(obj.parts) + 1 and model.nmesh == mesh_count(obj)
    assert list(tmp_path.iterdir()) == []


def test_build_spec_reads_an_existing_mesh_folder(exported):
    obj, path = exported
    spec = mjcf.build_spec(obj, mesh_dir=path.parent / "meshes")
    assert spec.compile().nmesh == mesh_count(obj)
    # The same spec as text is the saved file, except where the meshes are read from.
    text = mjcf.to_xml(spec, obj).replace(f'meshdir="{path.parent / "meshes"}"',
                                          'meshdir="meshes"')
    assert text == path.read_text()


# -- round trips -----------------------------------------------------------------------------
def test_import_of_export_is_the_same_model(exported):
    obj, path = exported
    with warnings.catch_warnings():
        warnings.simplefilter("error", Real2CodeWarning)  # our own files need no repair
        back = mjcf.load(path)
    assert differences(obj, back, tol=1e-6) == []
    assert back.metadata == obj.metadata
    assert [p.name for p in back.parts_in_tree_order()] == [
        p.name for p in obj.parts_in_tree_order()]
    door = back.joint("door_hinge").limits
    assert (door.effort, door.velocity) == (5.0, 2.0)
    assert back.joint("drawer_slide").limits.effort == 0.0
    assert back.part("marker").color == obj.part("marker").color
    assert back.part("shelf").inertial is None and back.part("shelf").collision == []


def test_export_import_export_gives_the_same_bytes(exported, tmp_path):
    obj, path = exported
    again = mjcf.save(mjcf.load(path), tmp_path / "again")
    assert again.read_bytes() == path.read_bytes()
    third = mjcf.save(mjcf.load(again), tmp_path / "third")
    assert third.read_bytes() == path.read_bytes()


def test_output_is_deterministic(exported, tmp_path):
    obj, path = exported
    other = mjcf.save(cabinet(), tmp_path)
    assert other.read_bytes() == path.read_bytes()
    for mesh in (path.parent / "meshes").iterdir():
        assert (tmp_path / "meshes" / mesh.name).read_bytes() == mesh.read_bytes()


def test_registry_export_and_load(tmp_path):
    obj = cabinet()
    written = export(obj, tmp_path, ["mjcf"])
    assert written["mjcf"] == tmp_path / "cabinet.xml"
    assert differences(obj, load_any(written["mjcf"]), tol=1e-6) == []


def test_world_root_part_is_mujocos_world_body(tmp_path):
    obj = cabinet()
    obj.part("body").name = "world"
    for joint in obj.joints:
        joint.parent = "world" if joint.parent == "body" else joint.parent
    path = mjcf.save(obj, tmp_path)
    model = mujoco.MjModel.from_xml_path(str(path))
    assert model.body("door").parentid[0] == 0 and model.body_geomnum[0] == 2
    back = mjcf.load(path)
    assert differences(obj, back, tol=1e-6) == []
    assert mjcf.save(back, tmp_path / "again").read_bytes() == path.read_bytes()


# -- refusals --------------------------------------------------------------------------------
def test_model_mujoco_refuses_leaves_nothing_behind(tmp_path):
    obj = cabinet()
    obj.joint("door_hinge").limits = Limits(0.3, 0.3)  # valid here, refused by MuJoCo
    obj.joint("door_hinge").state = 0.3
    out = tmp_path / "out"
    out.mkdir()
    with pytest.raises(ExportError, match="joint 'door_hinge'.*range"):
        mjcf.save(obj, out)
    assert list(out.iterdir()) == []
    with pytest.raises(ExportError, match="door_hinge"):
        export(obj, tmp_path / "new", ["mjcf"])
    assert not (tmp_path / "new").exists()


def write(path, text):
    path.write_text(text)
    return path


def test_malformed_xml_names_file_and_line(tmp_path):
    path = write(tmp_path / "broken.xml", "<mujoco>\n  <worldbody>\n    <body>\n</mujoco>\n")
    with pytest.raises(FormatError) as err:
        mjcf.load(path)
    assert err.value.path == str(path) and err.value.line is not None
    assert "broken.xml" in str(err.value)


def test_missing_mesh_file_names_file_and_mesh(tmp_path):
    path = write(tmp_path / "nomesh.xml", """<mujoco>
  <asset>
    <mesh name="door" file="gone.obj"/>
  </asset>
  <worldbody><body><geom type="mesh" mesh="door"/></body></worldbody>
</mujoco>
""")
    with pytest.raises(FormatError, match=r"nomesh\.xml:3: <mesh name='door'>: mesh file not found"):
        mjcf.load(path)


@pytest.mark.parametrize("suffix", ["obj", "stl"])
def test_meshes_read_once_compile_as_mujoco_compiles_the_file(tmp_path, suffix):
    """The reader reads an OBJ or STL once and gives MuJoCo its vertices (``give_meshes``): the
    model it reads compiles as MuJoCo compiles the file itself (the mesh's vertices and faces
    bit for bit, its scale, its centring into the geom pose, the mass from the geom), and
    keeps the file's own float64 vertices."""
    from real2code_export.formats.mjcf.read import _compile

    mesh = trimesh.creation.box(extents=(0.3, 0.2, 0.1))
    mesh.apply_translation((0.1, -0.05, 0.02))
    (tmp_path / "meshes").mkdir()
    mesh.export(tmp_path / "meshes" / f"lid.{suffix}")
    path = write(tmp_path / "lid.xml", f"""<mujoco>
  <compiler meshdir="meshes"/>
  <asset>
    <mesh name="lid" file="lid.{suffix}" scale="1 2 0.5"/>
    <mesh name="unused" file="lid.{suffix}"/>
  </asset>
  <worldbody>
    <body name="base"><geom size="0.1"/>
      <body name="lid" pos="0 0 0.2"><joint name="hinge" axis="0 1 0"/>
        <geom type="mesh" mesh="lid" density="300"/></body></body>
  </worldbody>
</mujoco>
""")
    _, model, given = _compile(path)
    assert len(given) == 2  # read here, not by MuJoCo
    direct = mujoco.MjModel.from_xml_path(str(path))
    for field in ("body_mass", "body_inertia", "body_ipos", "body_iquat", "geom_pos",
                  "geom_quat", "geom_size", "mesh_vert", "mesh_face", "mesh_normal"):
        assert np.array_equal(getattr(model, field), getattr(direct, field)), field
    obj = mjcf.load(path)
    lid = next(p for p in obj.parts if p.name == "lid")
    written = np.asarray(mesh.vertices, dtype=np.float32 if suffix == "stl" else np.float64)
    expected = written.astype(np.float64) * [1.0, 2.0, 0.5]  # (an STL's numbers are float32)
    assert np.allclose(np.sort(lid.visual.vertices, axis=0), np.sort(expected, axis=0),
                       rtol=0, atol=1e-12)


def test_compiled_without_collision_structures_reads_the_same(tmp_path):
    """The reader compiles with collisions off (MuJoCo then builds no convex hulls or
    collision trees, a quarter of the compile): every mass, inertia and frame as MuJoCo
    compiles the file, a mesh with ``inertia="convex"`` weighed by its hull still, and each
    geom's ``contype`` and ``conaffinity`` as written, in the model and in the spec."""
    from real2code_export.formats.mjcf.read import _compile

    ell = trimesh.Trimesh(*_ell_prism())  # not convex: its hull weighs more
    ell.export(tmp_path / "ell.stl")
    path = write(tmp_path / "ell.xml", """<mujoco>
  <asset><mesh name="ell" file="ell.stl" inertia="convex"/>
         <mesh name="plain" file="ell.stl"/></asset>
  <worldbody>
    <body name="base"><geom type="mesh" mesh="ell" contype="2" conaffinity="5"/>
      <body name="arm" pos="0 0 1"><joint axis="0 1 0"/>
        <geom type="mesh" mesh="plain"/>
        <geom type="box" size="0.1 0.1 0.1" contype="0" conaffinity="0" group="2"/></body></body>
  </worldbody>
</mujoco>
""")
    spec, model, _ = _compile(path)
    direct = mujoco.MjModel.from_xml_path(str(path))
    for field in ("body_mass", "body_inertia", "body_ipos", "body_iquat", "geom_pos",
                  "geom_quat", "geom_size", "geom_contype", "geom_conaffinity", "mesh_vert"):
        assert np.array_equal(getattr(model, field), getattr(direct, field)), field
    assert [(g.contype, g.conaffinity) for g in spec.geoms] == [(2, 5), (1, 1), (0, 0)]
    assert model.body_mass[1] > model.body_mass[2]  # the hull's volume, not the mesh's
    assert direct.body_bvhnum.sum() > 0 and model.body_bvhnum.sum() == 0


def _ell_prism() -> tuple[np.ndarray, np.ndarray]:
    """An L-shaped prism, 2 x 2 x 1 with a 1 x 1 notch: 3 of volume, its hull 3.5."""
    ring = [(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)]
    vertices = np.array([(x, y, z) for z in (0, 1) for x, y in ring], dtype=float)
    n = len(ring)
    faces = [f for i in range(n) for f in ((i, (i + 1) % n, (i + 1) % n + n),
                                           (i, (i + 1) % n + n, i + n))]
    cap = [(0, 1, 2), (0, 2, 3), (0, 3, 4), (0, 4, 5)]
    faces += [(c, b, a) for a, b, c in cap] + [(a + n, b + n, c + n) for a, b, c in cap]
    return vertices, np.array(faces)


def test_stl_mujoco_refuses_is_refused_as_before(tmp_path):
    """An ASCII STL, which MuJoCo's decoder refuses, is not given to MuJoCo read by ours (which
    reads ASCII for URDF files): the MJCF is refused with MuJoCo's message, naming the mesh."""
    (tmp_path / "lid.stl").write_text(
        trimesh.exchange.stl.export_stl_ascii(trimesh.creation.box(extents=(0.3, 0.2, 0.1))))
    path = write(tmp_path / "lid.xml", """<mujoco>
  <asset><mesh name="shell" file="lid.stl"/></asset>
  <worldbody><body name="lid"><freejoint/><geom type="mesh" mesh="shell"/></body></worldbody>
</mujoco>
""")
    with pytest.raises(FormatError, match=r"lid\.xml:2: <mesh name='shell'>: .*ASCII"):
        mjcf.load(path)


def test_compile_error_names_file_element_and_line(tmp_path):
    path = write(tmp_path / "physics.xml", """<mujoco>
  <worldbody>
    <body name="base"><geom size="0.1"/>
      <body name="lid">
        <joint name="hinge"/>
        <inertial pos="0 0 0" mass="1" diaginertia="0.1 0.1 0.5"/>
      </body>
    </body>
  </worldbody>
</mujoco>
""")
    with pytest.raises(FormatError, match=r"physics\.xml:4: <body name='lid'>: inertia must satisfy"):
        mjcf.load(path)


BALL_AND_FREE = """<mujoco model="rod">
  <worldbody>
    <body name="base" pos="0.1 0.2 0.9" quat="0.9 0 0.3 0.1">
      <freejoint name="base_free"/>
      <geom size="0.1" mass="2"/>
      <body name="arm" pos="0 0 -0.2">
        <joint name="shoulder" type="ball" pos="0 0 0.05" damping="0.01" armature="0.002"
               range="0 45"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.02"/>
        <body name="hand" pos="0 0 -0.3">
          <joint name="wrist_bend" axis="0 1 0" range="-1 1"/>
          <joint name="wrist_ball" type="ball"/>
          <geom size="0.03"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_ball_and_free_joints_through_every_format(tmp_path):
    """A free body and ball joints (one alone, one after a hinge in the same body) read as
    floating and ball joints, held at their reference pose, a limited ball with its cone
    (MuJoCo's range, degrees here); every export reads back equal and agrees with the source
    in its own tools; URDF, which has no ball joint, says so; a cone altered in the USD or the
    glTF is a mismatch with the source."""
    source = write(tmp_path / "rod.xml", BALL_AND_FREE)
    obj, _ = load_with_warnings(source)
    kinds = {j.name: j.type.value for j in obj.joints}
    assert kinds == {"base_free": "floating", "shoulder": "ball", "wrist_bend": "revolute",
                     "wrist_ball": "ball"}
    assert obj.root.name == "world" and obj.joint("base_free").parent == "world"
    assert obj.joint("shoulder").dynamics.damping == pytest.approx(0.01)
    assert obj.joint("shoulder").dynamics.armature == pytest.approx(0.002)
    assert obj.joint("shoulder").cone_limit == pytest.approx(np.pi / 4)
    assert obj.joint("wrist_ball").cone_limit is None
    poses = forward_kinematics(obj)
    np.testing.assert_allclose(poses["base"][:3, 3], [0.1, 0.2, 0.9], atol=1e-12)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        written = export(obj, tmp_path / "out")
    said = "\n".join(str(w.message) for w in caught)
    assert "'shoulder': URDF has no ball joint" in said
    for fmt, path in written.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Real2CodeWarning)
            back = load_any(path)
        diffs = [d for d in differences(obj, back) if "mesh" not in d and "collision" not in d
                 and "colour" not in d]
        assert not diffs, f"{fmt}: {diffs}"
    from real2code_export.check import check_files

    report = check_files(list(written.values()), source=source, n_configurations=5,
                         validate=False)
    assert report.ok, [m.message for m in report.mismatches]
    model = mujoco.MjModel.from_xml_path(str(written["mjcf"]))
    kinds = {model.joint(i).name: int(model.jnt_type[i]) for i in range(model.njnt)}
    assert kinds["base_free"] == mujoco.mjtJoint.mjJNT_FREE
    assert kinds["shoulder"] == kinds["wrist_ball"] == mujoco.mjtJoint.mjJNT_BALL
    np.testing.assert_allclose(model.joint("shoulder").range, [0, np.pi / 4])
    assert model.joint("shoulder").limited and not model.joint("wrist_ball").limited
    usda = written["usd"].read_text()
    assert usda.count("physics:coneAngle0Limit = 45") == 1, usda
    altered = tmp_path / "out" / "cone.usda"  # each cone altered: a mismatch in each file
    altered.write_text(usda.replace("coneAngle0Limit = 45", "coneAngle0Limit = 30").replace(
        "coneAngle1Limit = 45", "coneAngle1Limit = 30"))
    edit_glb(written["gltf"], _cone(0.5))
    report = check_files([altered, written["gltf"]], source=source, n_configurations=5,
                         validate=False)
    found = [m.message for m in report.mismatches
             if m.kind == "dynamics" and "joint 'shoulder': range" in m.message]
    assert len(found) == 2 and any("coneAngle0Limit" in m for m in found) \
        and any("2-D angular limit" in m for m in found), found



def _cone(value: float):
    """An edit of a glTF document setting every 2-D angular limit (a ball's cone) to
    ``value``."""
    def edit(doc):
        for joint in doc["extensions"]["KHR_physics_rigid_bodies"]["physicsJoints"]:
            for limit in joint["limits"]:
                if len(limit.get("angularAxes", [])) == 2:
                    limit["max"] = value
    return edit


def test_free_joint_below_the_top_level_is_refused(tmp_path):
    path = write(tmp_path / "free.xml", """<mujoco>
  <worldbody>
    <body name="base"><geom size="0.1"/>
      <body name="arm"><freejoint/><geom size="0.1"/></body>
    </body>
  </worldbody>
</mujoco>
""")
    with pytest.raises(FormatError, match=r"free\.xml.*free"):
        mjcf.load(path)


def test_a_model_without_geoms_loads(tmp_path):
    """Nothing to draw or collide (a body of an inertial, a joint and a site): the reader's
    count of geoms with their own contact parameters is zero, not an error."""
    path = write(tmp_path / "bare.xml", """<mujoco>
  <worldbody>
    <body name="arm"><inertial pos="0 0 0" mass="1" diaginertia="0.1 0.1 0.1"/>
      <joint name="hinge" axis="0 0 1"/><site name="tip"/></body>
  </worldbody>
</mujoco>
""")
    obj = mjcf.load(path)
    assert [j.name for j in obj.joints if j.type.movable] == ["hinge"]


def test_visual_geoms_under_discardvisual_are_kept(tmp_path):
    """``discardvisual`` is MuJoCo's run-time saving, not the file's content: the visual
    geoms it would drop are read (said), so every export shows them."""
    path = write(tmp_path / "dv.xml", """<mujoco>
  <compiler discardvisual="true"/>
  <worldbody>
    <body name="arm"><joint name="hinge" axis="0 0 1"/><geom size="0.1" mass="1"/>
      <geom type="box" size="0.3 0.01 0.01" contype="0" conaffinity="0" group="1" mass="0"/>
    </body>
  </worldbody>
</mujoco>
""")
    with pytest.warns(Real2CodeWarning, match=r"discardvisual='true'.*the visual geoms kept"):
        obj = mjcf.load(path)
    arm = next(p for p in obj.parts if p.name == "arm")
    assert np.isclose(np.ptp(arm.visual.vertices[:, 0]), 0.6)  # the box, 0.6 m long
    assert np.isclose(arm.inertial.mass, 1.0)


def test_geoms_of_several_colours_in_one_body_are_kept(tmp_path):
    """A body whose visual geoms differ in colour keeps each geom's colour per face (the
    part's is the first's), and the MJCF export writes a geom per colour."""
    path = write(tmp_path / "two.xml", """<mujoco>
  <worldbody>
    <body name="arm"><joint name="hinge" axis="0 0 1"/>
      <geom size="0.1" rgba="1 0 0 1" mass="1"/><geom size="0.05" pos="0 0 0.2" rgba="0 0 1 1"/>
    </body>
  </worldbody>
</mujoco>
""")
    obj = mjcf.load(path)
    arm = obj.parts[-1]
    assert arm.color == (1.0, 0.0, 0.0, 1.0)
    assert [c for _, c in arm.visual.colors] == [(1.0, 0.0, 0.0, 1.0), (0.0, 0.0, 1.0, 1.0)]
    written = export(obj, tmp_path / "out", formats=["mjcf"])
    back = mjcf.load(written["mjcf"])
    assert differences(obj, back) == []


def test_unlimited_slide_is_kept_in_every_format(tmp_path):
    """An MJCF slide without a range (a planar walker's root) is a prismatic joint without
    limits: unlimited in MJCF, USD and glTF, SDF's +-1e16 in URDF, read back without limits,
    and every export agrees with the source."""
    from real2code_export.check import check_files

    path = write(tmp_path / "slide.xml", """<mujoco>
  <worldbody>
    <body name="base"><geom size="0.1"/>
      <body name="cart"><joint name="rail" type="slide" axis="1 0 0" damping="0.5"/>
        <geom size="0.1"/></body>
    </body>
  </worldbody>
</mujoco>
""")
    obj = mjcf.load(path)
    rail = next(j for j in obj.joints if j.name == "rail")
    assert rail.type is JointType.PRISMATIC and rail.limits is None
    written = export(obj, tmp_path / "out")
    for fmt, file in written.items():
        back = load_any(file)
        assert not [d for d in differences(obj, back) if "colour" not in d], fmt
    report = check_files(list(written.values()), source=path, validate=False)
    assert report.ok, [m.message for m in report.mismatches]


def test_unnamed_joints_are_matched_with_the_source(tmp_path):
    """Unnamed hinges and slides (one in a named body, one in a body with several joints of
    an unnamed body) are compared with the joints our reader names after their parts."""
    from real2code_export.check import check_files

    path = write(tmp_path / "unnamed.xml", """<mujoco>
  <worldbody>
    <body name="base"><geom size="0.1"/>
      <body name="arm" pos="0.2 0 0"><joint axis="0 1 0"/><geom size="0.05"/></body>
      <body pos="0 0.3 0"><joint name="lift" type="slide" range="-0.2 0.5"/>
        <joint type="hinge" axis="1 0 0" pos="0 0 0.1"/><geom size="0.05"/></body>
    </body>
  </worldbody>
</mujoco>
""")
    written = export(mjcf.load(path), tmp_path / "out")
    report = check_files(list(written.values()), source=path, validate=False)
    assert report.ok, [m.message for m in report.mismatches]


# -- third-party MJCF ------------------------------------------------------------------------
PRISM_OBJ = """v 0 0 0
v 0.1 0 0
v 0 0.1 0
v 0 0 0.05
v 0.1 0 0.05
v 0 0.1 0.05
f 1 3 2
f 4 5 6
f 1 2 5
f 1 5 4
f 2 3 6
f 2 6 5
f 3 1 4
f 3 4 6
"""

THIRD_PARTY = """<mujoco model="third party">
  <compiler angle="degree" meshdir="assets"/>
  <default>
    <default class="panel">
      <geom type="box" rgba="0.2 0.4 0.6 1"/>
      <joint damping="0.3" armature="0.02"/>
    </default>
  </default>
  <asset>
    <material name="steel" rgba="0.9 0.1 0.1 1"/>
    <mesh name="prism" file="prism.obj" scale="2 1 1"/>
  </asset>
  <worldbody>
    <body name="base frame" pos="0 0 0.5" euler="0 0 30">
      <freejoint/>
      <inertial pos="0 0 0.1" mass="5" diaginertia="0.3 0.2 0.15" quat="0.9 0.1 0.2 0.3"/>
      <geom type="box" size="0.3 0.3 0.05"/>
      <frame pos="0.1 0 0" euler="90 0 0">
        <body name="lid" pos="0 0.05 0" childclass="panel">
          <joint name="lid hinge" type="hinge" pos="0.2 0 0" axis="0 1 0" range="-10 80"
                 ref="15" springref="20" stiffness="0.5"/>
          <geom size="0.2 0.01 0.2" contype="0" conaffinity="0"/>
          <geom type="capsule" fromto="0 0 0 0.1 0 0.05" size="0.01"/>
          <geom type="mesh" mesh="prism" pos="0 0.1 0" euler="0 0 45" contype="0"
                conaffinity="0" class="main" material="steel"/>
          <body name="knob" pos="0.1 0.1 0">
            <joint type="hinge" axis="1 0 0"/>
            <geom type="cylinder" size="0.02 0.01" mass="0.1"/>
          </body>
        </body>
      </frame>
      <body name="slider" pos="0 0.2 0">
        <joint name="slide" type="slide" axis="1 0 0" range="0 0.3" pos="0.01 0.02 0.03"/>
        <geom type="sphere" size="0.05" group="1"/>
        <geom type="ellipsoid" size="0.05 0.03 0.02" group="3"/>
        <inertial pos="0 0 0" mass="1" fullinertia="0.01 0.02 0.025 0.001 0 0"/>
      </body>
    </body>
  </worldbody>
  <actuator><motor joint="slide"/><general joint="slide" dyntype="integrator"/></actuator>
</mujoco>
"""


@pytest.fixture
def third_party(tmp_path):
    (tmp_path / "assets").mkdir()
    (tmp_path / "assets" / "prism.obj").write_text(PRISM_OBJ)
    return write(tmp_path / "third_party.xml", THIRD_PARTY)


def load_with_warnings(path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        obj = mjcf.load(path)
    return obj, "\n".join(str(w.message) for w in caught if w.category is Real2CodeWarning)


def test_third_party_structure_names_and_repairs(third_party):
    obj, said = load_with_warnings(third_party)
    assert obj.name == "third_party"
    # The free body stands 0.5 m up, turned 30 degrees: it hangs from the world at that pose.
    assert {p.name for p in obj.parts} == {"world", "base_frame", "lid", "knob", "slider"}
    assert obj.root.name == "world"
    assert {j.name: j.type.value for j in obj.joints} == {
        "base_frame_joint": "floating", "lid_hinge": "revolute", "knob_joint": "continuous",
        "slide": "prismatic"}
    base_pose = forward_kinematics(obj)["base_frame"]
    np.testing.assert_allclose(base_pose[:3, 3], [0, 0, 0.5])
    np.testing.assert_allclose(base_pose[:3, :3], tf.axis_angle_matrix([0, 0, 1], np.radians(30)),
                               atol=1e-12)
    # The motor is the slide's drive; the integrator has no place in the model: kept as
    # MuJoCo writes it, in the metadata, after the marker of the drive's place.
    assert obj.joint("slide").drive.kind.value == "effort"
    kept = obj.metadata["mjcf_elements"]["actuator"]
    assert 'dyntype="integrator"' in kept and "<motor" not in kept
    assert kept.index("real2code:drive slide") < kept.index("<general")
    assert "kept as metadata 'mjcf_elements'" in said
    for expected in ("'base frame' -> 'base_frame'",
                     "'lid hinge' -> 'lid_hinge'", "1 actuator"):
        assert expected in said, said
    lid = obj.joint("lid_hinge")
    np.testing.assert_allclose([lid.limits.lower, lid.limits.upper], np.radians([-10, 80]))
    assert lid.dynamics.damping == pytest.approx(0.3)  # from the class
    assert lid.dynamics.armature == pytest.approx(0.02)
    assert lid.dynamics.spring_ref == pytest.approx(np.radians(20))
    assert lid.state == pytest.approx(np.radians(15))  # no keyframe: the pose as written
    # The lid: a visual box and the prism mesh (both non-colliding) and a colliding capsule,
    # which shows (group 0) and so serves as both.
    lid_part = obj.part("lid")
    assert len(lid_part.collision) == 1
    assert len(lid_part.visual.vertices) == 8 + len(lid_part.collision[0].vertices) + 6
    # its colours per face: the steel prism's (meshes first: the part's colour), the panel's
    assert [c for _, c in lid_part.visual.colors] == [pytest.approx((0.9, 0.1, 0.1, 1.0)),
                                                       pytest.approx((0.2, 0.4, 0.6, 1.0))]
    assert lid_part.color == pytest.approx((0.9, 0.1, 0.1, 1.0))
    # The base's one box collides and shows: it serves as both.
    base = obj.part("base_frame")
    assert len(base.collision) == 1 and base.visual is not None
    # The slider's group-1 sphere is its visual, both of its geoms collide.
    slider = obj.part("slider")
    assert len(slider.collision) == 2
    assert len(slider.visual.vertices) == len(slider.collision[0].vertices)
    # The knob's inertial is MuJoCo's, inferred from its geom.
    assert obj.part("knob").inertial.mass == pytest.approx(0.1)


def test_third_party_geometry_and_kinematics_are_mujocos(third_party):
    """At random joint values (by name; ref and anchors handled), every imported collision
    piece sits where MuJoCo puts its geom, and the visual of the lid contains MuJoCo's mesh."""
    obj, _ = load_with_warnings(third_party)
    model = mujoco.MjModel.from_xml_path(str(third_party))
    data = mujoco.MjData(model)
    qpos_adr = {"lid_hinge": model.joint("lid hinge").qposadr[0],
                "knob_joint": model.jnt_qposadr[model.body("knob").jntadr[0]],  # unnamed
                "slide": model.joint("slide").qposadr[0]}
    bodies = {"base_frame": "base frame", "lid": "lid", "knob": "knob", "slider": "slider"}
    rng = np.random.default_rng(3)
    for _ in range(20):
        q = sample_configuration(obj, rng)
        poses = forward_kinematics(obj, q)
        data.qpos[:] = model.qpos0
        for name, adr in qpos_adr.items():
            data.qpos[adr] = q[name]
        mujoco.mj_kinematics(model, data)
        for part_name, body_name in bodies.items():
            b = model.body(body_name)
            geoms = [g for g in range(b.geomadr[0], b.geomadr[0] + b.geomnum[0])
                     if model.geom_contype[g] or model.geom_conaffinity[g]]
            for piece, g in zip(obj.part(part_name).collision, geoms, strict=True):
                world = piece.transformed(poses[part_name]).vertices
                local = (world - data.geom_xpos[g]) @ data.geom_xmat[g].reshape(3, 3)
                np.testing.assert_allclose(local.mean(axis=0), 0.0, atol=1e-9)
                if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
                    np.testing.assert_allclose(np.abs(local).max(axis=0), model.geom_size[g],
                                               atol=1e-9)
                if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_CAPSULE:
                    radius, half = model.geom_size[g][:2]
                    assert np.abs(local[:, 2]).max() == pytest.approx(half + radius, abs=1e-9)
        # The prism: MuJoCo's (float32) vertices placed by MuJoCo == ours placed by the model.
        g = next(g for g in range(model.ngeom) if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH)
        mesh = model.geom_dataid[g]
        verts = model.mesh_vert[model.mesh_vertadr[mesh]:model.mesh_vertadr[mesh]
                                + model.mesh_vertnum[mesh]]
        theirs = verts @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g]
        ours = obj.part("lid").visual.transformed(poses["lid"]).vertices
        distance = np.linalg.norm(theirs[:, None, :] - ours[None, :, :], axis=2).min(axis=1)
        assert distance.max() < 1e-6


def test_third_party_import_exports_losslessly(third_party, tmp_path):
    obj, _ = load_with_warnings(third_party)
    first = mjcf.save(obj, tmp_path / "first")
    back = mjcf.load(first)
    assert differences(obj, back, tol=1e-6) == []
    assert mjcf.save(back, tmp_path / "second").read_bytes() == first.read_bytes()


def test_world_geoms_make_a_world_root_part(tmp_path):
    path = write(tmp_path / "scene.xml", """<mujoco model="scene">
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <geom name="post" type="box" size="0.05 0.05 0.5" pos="0 0 0.5"/>
    <body name="door" pos="0.05 0 0.5">
      <joint name="hinge" axis="0 0 1" range="0 1.5"/>
      <geom type="box" size="0.01 0.3 0.4" pos="0 0.3 0"/>
    </body>
  </worldbody>
</mujoco>
""")
    obj, said = load_with_warnings(path)
    assert obj.root.name == "world"
    assert obj.joint("hinge").parent == "world"
    assert len(obj.part("world").collision) == 1  # the plane has no finite surface
    assert "plane" in said
    again = mjcf.save(obj, tmp_path / "out")
    assert differences(obj, mjcf.load(again), tol=1e-6) == []


# -- the procedural generator, when present --------------------------------------------------
def _categories() -> list[str]:
    try:
        from pipeline.procedural import CATEGORIES
    except ImportError:
        return ["absent"]
    return list(CATEGORIES)


@pytest.mark.parametrize("category", _categories())
def test_generated_objects_round_trip(category, tmp_path):
    if category == "absent":
        pytest.skip("pipeline.procedural is not available")
    from pipeline.procedural import generate

    obj = generate(category, None, 11)
    path = mjcf.save(obj, tmp_path / "a")
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    rng = np.random.default_rng(0)
    for _ in range(20):
        q = sample_configuration(obj, rng)
        theirs = world_poses(model, data, qpos_for(model, q))
        for name, pose in forward_kinematics(obj, q).items():
            np.testing.assert_allclose(theirs[name], pose, atol=1e-9)
    back = mjcf.load(path)
    assert differences(obj, back, tol=1e-6) == []
    assert mjcf.save(back, tmp_path / "b").read_bytes() == path.read_bytes()


# -- real third-party objects (PartNet-Mobility URDF) through MJCF ---------------------------
PARTNET_SAMPLE = ["40147", "11361", "100189", "12553"]  # small ones: the URDF reader is slow


@pytest.mark.partnet
@pytest.mark.parametrize("object_id", PARTNET_SAMPLE)
def test_partnet_objects_through_mjcf(object_id, tmp_path):
    folder = partnet_dir() / object_id
    if not folder.is_dir():
        pytest.skip(f"PartNet-Mobility object {object_id} not in the shared data")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)  # the URDF reader's repairs
        obj = load_any(folder / "mobility.urdf")
    path = mjcf.save(obj, tmp_path / "a")
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    rng = np.random.default_rng(5)
    for _ in range(20):
        q = sample_configuration(obj, rng)
        theirs = world_poses(model, data, qpos_for(model, q))
        for name, pose in forward_kinematics(obj, q).items():
            np.testing.assert_allclose(theirs[name], pose, atol=1e-9)
    back = mjcf.load(path)
    assert differences(obj, back, tol=1e-6) == []
    assert mjcf.save(back, tmp_path / "b").read_bytes() == path.read_bytes()


TWO_JOINTS = """<mujoco model="two_joints">
  <worldbody>
    <body name="base">
      <geom type="box" size="0.1 0.1 0.1" mass="1"/>
      <body name="head" pos="0 0 0.3" euler="0 0 20">
        <joint name="pitch" axis="0 1 0" pos="0.05 0 0" range="-1 1" ref="0.2"/>
        <joint name="roll" axis="1 0 0" pos="0 0.02 0.1" range="-1 1"/>
        <joint name="lift" type="slide" axis="0 0 1" range="0 0.1"/>
        <geom type="box" size="0.05 0.03 0.02" pos="0.1 0 0" mass="0.2"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_a_body_with_several_joints_is_a_chain_that_moves_as_mujoco_moves_it(tmp_path):
    path = write(tmp_path / "two_joints.xml", TWO_JOINTS)
    obj, said = load_with_warnings(path)
    assert "split into a chain of massless parts" in said and "head (3 joints)" in said
    assert [j.name for j in obj.joints] == ["pitch", "roll", "lift"]
    assert {p.name for p in obj.parts} == {"base", "head_pitch", "head_roll", "head"}
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    rng = np.random.default_rng(0)
    for _ in range(20):
        q = sample_configuration(obj, rng)
        for name, value in q.items():
            data.qpos[model.joint(name).qposadr[0]] = value
        mujoco.mj_kinematics(model, data)
        head = forward_kinematics(obj, q)["head"]
        np.testing.assert_allclose(head[:3, 3], data.xpos[model.body("head").id], atol=1e-12)
        np.testing.assert_allclose(head[:3, :3], data.xmat[model.body("head").id].reshape(3, 3),
                                   atol=1e-12)
    back = mjcf.load(mjcf.save(obj, tmp_path / "out"))
    assert not differences(obj, back)


# A planar walker's root (two slides and a hinge in one body, its height a ref, as Gymnasium's
# hopper has it), a tilted chain of hinges with refs off their body origin, and a joint with a
# ref, a springref and a joint equality whose polynomial is about the refs.
REFS = """<mujoco model="refs">
  <compiler angle="radian"/>
  <worldbody>
    <body name="torso" pos="0 0 1.25">
      <joint name="rootx" type="slide" axis="1 0 0" limited="false"/>
      <joint name="rootz" type="slide" axis="0 0 1" ref="1.25" limited="false"/>
      <joint name="rooty" type="hinge" axis="0 1 0" limited="false"/>
      <geom type="capsule" size="0.05" fromto="0 0 -0.2 0 0 0.2" mass="3"/>
      <body name="arm" pos="0.3 0 0" euler="0.2 0 0.4">
        <joint name="hx" axis="1 0 0" pos="0.1 0 0" ref="0.3" range="-1 1"/>
        <joint name="hy" axis="0 1 0.2" pos="0 0.2 0" ref="-0.5" range="-2 1"/>
        <joint name="sz" type="slide" axis="0 0 1" ref="0.1" range="-0.5 0.5"/>
        <geom type="capsule" size="0.02" fromto="0 0 0 0.2 0 0" mass="0.5"/>
        <body name="tip" pos="0.2 0 0">
          <joint name="tz" axis="0 0 1" ref="0.7" springref="0.2" stiffness="3"/>
          <geom type="sphere" size="0.03" mass="0.1"/>
        </body>
      </body>
    </body>
  </worldbody>
  <equality><joint joint1="tz" joint2="hx" polycoef="0.1 2 0 0 0"/></equality>
</mujoco>
"""


def test_joint_refs_are_where_the_export_starts_in_mujoco(tmp_path):
    """A joint's ref is the model's joint state (the pose the object starts in): the MJCF
    export has the source's refs (MuJoCo's qpos0), hence its bodies where the source has them
    before anything moves, its joint equality's polynomial and its springs; kinematics at any
    value and the model read back are the same."""
    source = write(tmp_path / "refs.xml", REFS)
    obj = mjcf.load(source)
    assert obj.joint("rootz").state == 1.25 and obj.joint("hy").state == -0.5
    path = mjcf.save(obj, tmp_path / "out")
    src, exp = (mujoco.MjModel.from_xml_path(str(p)) for p in (source, path))
    for j in range(src.njnt):
        name = src.joint(j).name
        assert src.qpos0[src.jnt_qposadr[j]] == pytest.approx(
            exp.qpos0[exp.joint(name).qposadr[0]], abs=1e-12), name
        assert src.qpos_spring[src.jnt_qposadr[j]] == pytest.approx(
            exp.qpos_spring[exp.joint(name).qposadr[0]], abs=1e-12), name
    np.testing.assert_allclose(exp.eq_data[0], src.eq_data[0], atol=1e-12)
    poses = [world_poses(m, mujoco.MjData(m), m.qpos0) for m in (src, exp)]
    for body in ("torso", "arm", "tip"):
        np.testing.assert_allclose(poses[1][body], poses[0][body], atol=1e-12, err_msg=body)
    rng = np.random.default_rng(1)
    data = mujoco.MjData(exp)
    for _ in range(20):
        q = sample_configuration(obj, rng)
        fk, mj = forward_kinematics(obj, q), world_poses(exp, data, qpos_for(exp, q))
        for body in ("torso", "arm", "tip"):
            np.testing.assert_allclose(mj[body], fk[body], atol=1e-12, err_msg=body)
    assert not differences(obj, mjcf.load(path))


CHAINED_EQUALITIES = """<mujoco model="chain">
  <worldbody>
    <body name="a"><joint name="j1" axis="0 0 1"/><geom type="box" size=".1 .02 .02" mass="1"/>
      <body name="b" pos=".2 0 0"><joint name="j2" axis="0 0 1"/>
        <geom type="box" size=".1 .02 .02" mass="1"/>
        <body name="c" pos=".2 0 0"><joint name="j3" axis="0 0 1"/>
          <geom type="box" size=".1 .02 .02" mass="1"/></body></body></body>
  </worldbody>
  <equality>
    <joint joint1="j2" joint2="j1" polycoef="0.1 -0.5 0 0 0"/>
    <joint joint1="j3" joint2="j2"/>
  </equality>
</mujoco>
"""


def test_chained_joint_equalities_are_one_coupling_to_the_first_leader(tmp_path):
    """Joint equalities chained (j3 = j2, j2 = 0.1 - 0.5 j1: MuJoCo applies each) read as
    mimics of the chain's first leader (j3 = 0.1 - 0.5 j1), the same coupling, warned; the
    MJCF export holds it: at a configuration meeting the source's equalities the export's
    are met too, and off it both are violated alike."""
    source = write(tmp_path / "chain.xml", CHAINED_EQUALITIES)
    with pytest.warns(Real2CodeWarning, match=r"joint 'j3': mimics 'j2' which mimics 'j1': "
                      r"coupled to 'j1' directly \(multiplier -0.5, offset 0.1\)"):
        obj = mjcf.load(source)
    assert obj.joint("j3").mimic == Mimic("j1", -0.5, 0.1)
    assert obj.joint("j2").mimic == Mimic("j1", -0.5, 0.1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        path = mjcf.save(obj, tmp_path / "out")
    for j3_off in (0.0, 0.2):
        residuals = []
        for model in (mujoco.MjModel.from_xml_path(str(p)) for p in (source, path)):
            data = mujoco.MjData(model)
            j1 = 0.3
            data.qpos[[model.joint(n).qposadr[0] for n in ("j1", "j2", "j3")]] = \
                [j1, 0.1 - 0.5 * j1, 0.1 - 0.5 * j1 + j3_off]
            mujoco.mj_forward(model, data)
            rows = data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY
            residuals.append(np.abs(data.efc_pos[rows]).max())
        if j3_off == 0.0:
            assert max(residuals) < 1e-12, residuals
        else:
            assert min(residuals) == pytest.approx(j3_off), residuals


def test_a_tactile_sensor_whose_body_collides_is_read(tmp_path):
    """MuJoCo's compiler wants a colliding geom on a tactile sensor's body, which the reader's
    compile without collision hulls (every geom's collisions off) lacks: such a file is
    compiled as written and read (it was refused, "Touch sensor requires a body with at
    least one collision geom"), the pad's mass and joint as MuJoCo has them."""
    source = write(tmp_path / "tactile.xml", """<mujoco model="tactile">
  <asset><mesh name="plate" builtin="plate" params="5 5" scale=".05 .05 .01"/></asset>
  <worldbody>
    <body name="pad" pos="0 0 0.1"><joint name="z" type="slide" axis="0 0 1" range="-0.1 0.1"/>
      <geom type="box" size=".05 .05 .01" mass="0.1"/>
      <geom name="skin" type="mesh" mesh="plate" mass="0" contype="0" conaffinity="0"/></body>
  </worldbody>
  <sensor><tactile geom="skin" mesh="plate"/></sensor>
</mujoco>""")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        obj = mjcf.load(source)
    assert obj.part("pad").inertial.mass == pytest.approx(0.1)
    assert obj.joint("z").type is JointType.PRISMATIC


def test_joint_states_in_every_format(tmp_path):
    """The state (MJCF's ref) round-trips through every format; URDF, which has no initial
    joint position, holds it in real2code:state (its tools start at 0; docs/formats.md)."""
    obj = mjcf.load(write(tmp_path / "refs.xml", REFS))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        written = export(obj, tmp_path / "out")
    from lxml import etree

    held = {j.get("name") for j in etree.parse(str(written["urdf"])).iter("joint")
            if any(key.endswith("}state") for key in j.attrib)}
    assert held == {j.name for j in obj.movable_joints if j.state != 0.0} and "rootz" in held
    for fmt, path in written.items():
        back = load_any(path)
        states = {j.name: j.state for j in back.movable_joints}
        assert states == pytest.approx({j.name: j.state for j in obj.movable_joints},
                                       abs=1e-9), fmt


def test_a_mesh_file_of_vertices_only_is_their_convex_hull_as_in_mujoco(tmp_path):
    """An OBJ with vertices and no faces (a point cloud): MuJoCo meshes it as their convex
    hull; the reader takes that hull, with a warning naming the mesh, and the body's mass is
    MuJoCo's. A mesh file with no vertices at all is still refused."""
    points = np.random.default_rng(0).normal(size=(30, 3))
    (tmp_path / "points.obj").write_text("".join(f"v {x} {y} {z}\n" for x, y, z in points))
    source = tmp_path / "cloud.xml"
    source.write_text("""<mujoco model="cloud">
      <asset><mesh name="points" file="points.obj" scale="0.1 0.1 0.1"/></asset>
      <worldbody><body name="rock"><freejoint/><geom type="mesh" mesh="points"/></body>
      </worldbody></mujoco>""")
    with pytest.warns(Real2CodeWarning, match="points.obj has vertices but no triangles"):
        obj = load_any(source)
    hull = trimesh.convex.convex_hull(points * 0.1)
    rock = obj.part("rock")
    assert len(rock.visual.faces) == len(hull.faces)
    assert rock.inertial.mass == pytest.approx(
        mujoco.MjModel.from_xml_path(str(source)).body_mass[1], rel=1e-6)
    empty = tmp_path / "empty"  # (another folder: the mesh cache knows the first file)
    empty.mkdir()
    (empty / "points.obj").write_text("# nothing\n")
    (empty / "cloud.xml").write_text(source.read_text())
    with pytest.raises(FormatError, match="<mesh name='points'>: at least 4 vertices"):
        load_any(empty / "cloud.xml")


def _bolts(tmp_path, box: bool = False) -> ArticulatedObject:
    """An MJCF whose one mesh (a bolt) three geoms use, two in one body (red, blue) and one
    in another (and, ``box``, a box geom beside them), read: one asset placed six times
    (three visuals, three colliders)."""
    (tmp_path / "bolt.obj").write_text(trimesh.exchange.obj.export_obj(
        trimesh.creation.box(extents=(0.02, 0.03, 0.05)), include_normals=False))
    extra = '    <geom type="box" size="0.01 0.01 0.01" pos="0 0 -0.1"/>\n' if box else ""
    path = write(tmp_path / "bolts.xml", """<mujoco>
  <asset><mesh name="bolt" file="bolt.obj"/></asset>
  <worldbody><body name="base">
    <geom type="mesh" mesh="bolt" pos="0.1 0 0" euler="0 0 30" rgba="1 0 0 1"/>
    <geom type="mesh" mesh="bolt" pos="-0.1 0 0" rgba="0 0 1 1"/>
""" + extra + """    <body name="arm" pos="0 0 0.2"><joint name="hinge" axis="0 0 1" range="-1 1"/>
      <geom type="mesh" mesh="bolt" pos="0 0.1 0" euler="90 0 0" mass="0.1"/>
    </body></body></worldbody>
</mujoco>
""")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        return mjcf.load(path)


def test_a_mesh_used_by_several_geoms_is_one_placed_asset(tmp_path):
    """A mesh asset used by several geoms (two in one body, one in another, as a robot's
    wheels and bolts are) reads as one asset placed at each geom's pose (Mesh.placements):
    the USD export writes its data once and places it by reference, and reads back equal."""
    obj = _bolts(tmp_path)
    placements = [p for part in obj.parts for m in [part.visual, *part.collision]
                  if m is not None for p in m.placements]
    assert len(placements) == 6  # 3 visuals, 3 colliders
    assert all(p.asset is placements[0].asset for p in placements)
    for part in obj.parts:
        for m in [part.visual, *part.collision]:
            for p in m.placements:
                np.testing.assert_allclose(m.vertices[p.vertex:p.vertex_end],
                                           p.asset.transformed(p.pose).vertices, atol=1e-15)
    written = export(obj, tmp_path / "out", ["usd"])
    text = written["usd"].read_text()
    assert text.count("references = </bolts/MeshAssets/mesh_0>") == 6
    assert "MeshAssets/mesh_1" not in text
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        back = load_any(written["usd"])
    assert differences(obj, back, 1e-6) == []
    for name in ("base", "arm"):
        np.testing.assert_allclose(back.part(name).visual.vertices,
                                   obj.part(name).visual.vertices, atol=1e-7)
        assert back.part(name).visual.colors == obj.part(name).visual.colors


def test_a_mesh_used_by_several_geoms_is_one_file_in_every_file_format(tmp_path):
    """The same placed asset in the formats that write mesh files (MJCF, URDF, object.json,
    one meshes/ folder): the asset is one file, each placement a geom / <visual> /
    <collision> / entry naming it at its pose; each reads back equal, the asset placed again
    (so written so again: a second export gives the same bytes); object.json bit for bit."""
    obj = _bolts(tmp_path, box=True)
    written = export(obj, tmp_path / "out", ["mjcf", "urdf", "json"])
    meshes = sorted(p.name for p in (tmp_path / "out" / "meshes").iterdir())
    assert meshes == ["base_mesh_0.obj"], meshes  # 3 visuals and 3 colliders place it
    xml, urdf_text = written["mjcf"].read_text(), written["urdf"].read_text()
    assert xml.count('mesh="base_mesh_0"') == 6 and xml.count("<mesh ") == 1, xml
    assert urdf_text.count('filename="meshes/base_mesh_0.obj"') == 6, urdf_text
    again = {}
    for fmt, out in written.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Real2CodeWarning)
            back = load_any(out)
        assert differences(obj, back, 0.0 if fmt == "json" else 1e-9) == [], fmt
        placed = [p.asset for part in back.parts for m in [part.visual, *part.collision]
                  if m is not None for p in m.placements]
        assert len(placed) == 6 and all(a is placed[0] for a in placed), fmt
        for name in ("base", "arm"):
            assert back.part(name).visual.colors == obj.part(name).visual.colors, fmt
        again[fmt] = export(back, tmp_path / f"again_{fmt}", [fmt])[fmt]
        assert again[fmt].read_bytes() == out.read_bytes(), fmt
    assert (tmp_path / "again_json" / "meshes" / "base_mesh_0.obj").read_bytes() == \
        (tmp_path / "out" / "meshes" / "base_mesh_0.obj").read_bytes()


def test_a_mesh_used_by_several_geoms_is_instanced_by_glTF_nodes(tmp_path):
    """glTF: a visual wholly of placed assets is a child node per placement (its TRS the
    pose, its material the colour) of the asset's one mesh data; the Khronos validator
    finds no error; our reader joins the children back into the part's visual, placing one
    asset."""
    import json
    import struct

    from real2code_export.formats.gltf import validator as gltf_validator

    obj = _bolts(tmp_path)
    glb = export(obj, tmp_path / "out", ["gltf"])["gltf"]
    data = glb.read_bytes()
    doc = json.loads(data[20:20 + struct.unpack_from("<I", data, 12)[0]])
    nodes = {n["name"]: n for n in doc["nodes"]}
    assert "mesh" not in nodes["base"] and "mesh" not in nodes["arm"]
    placed = [nodes[n] for n in ("base_mesh_0", "base_mesh_1", "arm_mesh_0")]
    positions = {doc["meshes"][n["mesh"]]["primitives"][0]["attributes"]["POSITION"]
                 for n in placed}
    assert len(positions) == 1  # the asset's vertex data once
    assert len({doc["meshes"][n["mesh"]]["primitives"][0]["material"] for n in placed}) == 3
    report = gltf_validator.validate_gltf(glb)
    assert report["errors"] == 0, report["messages"]
    back = load_any(glb)
    assert differences(obj, back, 1e-6) == []
    for name in ("base", "arm"):
        assert back.part(name).visual.colors == obj.part(name).visual.colors
    visual_assets = [p.asset for part in back.parts for p in part.visual.placements]
    assert len(visual_assets) == 3 and all(a is visual_assets[0] for a in visual_assets)
    again = export(back, tmp_path / "again", ["gltf"])["gltf"]
    assert again.read_bytes() == data
