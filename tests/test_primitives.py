"""Primitive shapes (box, cylinder, sphere, capsule, ellipsoid) kept as shapes, visual and
collision, through every format and back, and in each format's own element for them."""

from __future__ import annotations

import warnings

import mujoco
import numpy as np
import pytest
from lxml import etree

from real2code_export import transforms as tf
from real2code_export.errors import ModelError, Real2CodeWarning
from real2code_export.formats import export
from real2code_export.formats import load as load_any
from real2code_export.model import Mesh, differences, validate
from real2code_export.primitives import Primitive, ShapeKind

SHAPES = """<mujoco model="shapes">
  <worldbody>
    <body name="base">
      <geom type="box" size="0.1 0.2 0.05" pos="0 0 0.05"/>
      <geom type="cylinder" size="0.03 0.1" pos="0.1 0 0.2" euler="0 1.2 0" contype="0"
            conaffinity="0" group="1"/>
      <body name="arm" pos="0 0 0.3">
        <joint name="hinge" axis="0 1 0" range="-1 1"/>
        <geom type="capsule" fromto="0 0 0 0 0.1 0.3" size="0.02"/>
        <geom type="sphere" size="0.04" pos="0 0 0.3"/>
        <geom type="ellipsoid" size="0.04 0.02 0.01" pos="0 0 0.35" contype="0"
              conaffinity="0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _kinds(mesh: Mesh | None) -> list[tuple[str, list[float]]]:
    return [] if mesh is None else [(s.kind.value, s.size.tolist()) for s in mesh.primitives]


def _quiet_load(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        return load_any(path)


def test_mjcf_shapes_through_every_format(tmp_path):
    source = tmp_path / "shapes.xml"
    source.write_text(SHAPES)
    obj = _quiet_load(source)
    base, arm = obj.part("base"), obj.part("arm")
    assert _kinds(base.visual) == [("box", [0.2, 0.4, 0.1]), ("cylinder", [0.03, 0.2])]
    assert [m.primitive.kind.value for m in base.collision] == ["box"]
    assert [k for k, _ in _kinds(arm.visual)] == ["capsule", "sphere", "ellipsoid"]
    assert arm.visual.primitives[0].size[1] == pytest.approx(np.hypot(0.1, 0.3))
    assert [m.primitive.kind.value for m in arm.collision] == ["capsule", "sphere"]

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        written = export(obj, tmp_path / "out", ["json", "mjcf", "urdf", "usd", "gltf"])
    said = "\n".join(str(w.message) for w in caught)
    assert "URDF has no capsule or ellipsoid: 3 shape(s)" in said
    for fmt, path in written.items():
        back = _quiet_load(path)
        assert not differences(obj, back), (fmt, differences(obj, back))
        again = export(back, tmp_path / f"again_{fmt}", [fmt])[fmt]
        assert not differences(obj, _quiet_load(again)), fmt

    # Each format's own element for the shape (no mesh file for what it can hold)
    model = mujoco.MjModel.from_xml_path(str(written["mjcf"]))
    G = mujoco.mjtGeom
    assert sorted(int(t) for t in model.geom_type) == sorted(int(t) for t in
        [G.mjGEOM_BOX, G.mjGEOM_CYLINDER, G.mjGEOM_BOX, G.mjGEOM_CAPSULE, G.mjGEOM_SPHERE,
         G.mjGEOM_ELLIPSOID, G.mjGEOM_CAPSULE, G.mjGEOM_SPHERE])
    assert model.nmesh == 0
    urdf = etree.parse(str(written["urdf"])).getroot()
    assert len(urdf.findall(".//geometry/box")) == 2
    assert len(urdf.findall(".//geometry/cylinder")) == 1
    assert len(urdf.findall(".//geometry/sphere")) == 2
    from pxr import Usd, UsdGeom, UsdPhysics

    stage = Usd.Stage.Open(str(written["usd"]))
    types = sorted(p.GetTypeName() for p in stage.Traverse() if p.IsA(UsdGeom.Gprim))
    assert types == ["Capsule", "Capsule", "Cube", "Cube", "Cylinder", "Sphere", "Sphere",
                     "Sphere"]
    colliders = [p for p in stage.Traverse() if p.HasAPI(UsdPhysics.CollisionAPI)]
    assert len(colliders) == 3 and not any(p.HasAPI(UsdPhysics.MeshCollisionAPI)
                                           for p in colliders)

    from real2code_export.check import check_files

    report = check_files(list(written.values()), source=source, n_configurations=5,
                         validate=True)
    assert report.ok, [m.message for m in report.mismatches]
    assert all(v.errors == 0 for v in report.validations), report.validations


URDF = """<robot name="boxes">
  <link name="base">
    <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0"
      iyz="0"/></inertial>
    <visual><origin xyz="0 0 0.1" rpy="0.3 0 0"/><geometry><box size="0.2 0.3 0.4"/></geometry>
      <material name="red"><color rgba="1 0 0 1"/></material></visual>
    <visual><geometry><sphere radius="0.05"/></geometry><material name="red"/></visual>
    <collision><origin xyz="0 0 0.1" rpy="0.3 0 0"/><geometry><box size="0.2 0.3 0.4"/>
      </geometry></collision>
    <collision><origin xyz="0 0 -0.2"/><geometry><cylinder radius="0.05" length="0.3"/>
      </geometry></collision>
  </link>
  <link name="lid">
    <inertial><mass value="0.5"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0"
      iyz="0"/></inertial>
    <visual><geometry><capsule radius="0.02" length="0.1"/></geometry></visual>
  </link>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="lid"/>
    <origin xyz="0 0 0.4"/><axis xyz="1 0 0"/><limit lower="0" upper="1.5" effort="1"
    velocity="1"/></joint>
</robot>
"""


def test_urdf_shapes_stay_shapes(tmp_path):
    """Third-party URDF collision shapes are collision pieces as they are (never decomposed);
    a link without <collision> gets its visual shapes; each comes back in every format."""
    source = tmp_path / "boxes.urdf"
    source.write_text(URDF)
    obj = _quiet_load(source)
    base, lid = obj.part("base"), obj.part("lid")
    assert _kinds(base.visual) == [("box", [0.2, 0.3, 0.4]), ("sphere", [0.05])]
    np.testing.assert_allclose(base.visual.primitives[0].pose,
                               tf.make(tf.rpy_to_matrix([0.3, 0, 0]), [0, 0, 0.1]), atol=1e-15)
    assert [_kinds(m) for m in base.collision] == [[("box", [0.2, 0.3, 0.4])],
                                                  [("cylinder", [0.05, 0.3])]]
    assert [_kinds(m) for m in lid.collision] == [[("capsule", [0.02, 0.1])]]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        written = export(obj, tmp_path / "out", ["json", "mjcf", "urdf", "usd", "gltf"])
    for fmt, path in written.items():
        assert not differences(obj, _quiet_load(path)), fmt
    from real2code_export.check import check_files

    report = check_files(list(written.values()), source=source, n_configurations=5,
                         validate=False)
    assert report.ok, [m.message for m in report.mismatches]


def test_usd_scaled_shapes(tmp_path):
    """A scaled cube is a box, an unevenly scaled sphere an ellipsoid, a cylinder along X is
    the model's cylinder turned onto X."""
    from pxr import Usd, UsdGeom

    from real2code_export.formats.usd.geometry import shape_mesh

    stage = Usd.Stage.CreateInMemory()
    cube = UsdGeom.Cube.Define(stage, "/cube")
    cube.CreateSizeAttr(2.0)
    sphere = UsdGeom.Sphere.Define(stage, "/sphere")
    sphere.CreateRadiusAttr(0.5)
    cylinder = UsdGeom.Cylinder.Define(stage, "/cylinder")
    cylinder.CreateAxisAttr("X")
    cylinder.CreateRadiusAttr(0.1)
    cylinder.CreateHeightAttr(0.4)
    scaled = np.diag([0.1, 0.2, 0.3, 1.0])
    box = shape_mesh(cube.GetPrim(), scaled).primitive
    assert box.kind is ShapeKind.BOX
    np.testing.assert_allclose(box.size, [0.2, 0.4, 0.6])
    ellipsoid = shape_mesh(sphere.GetPrim(), scaled).primitive
    assert ellipsoid.kind is ShapeKind.ELLIPSOID
    np.testing.assert_allclose(ellipsoid.size, [0.05, 0.1, 0.15])
    turned = shape_mesh(cylinder.GetPrim(), np.eye(4)).primitive
    assert turned.kind is ShapeKind.CYLINDER
    np.testing.assert_allclose(turned.size, [0.1, 0.4])
    np.testing.assert_allclose(turned.pose[:3, :3] @ [0, 0, 1], [1, 0, 0], atol=1e-15)


def test_concatenation_is_canonical_and_invalid_shapes_refused():
    box = Mesh.of_primitive(Primitive("box", [1, 2, 3]))
    ball = Mesh.of_primitive(Primitive("sphere", [0.5], tf.make(translation=[1, 0, 0])))
    own = Mesh(np.eye(3), [[0, 1, 2]])
    a, b = Mesh.concatenate([box, own, ball]), Mesh.concatenate([own, box, ball])
    assert [s.kind.value for s in a.primitives] == ["box", "sphere"]
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.remainder().vertices, own.vertices)
    assert a.primitive is None and box.primitive is not None
    assert Mesh.concatenate([box, ball]).remainder() is None
    from real2code_export.model import ArticulatedObject, Part

    bad = ArticulatedObject("bad", [Part("p", visual=Mesh.of_primitive(
        Primitive("box", [1.0, 1.0, 1.0])))])
    bad.parts[0].visual.primitives[0].size[1] = -1.0
    with pytest.raises(ModelError, match="sizes must be finite and > 0"):
        validate(bad)


def test_bad_shapes_are_refused_with_file_and_element(tmp_path):
    from real2code_export.errors import FormatError

    bad_size = URDF.replace('<sphere radius="0.05"/>', '<sphere radius="-0.05"/>')
    (tmp_path / "size.urdf").write_text(bad_size)
    with pytest.raises(FormatError, match=r"size\.urdf:\d+: <link name='base'>.*radius"):
        _quiet_load(tmp_path / "size.urdf")
    marked = URDF.replace(
        '<capsule radius="0.02" length="0.1"/>',
        '<mesh filename="x.obj" xmlns:real2code="urn:real2code-export:urdf:1" '
        'real2code:shape="cone" real2code:size="1 2"/>')
    (tmp_path / "cone.urdf").write_text(marked)
    with pytest.raises(FormatError, match=r"cone\.urdf:\d+: <link name='lid'>.*unknown shape"):
        _quiet_load(tmp_path / "cone.urdf")


COLLIDING_ELLIPSOID = """<mujoco model="pebble">
  <worldbody>
    <body name="base"><geom type="box" size="0.1 0.1 0.02"/>
      <body name="pebble" pos="0 0 0.1" euler="0.3 0 0">
        <joint name="turn" axis="0 0 1" range="-1 1"/>
        <geom type="ellipsoid" size="0.04 0.02 0.01" pos="0.01 0 0" euler="0 0 0.5"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_colliding_ellipsoid_in_usd_is_a_convex_mesh_read_back_as_the_shape(tmp_path):
    """UsdPhysics has no ellipsoid and refuses a sphere scaled unevenly as a collider: the
    USD holds a convex mesh that UsdValidation accepts, and reads back as the ellipsoid."""
    from pxr import Usd, UsdPhysics

    from real2code_export.validators import validate_usd

    source = tmp_path / "pebble.xml"
    source.write_text(COLLIDING_ELLIPSOID)
    obj = _quiet_load(source)
    (piece,) = obj.part("pebble").collision
    assert piece.primitive.kind is ShapeKind.ELLIPSOID
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        usd = export(obj, tmp_path / "out", ["usd"])["usd"]
    stage = Usd.Stage.Open(str(usd))
    (collider,) = [p for p in stage.Traverse() if p.HasAPI(UsdPhysics.CollisionAPI)
                   and p.GetName() == "pebble_collision_0"]
    assert collider.GetTypeName() == "Mesh"
    assert UsdPhysics.MeshCollisionAPI(collider).GetApproximationAttr().Get() == "convexHull"
    (validation,) = validate_usd([usd])
    assert validation.errors == 0, validation.messages
    back = _quiet_load(usd)
    assert not differences(obj, back), differences(obj, back)
    assert back.part("pebble").collision[0].primitive.kind is ShapeKind.ELLIPSOID


@pytest.mark.parametrize("kind, size", [
    ("sphere", [0.07]), ("ellipsoid", [0.05, 0.08, 0.11]), ("cylinder", [0.04, 0.3]),
    ("capsule", [0.03, 0.25])])
def test_round_shapes_weigh_what_mujoco_computes(kind, size):
    """A round shape's mass properties are its exact solid's, as MuJoCo (and PhysX) compute
    them, not its tessellation's (up to 3 % less volume: a humanoid's capsules and spheres
    read from USD colliders weighed light); beside a mesh of its own, both count."""
    from real2code_export.inertia import inertial_from_meshes

    pose = tf.make(tf.rpy_to_matrix([0.3, -0.5, 1.1]), [0.1, -0.2, 0.3])
    shape = Primitive(ShapeKind(kind), size, pose)
    mjcf_size = [size[0], size[1] / 2] if kind in ("cylinder", "capsule") else size
    quat = tf.matrix_to_quat(pose[:3, :3])
    xml = (f'<mujoco><worldbody><body><freejoint/><geom type="{kind}" density="800" '
           f'size="{" ".join(map(str, mjcf_size))}" pos="{" ".join(map(str, pose[:3, 3]))}" '
           f'quat="{" ".join(map(str, quat))}"/></body></worldbody></mujoco>')
    m = mujoco.MjModel.from_xml_string(xml)
    ours = inertial_from_meshes([Mesh.of_primitive(shape)], 800.0)
    assert ours.mass == pytest.approx(m.body_mass[1], rel=1e-9)
    np.testing.assert_allclose(ours.com, m.body_ipos[1], atol=1e-12)
    np.testing.assert_allclose(np.linalg.eigvalsh(ours.inertia), np.sort(m.body_inertia[1]),
                               rtol=1e-9)
    box = Mesh.of_primitive(Primitive(ShapeKind.BOX, [0.1, 0.1, 0.1]))
    both = inertial_from_meshes([Mesh.concatenate([box, Mesh.of_primitive(shape)])], 800.0)
    assert both.mass == pytest.approx(m.body_mass[1] + 0.8, rel=1e-9)
