"""glTF export/import: the Khronos validator, the probe against forward kinematics, the
animations, lossless round trips, import of other glTF files, and bad input.

Tolerances: kinematics to 1e-6 m / 1e-6 rad (node transforms are float64 JSON numbers).
Vertex positions are float32 in glTF: a coordinate |x| < 2 m is off by at most half a
float32 ulp (1.2e-7 m), so meshes are compared with the same 1e-6 tolerance.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pygltflib
import pytest
import trimesh

from real2code_export import transforms as tf
from real2code_export.errors import FormatError, Real2CodeWarning
from real2code_export.formats import export as export_formats
from real2code_export.formats import gltf
from real2code_export.formats import load as load_any
from real2code_export.formats.gltf import validator as gltf_validator
from real2code_export.formats.gltf.physics import BOX_CORNERS, BOX_FACES, box_mesh
from real2code_export.model import (
    ArticulatedObject,
    Dynamics,
    Inertial,
    Joint,
    Limits,
    Mesh,
    Part,
    differences,
    forward_kinematics,
    sample_configuration,
    validate,
)
from real2code_export.probes import open_probes

TOL = 1e-6
Y_UP_TO_Z_UP = np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])


# -- test objects ----------------------------------------------------------------------------
def box(extents, centre=(0.0, 0.0, 0.0)) -> Mesh:
    m = trimesh.creation.box(extents=extents)
    return Mesh(np.asarray(m.vertices) + centre, np.asarray(m.faces))


def cylinder(radius, height) -> Mesh:
    m = trimesh.creation.cylinder(radius=radius, height=height, sections=16)
    return Mesh(np.asarray(m.vertices), np.asarray(m.faces))


def solid_box(mass, extents, com=(0.0, 0.0, 0.0)) -> Inertial:
    a, b, c = extents
    return Inertial(mass, com, np.diag([b * b + c * c, a * a + c * c, a * a + b * b]) * mass / 12)


def body() -> Part:
    return Part("body", visual=box([0.6, 0.4, 0.8], (0, 0, 0.4)),
                collision=[box([0.6, 0.4, 0.05], (0, 0, 0.025)), box([0.6, 0.05, 0.8], (0, 0.175, 0.4))],
                inertial=solid_box(10.0, [0.6, 0.4, 0.8], (0, 0, 0.4)), color=(0.5, 0.3, 0.2, 1.0))


def door_part() -> Part:
    # principal axes that are not the part axes
    rot = tf.rpy_to_matrix([0.1, 0.2, 0.3])
    inertia = rot @ solid_box(1.2, [0.02, 0.3, 0.7]).inertia @ rot.T
    return Part("door", visual=box([0.02, 0.3, 0.7], (0.01, 0.15, 0.0)),
                collision=[box([0.02, 0.3, 0.7], (0.01, 0.15, 0.0))],
                inertial=Inertial(1.2, [0.01, 0.15, 0.0], inertia), color=(0.8, 0.1, 0.1, 0.6))


def hinge(parent="body") -> Joint:
    axis = np.array([0.1, 0.2, 1.0])
    return Joint("door_hinge", "revolute", parent, "door",
                 origin=tf.make(tf.rpy_to_matrix([0.1, -0.2, 0.3]), [0.31, -0.2, 0.45]),
                 axis=axis / np.linalg.norm(axis), limits=Limits(-0.3, 2.0, effort=5.0),
                 dynamics=Dynamics(damping=0.5, friction=0.1, stiffness=2.0, spring_ref=0.3,
                                   armature=0.01), state=0.7)


def door_object() -> ArticulatedObject:
    return ArticulatedObject("door", [body(), door_part()], [hinge()],
                             metadata={"category": "test", "empty": {}, "blank": "", "none": None})


def drawer_object() -> ArticulatedObject:
    drawer = Part("drawer", visual=box([0.5, 0.3, 0.1]), collision=[box([0.5, 0.3, 0.1])],
                  inertial=solid_box(0.5, [0.5, 0.3, 0.1]))
    slide = Joint("drawer_slide", "prismatic", "body", "drawer", origin=tf.make(translation=[0.05, 0, 0.2]),
                  axis=[0.0, -0.6, 0.8], limits=Limits(0.0, 0.35, velocity=1.0),
                  dynamics=Dynamics(damping=3.0), state=0.1)
    return ArticulatedObject("drawer", [body(), drawer], [slide])


def knob_object() -> ArticulatedObject:
    knob = Part("knob", visual=cylinder(0.02, 0.03), inertial=solid_box(0.05, [0.04, 0.04, 0.03]))
    spin = Joint("knob_spin", "continuous", "body", "knob",
                 origin=tf.make(tf.rpy_to_matrix([0.0, math.pi / 2, 0.0]), [0.31, 0.0, 0.6]),
                 axis=[0.0, 0.0, 1.0], state=-2.5)
    return ArticulatedObject("knob", [body(), knob], [spin])


def fixed_object() -> ArticulatedObject:
    shelf = Part("shelf", visual=box([0.55, 0.35, 0.02]), inertial=solid_box(0.8, [0.55, 0.35, 0.02]))
    mount = Joint("shelf_mount", "fixed", "body", "shelf",
                  origin=tf.make(tf.rpy_to_matrix([0.0, 0.0, 0.2]), [0.0, 0.0, 0.4]))
    return ArticulatedObject("shelf", [body(), shelf], [mount])


def cabinet_object() -> ArticulatedObject:
    """Everything nested: a door with a massless fixed handle, a drawer carrying a knob,
    a fixed shelf with mass."""
    obj = door_object()
    drawer = drawer_object()
    knob = knob_object()
    knob.joints[0].parent = "drawer"
    knob.joints[0].origin = tf.make(tf.rpy_to_matrix([0.0, math.pi / 2, 0.0]), [0.26, 0.0, 0.0])
    handle = Part("handle", visual=box([0.02, 0.02, 0.12]), color=(0.1, 0.1, 0.1, 1.0))
    grip = Joint("handle_fixed", "fixed", "door", "handle", origin=tf.make(translation=[0.03, 0.25, 0.0]))
    shelf = fixed_object()
    return ArticulatedObject(
        "cabinet", [obj.parts[0], obj.parts[1], handle, drawer.parts[1], knob.parts[1], shelf.parts[1]],
        [obj.joints[0], grip, drawer.joints[0], knob.joints[0], shelf.joints[0]],
        metadata={"category": "storage_furniture"})


def procedural_objects() -> list[ArticulatedObject]:
    try:
        from pipeline.procedural import CATEGORIES, generate, part_count_range
    except ImportError:
        return []
    return [generate(c, part_count_range(c)[1], seed=3) for c in CATEGORIES]


OBJECTS = {o.name: o for o in [door_object(), drawer_object(), knob_object(), fixed_object(),
                               cabinet_object(), *procedural_objects()]}
PROCEDURAL = [o.name for o in procedural_objects()]
for _o in OBJECTS.values():
    validate(_o)


@pytest.fixture(scope="module")
def exported(tmp_path_factory) -> dict:
    out = tmp_path_factory.mktemp("gltf")
    return {name: gltf.save(obj, out / name, write_meshes=False) for name, obj in OBJECTS.items()}


@pytest.fixture(scope="module")
def documents(exported) -> dict:
    """pygltflib's reading of each exported file (slow for big files: read once)."""
    cache: dict = {}

    class Lazy(dict):
        def __missing__(self, name):
            cache[name] = pygltflib.GLTF2.load(str(exported[name]))
            self[name] = cache[name]
            return cache[name]

    return Lazy()


# -- helpers reading the file independently (pygltflib + numpy) ------------------------------
def local_matrix(node) -> np.ndarray:
    t = np.eye(4)
    if node.rotation:
        x, y, z, w = node.rotation
        t[:3, :3] = tf.quat_to_matrix([w, x, y, z])
    if node.translation:
        t[:3, 3] = node.translation
    return t


def part_worlds(doc: pygltflib.GLTF2, override: dict[int, np.ndarray] | None = None) -> dict:
    """World (Z up) of every part node, composing the stored node transforms."""
    override = override or {}
    out, stack = {}, [(i, Y_UP_TO_Z_UP) for i in doc.scenes[doc.scene].nodes]
    while stack:
        i, parent = stack.pop()
        node = doc.nodes[i]
        world = parent @ override.get(i, local_matrix(node))
        if "part" in (node.extras or {}).get("real2code", {}):
            out[node.name] = world
        stack.extend((c, world) for c in node.children)
    return out


def accessor(doc: pygltflib.GLTF2, index: int) -> np.ndarray:
    acc = doc.accessors[index]
    view = doc.bufferViews[acc.bufferView]
    width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[acc.type]
    data = np.frombuffer(doc.binary_blob(), dtype="<f4", count=acc.count * width,
                         offset=(view.byteOffset or 0) + (acc.byteOffset or 0))
    return data.reshape(acc.count, width).astype(float)


def rotation_error(a: np.ndarray, b: np.ndarray) -> float:
    r = a[:3, :3].T @ b[:3, :3]
    s = np.linalg.norm([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]]) / 2
    return math.atan2(s, (np.trace(r) - 1) / 2)


def assert_poses_equal(expected: dict, actual: dict, what: str) -> None:
    assert set(expected) == set(actual), what
    for name, pose in expected.items():
        dt = float(np.abs(pose[:3, 3] - actual[name][:3, 3]).max())
        dr = rotation_error(pose, actual[name])
        assert dt < TOL and dr < TOL, f"{what}: part {name!r} off by {dt:.3g} m, {dr:.3g} rad"


# -- the Khronos validator ---------------------------------------------------------------------
def test_khronos_validator_reports_zero_errors(exported, capsys):
    paths = list(exported.values())
    try:
        reports = gltf.validate_gltf_files(paths)
    except gltf.ValidatorUnavailable as e:
        pytest.fail(f"the Khronos glTF validator must run here: {e}")
    with capsys.disabled():
        for path, report in zip(paths, reports, strict=True):
            print(f"\n[gltf-validator {report['validator_version']}] {path.name}: "
                  f"{report['errors']} errors, {report['warnings']} warnings, "
                  f"{report['infos']} infos")
            for m in report["messages"]:
                if m["severity"] in ("error", "warning"):
                    print(f"  {m['severity']}: {m['code']} {m['pointer']}: {m['message']}")
    for path, report in zip(paths, reports, strict=True):
        errors = [m for m in report["messages"] if m["severity"] == "error"]
        assert report["errors"] == 0, f"{path.name}: {errors}"
        assert report["report"]["uri"] == path.name  # it really read our file


def test_an_object_without_meshes_is_a_valid_glb(tmp_path):
    """A URDF of one empty link (MuJoCo's test model "tool") has no mesh: its glb has no
    buffer and no binary chunk (glTF refuses a buffer of 0 bytes), passes the validator and
    reads back equal."""
    obj = validate(ArticulatedObject("tool", [Part("tool")]))
    path = gltf.save(obj, tmp_path / "tool", write_meshes=False)
    assert gltf.validate_gltf(path)["errors"] == 0
    assert differences(obj, gltf.load(path)) == []


def test_validator_rejects_a_broken_file(exported, tmp_path):
    data = exported["door"].read_bytes()
    broken = tmp_path / "broken.glb"
    broken.write_bytes(data[: len(data) // 2])
    assert gltf.validate_gltf(broken)["errors"] > 0


def test_validator_missing_gives_install_hint(monkeypatch, tmp_path, exported):
    monkeypatch.setattr(gltf_validator, "VALIDATOR_DIR", tmp_path)
    with pytest.raises(gltf.ValidatorUnavailable, match="npm ci"):
        gltf.validate_gltf(exported["door"])
    monkeypatch.setattr(gltf_validator.shutil, "which", lambda name: None)
    with pytest.raises(gltf.ValidatorUnavailable, match="Node.js"):
        gltf.validate_gltf(exported["door"])


# -- structure ---------------------------------------------------------------------------------
def test_file_structure(documents):
    doc = documents["cabinet"]
    obj = OBJECTS["cabinet"]
    assert doc.extensionsUsed == ["KHR_physics_rigid_bodies", "KHR_implicit_shapes"]
    assert not doc.extensionsRequired
    root = doc.nodes[doc.scenes[doc.scene].nodes[0]]
    assert root.rotation == pytest.approx([-math.sqrt(0.5), 0, 0, math.sqrt(0.5)])
    nodes = {n.name: n for n in doc.nodes}
    # a visible part: float32 positions with bounds, unit normals, a linear-colour material
    door = doc.meshes[nodes["door"].mesh].primitives[0]
    assert doc.accessors[door.attributes.POSITION].min is not None
    normals = accessor(doc, door.attributes.NORMAL)
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-6)
    material = doc.materials[door.material]
    assert material.pbrMetallicRoughness.baseColorFactor == list(obj.part("door").color)
    assert material.alphaMode == "BLEND"
    # collision pieces: colliders under the part; a box is an implicit shape the collider
    # node places, any other piece's mesh is on a node outside the scene
    physics = doc.extensions["KHR_physics_rigid_bodies"]
    kinds = [_collider_kinds(documents[o.name], o) for o in OBJECTS.values()]
    assert set().union(*kinds) == {"box", "mesh"} and kinds[list(OBJECTS).index("cabinet")]
    # the hinge: attachment frames with X along the axis, limits about X, the passive drive
    joint = nodes["door_hinge_attach_parent"].extensions["KHR_physics_rigid_bodies"]["joint"]
    assert doc.nodes[joint["connectedNode"]].name == "door_hinge_attach_child"
    desc = physics["physicsJoints"][joint["joint"]]
    hinge_joint = obj.joint("door_hinge")
    assert {"angularAxes": [0], "min": -0.3, "max": 2.0} in desc["limits"]
    assert desc["drives"] == [{"type": "angular", "mode": "force", "axis": 0, "positionTarget": 0.3,
                               "stiffness": 2.0, "velocityTarget": 0.0, "damping": 0.5}]
    attach = local_matrix(nodes["door_hinge_attach_parent"])
    assert np.allclose(attach[:3, 0], hinge_joint.axis, atol=1e-12)
    motion = nodes["door"].extensions["KHR_physics_rigid_bodies"]["motion"]
    x, y, z, w = motion["inertiaOrientation"]
    rot = tf.quat_to_matrix([w, x, y, z])
    assert np.allclose(rot @ np.diag(motion["inertiaDiagonal"]) @ rot.T,
                       obj.part("door").inertial.inertia, atol=1e-12)
    # the massless handle on a fixed joint belongs to the door's body; the root is static
    assert not nodes["handle"].extensions and not nodes["body"].extensions
    assert "motion" in nodes["shelf"].extensions["KHR_physics_rigid_bodies"]
    # first every joint together (the animation importers make active), then one per joint
    assert [a.name for a in doc.animations] == [f"{obj.name} all joints",
                                                *(j.name for j in obj.movable_joints)]
    together = doc.animations[0]
    assert together.extras["real2code"]["joints"] == [j.name for j in obj.movable_joints]
    assert len({(c.target.node, c.target.path) for c in together.channels}) == \
        len(obj.movable_joints)


def test_save_writes_shared_meshes_and_registry_export(tmp_path):
    obj = OBJECTS["door"]
    path = gltf.save(obj, tmp_path / "a")
    assert path == tmp_path / "a" / "door.glb"
    assert (tmp_path / "a" / "meshes" / "door.obj").is_file()
    assert (tmp_path / "a" / "meshes" / "body_collision_1.obj").is_file()
    written = export_formats(obj, tmp_path / "b", ["gltf"])
    assert written["gltf"].read_bytes() == path.read_bytes()
    assert not differences(obj, load_any(written["gltf"]), TOL)


# -- kinematics ----------------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(OBJECTS))
def test_probe_matches_forward_kinematics(exported, name):
    obj = OBJECTS[name]
    (probe,) = open_probes(exported[name])
    assert probe.label == "glTF (nodes + joint metadata)"
    assert sorted(probe.parts) == sorted(p.name for p in obj.parts)
    assert {j.name: (j.kind, j.lower, j.upper) for j in probe.joints} == {
        j.name: (j.type.value, *((j.limits.lower, j.limits.upper) if j.limits else (None, None)))
        for j in obj.movable_joints}
    rng = np.random.default_rng(7)
    for k in range(100):
        q = sample_configuration(obj, rng)
        assert_poses_equal(forward_kinematics(obj, q), probe.poses(q), f"{name} configuration {k}")


@pytest.mark.parametrize("name", list(OBJECTS))
def test_file_is_posed_at_the_observed_state(documents, name):
    obj = OBJECTS[name]
    doc = documents[name]
    assert_poses_equal(forward_kinematics(obj, obj.observed_configuration()), part_worlds(doc),
                       f"{name} as stored")


@pytest.mark.parametrize("name", ["cabinet", *PROCEDURAL])
def test_animations_pose_parts_as_forward_kinematics(documents, name):
    obj = OBJECTS[name]
    doc = documents[name]
    state = obj.observed_configuration()
    together, *per_joint = doc.animations
    assert len(per_joint) == len(obj.movable_joints)
    for anim in per_joint:
        joint = obj.joint(anim.name)
        # the animation of every joint plays this joint's keys on the same node
        (same,) = [c for c in together.channels if c.target.node == anim.channels[0].target.node]
        assert together.samplers[same.sampler] == anim.samplers[anim.channels[0].sampler]
        (channel,) = anim.channels
        sampler = anim.samplers[channel.sampler]
        assert sampler.interpolation == "LINEAR"
        times, keys = accessor(doc, sampler.input), accessor(doc, sampler.output)
        values = anim.extras["real2code"]["values"]
        assert np.all(np.diff(times[:, 0]) > 0) and len(values) == len(times) == len(keys)
        if joint.limits is not None:  # lower -> upper -> lower
            assert values[0] == values[-1] == joint.limits.lower
            assert max(values) == joint.limits.upper
        else:  # a full turn
            assert values[-1] - values[0] == pytest.approx(2 * math.pi)
        if channel.target.path == "rotation":  # slerp between keys stays on the joint axis
            steps = [2 * math.acos(min(1.0, abs(float(np.dot(a, b))))) for a, b in zip(keys[:-1], keys[1:], strict=True)]
            assert max(steps) < math.pi / 2
        for key, value in zip(keys, values, strict=True):
            local = np.eye(4)
            if channel.target.path == "rotation":
                x, y, z, w = key
                local[:3, :3] = tf.quat_to_matrix([w, x, y, z])
            else:
                local[:3, 3] = key
            posed = part_worlds(doc, {channel.target.node: local})
            expected = forward_kinematics(obj, {**state, joint.name: value})
            assert_poses_equal(expected, posed, f"{name} animation {anim.name} at {value}")


# -- round trips -------------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(OBJECTS))
def test_import_export_import_is_lossless_and_idempotent(exported, tmp_path, name):
    obj = OBJECTS[name]
    first = gltf.load(exported[name])
    assert differences(obj, first, TOL) == []  # meshes within float32 rounding (see top)
    assert first.metadata == obj.metadata
    again = gltf.save(obj, tmp_path / "again", write_meshes=False)
    assert again.read_bytes() == exported[name].read_bytes()  # deterministic
    b1 = gltf.save(first, tmp_path / "b1", write_meshes=False)
    assert b1.read_bytes() == exported[name].read_bytes()  # idempotent from the first export
    second = gltf.load(b1)
    assert differences(first, second, tol=0.0) == []


def test_data_the_buffer_holds_is_written_once(tmp_path):
    """Two parts with the same collision mesh (a robot's left and right fingers): the second
    one's accessors are the first's, the data once in the buffer; read back, both have it."""
    obj = OBJECTS["cabinet"]
    first = next(p for p in obj.parts if p.collision and p.collision[0].primitive is None)
    piece = Mesh(first.collision[0].vertices + [0.0, 0.0, 0.01], first.collision[0].faces)
    twin = Part("twin", collision=[piece], inertial=first.inertial)
    other = Part("other", collision=[piece], inertial=first.inertial)
    doubled = ArticulatedObject("doubled", [*obj.parts, twin, other], [
        *obj.joints, Joint("t", "fixed", obj.root.name, "twin"),
        Joint("o", "fixed", obj.root.name, "other", origin=tf.make(None, [0.0, 1.0, 0.0]))])
    path = gltf.save(doubled, tmp_path, write_meshes=False)
    doc = pygltflib.GLTF2().load(str(path))
    meshes = {m.name: m.primitives[0] for m in doc.meshes}
    a, b = meshes["twin_collision_0"], meshes["other_collision_0"]
    assert (a.attributes.POSITION, a.indices) == (b.attributes.POSITION, b.indices)
    views = [doc.accessors[i].bufferView for i in range(len(doc.accessors))]
    assert len(set(views)) == len(views)  # no two accessors over the same data written twice
    assert differences(doubled, gltf.load(path), TOL) == []


def test_pygltflib_rewrites_our_file_byte_for_byte(exported, documents):
    """Our GLB is exactly what pygltflib writes for the document it reads from it."""
    for name in ("cabinet", PROCEDURAL[0] if PROCEDURAL else "door"):
        assert b"".join(documents[name].save_to_bytes()) == exported[name].read_bytes()


def test_gltf_json_with_external_buffer(exported, tmp_path):
    doc = pygltflib.GLTF2.load(str(exported["cabinet"]))
    path = tmp_path / "cabinet.gltf"
    doc.save_json(str(path))  # JSON + cabinet.bin beside it
    assert (tmp_path / "cabinet.bin").is_file()
    assert differences(gltf.load(exported["cabinet"]), load_any(path), tol=0.0) == []
    assert gltf.validate_gltf(path)["errors"] == 0
    (probe,) = open_probes(path)
    obj = OBJECTS["cabinet"]
    q = sample_configuration(obj, np.random.default_rng(1))
    assert_poses_equal(forward_kinematics(obj, q), probe.poses(q), ".gltf probe")


def strip_our_extras(src, dst) -> None:
    doc = pygltflib.GLTF2.load(str(src))
    for item in [*doc.nodes, *doc.animations, *(p for m in doc.meshes for p in m.primitives)]:
        item.extras = {}
    doc.save(str(dst))


def test_import_from_khr_physics_alone(exported, tmp_path):
    """A file with only KHR_physics_rigid_bodies (our extras removed) gives back the joints."""
    obj = OBJECTS["cabinet"]
    path = tmp_path / "cabinet.glb"
    strip_our_extras(exported["cabinet"], path)
    with pytest.warns(Real2CodeWarning, match="KHR_physics_rigid_bodies"):
        khr = gltf.load(path)
    # the massless handle on its fixed joint is part of the door's rigid body
    assert sorted(p.name for p in khr.parts) == sorted(p.name for p in obj.parts if p.name != "handle")
    for joint in khr.joints:
        ref = obj.joint(joint.name)
        assert (joint.type, joint.parent, joint.child) == (ref.type, ref.parent, ref.child)
        assert np.allclose(joint.origin, ref.origin, atol=TOL)
        assert np.allclose(joint.axis, ref.axis, atol=TOL) or not ref.type.movable
        assert joint.state == pytest.approx(ref.state, abs=TOL)
        if ref.limits is not None:
            assert (joint.limits.lower, joint.limits.upper) == pytest.approx(
                (ref.limits.lower, ref.limits.upper), abs=TOL)
        for attr in ("damping", "stiffness", "spring_ref"):
            assert getattr(joint.dynamics, attr) == pytest.approx(getattr(ref.dynamics, attr))
    for part in khr.parts:
        if part.name != "body":
            assert np.allclose(part.inertial.inertia, obj.part(part.name).inertial.inertia, atol=TOL)
    # the door's mesh is the door's plus the handle's, where they are in the original
    rng = np.random.default_rng(3)
    for _ in range(10):
        q = sample_configuration(obj, rng)
        ref, got = forward_kinematics(obj, q), forward_kinematics(khr, q)
        expected = np.concatenate([obj.part(n).visual.transformed(ref[n]).vertices
                                   for n in ("door", "handle")])
        posed = khr.part("door").visual.transformed(got["door"]).vertices
        gap = np.linalg.norm(posed[:, None] - expected[None], axis=2).min(axis=1)
        assert gap.max() < TOL
        assert_poses_equal({n: ref[n] for n in got}, got, "KHR import")
    # check's probe falls back to this importer for files without our extras
    with pytest.warns(Real2CodeWarning):
        (probe,) = open_probes(path)
    assert probe.label.startswith("glTF (imported")
    q = sample_configuration(obj, rng)
    assert_poses_equal({n: forward_kinematics(obj, q)[n] for n in probe.parts}, probe.poses(q),
                       "imported-glTF probe")


def test_import_foreign_khr_physics_file(tmp_path):
    """A hand-written glTF in another tool's layout: bodies side by side at the scene root,
    Y up, the hinge about the world's vertical, the door open by 0.4 rad."""
    import base64
    import json

    triangle = np.array([[0, 0, 0], [0.5, 0, 0], [0, 1, 0]], dtype="<f4")
    s = math.sqrt(0.5)
    x_to_y = [0.0, 0.0, s, s]  # attachment frames: +90 deg about Z puts their X on +Y
    doc = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 2]}],
        "extensionsUsed": ["KHR_physics_rigid_bodies"],
        "extensions": {"KHR_physics_rigid_bodies": {"physicsJoints": [{"limits": [
            {"linearAxes": [0, 1, 2], "min": 0, "max": 0}, {"angularAxes": [1, 2], "min": 0, "max": 0},
            {"angularAxes": [0], "min": 0.0, "max": 1.5}],
            "drives": [{"type": "angular", "mode": "force", "axis": 0, "velocityTarget": 0,
                        "damping": 0.25}]}]}},
        "nodes": [
            {"name": "base", "mesh": 0, "children": [1]},
            {"name": "hinge", "translation": [0.5, 0, 0], "rotation": x_to_y,
             "extensions": {"KHR_physics_rigid_bodies": {"joint": {"connectedNode": 3, "joint": 0}}}},
            {"name": "door", "mesh": 0, "children": [3], "translation": [0.5, 0, 0],
             "rotation": [0.0, math.sin(0.2), 0.0, math.cos(0.2)],
             "extensions": {"KHR_physics_rigid_bodies": {"motion": {"mass": 2.0}}}},
            {"name": "pivot", "rotation": x_to_y}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0, 0, 0], "max": [0.5, 1, 0]}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "buffers": [{"byteLength": 36, "uri": "data:application/octet-stream;base64,"
                     + base64.b64encode(triangle.tobytes()).decode()}],
    }
    path = tmp_path / "foreign.gltf"
    path.write_text(json.dumps(doc))
    assert gltf.validate_gltf(path)["errors"] == 0
    with pytest.warns(Real2CodeWarning, match="1 joint"):
        obj = gltf.load(path)
    (joint,) = obj.joints
    assert (joint.type.value, joint.parent, joint.child) == ("revolute", "base", "door")
    assert (joint.limits.lower, joint.limits.upper) == (0.0, 1.5)
    assert joint.state == pytest.approx(0.4) and joint.dynamics.damping == 0.25
    world = forward_kinematics(obj)  # q = 0: the door closed, hinge vertical at x = 0.5
    hinge_axis = world["door"][:3, :3] @ joint.axis
    assert np.allclose(hinge_axis, [0, 0, 1], atol=1e-12)
    assert np.allclose(world["door"][:3, 3], [0.5, 0, 0], atol=1e-12)
    opened = forward_kinematics(obj, {joint.name: 0.4})["door"]
    door_y_up = tf.make(tf.quat_to_matrix([math.cos(0.2), 0, math.sin(0.2), 0]), [0.5, 0, 0])
    assert np.allclose(opened, Y_UP_TO_Z_UP @ door_y_up, atol=1e-12)
    assert obj.part("door").inertial.mass == 2.0


def test_import_plain_gltf_as_fixed_parts(tmp_path):
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(extents=[1, 1, 1]), node_name="base", geom_name="b")
    scene.add_geometry(trimesh.creation.icosphere(), node_name="ball", geom_name="s",
                       parent_node_name="base",
                       transform=trimesh.transformations.translation_matrix([0, 2, 0]))
    path = tmp_path / "plain.glb"
    path.write_bytes(scene.export(file_type="glb"))
    with pytest.warns(Real2CodeWarning, match="fixed joints"):
        obj = gltf.load(path)
    assert [p.name for p in obj.parts] == ["base", "ball"]
    (joint,) = obj.joints
    assert joint.type.value == "fixed" and (joint.parent, joint.child) == ("base", "ball")
    # glTF +Y (up) is the model's +Z
    assert np.allclose(forward_kinematics(obj)["ball"][:3, 3], [0, 0, 2], atol=1e-12)
    assert np.allclose(obj.part("ball").visual.bounds(), [[-1, -1, -1], [1, 1, 1]], atol=1e-6)


@pytest.mark.partnet
def test_partnet_objects(tmp_path, capsys):
    """Real objects (the three smallest PartNet-Mobility URDFs, loaded by our URDF reader):
    validator, probe and round trip."""
    from conftest import partnet_objects

    folders = sorted(partnet_objects(), key=lambda f: sum(
        p.stat().st_size for p in (f / "textured_objs").glob("*.obj")))[:3]
    objs = [load_any(f / "mobility.urdf") for f in folders]
    paths = [gltf.save(o, tmp_path / o.name, write_meshes=False) for o in objs]
    reports = gltf.validate_gltf_files(paths)
    for obj, path, report in zip(objs, paths, reports, strict=True):
        with capsys.disabled():
            print(f"\n[gltf-validator] {path.name}: {report['errors']} errors, "
                  f"{report['warnings']} warnings, {report['infos']} infos")
        assert report["errors"] == 0, report["messages"]
        assert differences(obj, gltf.load(path), TOL) == []
        (probe,) = open_probes(path)
        rng = np.random.default_rng(5)
        for k in range(100):
            q = sample_configuration(obj, rng)
            assert_poses_equal(forward_kinematics(obj, q), probe.poses(q), f"{obj.name} {k}")


# -- bad input ---------------------------------------------------------------------------------
def test_missing_file(tmp_path):
    path = tmp_path / "nothing.glb"
    with pytest.raises(FormatError, match="not found") as err:
        gltf.load(path)
    assert str(path) in str(err.value)


def test_truncated_glb(exported, tmp_path):
    path = tmp_path / "truncated.glb"
    path.write_bytes(exported["door"].read_bytes()[:-100])
    with pytest.raises(FormatError, match="truncated") as err:
        gltf.load(path)
    assert str(path) in str(err.value) and err.value.element == "GLB header"
    path.write_bytes(b"glTF\x02\x00\x00\x00" + b"\x00" * 4)
    with pytest.raises(FormatError, match=str(path)):
        gltf.load(path)


def test_malformed_gltf_json_names_the_line(tmp_path):
    path = tmp_path / "bad.gltf"
    path.write_text('{"asset": {"version": "2.0"},\n "nodes": [}\n')
    with pytest.raises(FormatError) as err:
        gltf.load(path)
    assert err.value.line == 2 and str(path) in str(err.value)


def test_joint_naming_a_missing_node(exported, tmp_path):
    doc = pygltflib.GLTF2.load(str(exported["door"]))
    index = next(i for i, n in enumerate(doc.nodes) if n.name == "door_hinge")
    doc.nodes[index].extras["real2code"]["child"] = "ghost"
    path = tmp_path / "ghost.glb"
    doc.save(str(path))
    with pytest.raises(FormatError, match="'ghost'") as err:
        gltf.load(path)
    assert str(path) in str(err.value)
    assert err.value.element == f"nodes[{index}] (door_hinge)"


def test_probe_refuses_inconsistent_joint_metadata(exported, tmp_path):
    doc = pygltflib.GLTF2.load(str(exported["door"]))
    joint = next(n for n in doc.nodes if n.name == "door_hinge")
    joint.extras["real2code"]["child"] = "ghost"
    path = tmp_path / "ghost.glb"
    doc.save(str(path))
    with pytest.raises(Exception, match="ghost"):
        open_probes(path)


def test_no_warnings_on_our_own_files(exported):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        gltf.load(exported["cabinet"])


def test_a_range_wider_than_a_turn_is_swept_once_and_kept(tmp_path):
    """Rotors limited to +-1e16 (real URDFs have them): the animation sweeps one turn, the
    range itself reads back exactly."""
    obj = door_object()
    joint = obj.joints[0]
    joint.limits = Limits(-1e16, 1e16)
    path = gltf.save(obj, tmp_path)
    document = pygltflib.GLTF2().load(str(path))
    assert sum(a.count for a in document.accessors) < 10_000
    back = gltf.load(path)
    assert back.joint(joint.name).limits.lower == -1e16
    assert back.joint(joint.name).limits.upper == 1e16


def _collider_kinds(doc, obj) -> set[str]:
    """Check each collision piece's collider; the kinds seen ("box", "mesh")."""
    nodes = {n.name: n for n in doc.nodes}
    shapes = (doc.extensions or {}).get("KHR_implicit_shapes", {}).get("shapes", [])
    in_scene = {c for n in doc.nodes for c in n.children} | set(doc.scenes[0].nodes)
    kinds = set()
    for part in obj.parts:
        for k, piece in enumerate(part.collision):
            node = nodes[f"{part.name}_collision_{k}"]
            geometry = node.extensions["KHR_physics_rigid_bodies"]["collider"]["geometry"]
            if "shape" in geometry:
                shape = shapes[geometry["shape"]]
                assert shape["type"] == "box" and node.mesh is None
                placed = box_mesh(shape["box"]["size"], local_matrix(node)).vertices
                assert np.allclose(placed, piece.vertices, atol=1e-6, rtol=0)
                kinds.add("box")
            else:
                assert geometry["convexHull"] is True and geometry["node"] not in in_scene
                assert doc.nodes[geometry["node"]].mesh is not None
                kinds.add("mesh")
    return kinds


def test_box_layout_is_trimesh_s():
    """Box pieces are recognised by trimesh.creation.box's layout, written out in physics.py."""
    unit = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    assert np.array_equal(unit.vertices, BOX_CORNERS) and np.array_equal(unit.faces, BOX_FACES)


WRAPPED_FREE_BODY = """<mujoco model="kettle">
  <worldbody>
    <geom type="plane" size="1 1 .1"/>
    <body name="wrapper" pos="0.3 0 0.5">
      <freejoint name="free"/>
      <body name="payload" pos="0 0.1 0.05" euler="0 0 30">
        <geom type="box" size=".05 .08 .1" mass="0.88"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_a_massless_free_body_carries_the_mass_welded_below_it(tmp_path):
    """A free body with no mass of its own, its mass in a body welded under it (as MJCF
    writes a kettle): KHR_physics_rigid_bodies can state no zero mass (zero is infinite,
    none is "compute it from the colliders", of which it has none), so the moving node's
    motion carries the welded parts' summed mass properties and the welded part is no body
    of its own; our extras keep each part's own, so the model reads back the same; the
    check against the source agrees (it stated no mass before)."""
    from real2code_export.check import check_files

    source = tmp_path / "kettle.xml"
    source.write_text(WRAPPED_FREE_BODY)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Real2CodeWarning)
        obj = load_any(source)
        written = export_formats(obj, tmp_path / "out", ["gltf"])
    doc = pygltflib.GLTF2().load(str(written["gltf"]))
    khr = {n.name: (n.extensions or {}).get("KHR_physics_rigid_bodies", {}) for n in doc.nodes}
    motion = khr["wrapper"]["motion"]
    assert motion["mass"] == pytest.approx(0.88)
    np.testing.assert_allclose(motion["centerOfMass"], [0, 0.1, 0.05], atol=1e-9)
    assert "motion" not in khr["payload"]
    assert not any("joint" in v for name, v in khr.items() if "payload" in name)
    back = gltf.load(written["gltf"])
    assert back.part("wrapper").inertial is None
    assert back.part("payload").inertial.mass == pytest.approx(0.88)
    report = check_files([written["gltf"]], source=source, n_configurations=5)
    assert report.ok, [m.message for m in report.mismatches]
