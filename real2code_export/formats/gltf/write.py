"""Write an articulated object as one binary glTF (.glb) with pygltflib.

Node tree (names are the model's; the scene holds one root node):

    <object>                      rotation: Z up -> Y up; extras: object name, metadata
      <root part>                 mesh: visual; extras: part (colour, inertial)
        <part>_mesh_<k>           a visual wholly of mesh assets the object places more than
                                  once: the part node has no mesh, a child per placement
                                  (TRS = its pose; extras: placement k) uses the asset's mesh
                                  (its vertex data once in the buffer, shared by every use)
        <part>_collision_<k>      KHR collider -> an implicit box (TRS places it), or the
                                  geometry node <part>_collision_<k>_geometry (outside the scene)
        <joint>                   TRS = joint origin; extras: the joint (type, axis, limits, ...)
          <joint>_attach_parent   KHR joint -> connectedNode <joint>_attach_child
          <child part>            TRS = the joint motion at the observed state (animated)
            <joint>_attach_child
            ...

The joint motion is the child part node's own rotation (revolute, continuous) or
translation (prismatic), so a viewer plays a joint by animating one node. Each movable
joint's sweep goes lower -> upper -> lower (continuous: one full turn from the state); the
first animation plays every sweep together, and one animation per joint follows.
Node transforms are float64 JSON numbers, so poses survive to ~1e-15; vertex data is
float32. Our extras hold every model value exactly, so our reader is lossless (up to the
float32 vertices) and re-exporting what it read gives the same bytes.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import struct
from pathlib import Path

import numpy as np

from ... import atomic
from ...errors import warn
from ...meshfiles import write_object_meshes
from ...model import (
    UNBOUNDED_SLIDE_SPAN,
    ArticulatedObject,
    Joint,
    JointType,
    Mesh,
    Part,
    Texture,
    metadata_json,
    validate,
)
from ...model_json import drive_json, mimic_json, shape_json
from ...placements import placed_pieces, shared_assets
from .. import output_file
from . import physics
from .conventions import (
    ARRAY_BUFFER,
    ELEMENT_ARRAY_BUFFER,
    EXTRAS_KEY,
    FLOAT,
    KHR_PHYSICS,
    KHR_SHAPES,
    LINEAR,
    LINEAR_MIPMAP_LINEAR,
    REPEAT,
    ROOT_ROTATION_XYZW,
    SCHEMA,
    SCHEMA_VERSION,
    TRIANGLES,
    UNSIGNED_INT,
    UNSIGNED_SHORT,
    axis_angle_xyzw,
    quat_xyzw,
)
from .mesh import VertexData, encode_collision, encode_visual

GENERATOR = "real2code_export"
SWEEP_SECONDS = 2.0  # one leg of a joint's animation (lower -> upper)
MAX_KEY_STEP = math.pi / 8  # rotation keys this close keep slerp on the joint axis


class _Builder:
    """Accumulates glTF objects and one binary buffer, in a deterministic order."""

    def __init__(self):
        import pygltflib

        self.g = pygltflib
        self.gltf = pygltflib.GLTF2(asset=pygltflib.Asset(generator=GENERATOR, version="2.0"))
        self.blob = bytearray()
        self._written: dict[tuple, int] = {}  # (digest of the bytes, how read) -> accessor
        self._textures: dict[tuple[bytes, str], int] = {}  # (image, name) -> texture

    def accessor(self, data: np.ndarray, component: int, type_: str, *, target: int | None = None,
                 bounds: bool = False) -> int:
        """The accessor of ``data``; data the buffer already holds read the same way (a
        collision mesh equal to another part's, a robot's left and right fingers) is that
        accessor, not a second copy (glTF lets primitives share accessors)."""
        g = self.g
        raw = np.ascontiguousarray(data).astype(data.dtype.newbyteorder("<"), copy=False).tobytes()
        key = (hashlib.blake2b(raw, digest_size=32).digest(), len(raw), component, type_,
               target, bounds)
        if key in self._written:
            return self._written[key]
        self.gltf.bufferViews.append(g.BufferView(buffer=0, byteOffset=len(self.blob),
                                                  byteLength=len(raw), target=target))
        self.blob += raw + b"\0" * (-len(raw) % 4)
        count = len(data)
        acc = g.Accessor(bufferView=len(self.gltf.bufferViews) - 1, componentType=component,
                         count=count, type=type_)
        if bounds:
            flat = data.reshape(count, -1)
            acc.min = [v.item() for v in flat.min(axis=0)]
            acc.max = [v.item() for v in flat.max(axis=0)]
        self.gltf.accessors.append(acc)
        self._written[key] = len(self.gltf.accessors) - 1
        return self._written[key]

    def mesh(self, name: str, data: VertexData, material: int | None,
             runs: list[tuple[int, int]] | None = None) -> int:
        """A mesh of one primitive, or (``runs``: (face count, material) over the faces) one
        primitive per run, all reading the same vertex accessors (a visual of several
        colours: glTF's material per primitive)."""
        g = self.g
        attributes = g.Attributes(POSITION=self.accessor(data.positions, FLOAT, "VEC3",
                                                         target=ARRAY_BUFFER, bounds=True))
        if data.normals is not None:
            attributes.NORMAL = self.accessor(data.normals, FLOAT, "VEC3", target=ARRAY_BUFFER)
        if data.texcoords is not None:
            attributes.TEXCOORD_0 = self.accessor(data.texcoords, FLOAT, "VEC2",
                                                  target=ARRAY_BUFFER)
        component = UNSIGNED_SHORT if data.indices.dtype == np.uint16 else UNSIGNED_INT
        source = None if data.source is None else \
            {EXTRAS_KEY: {"source_vertex": self.accessor(data.source, UNSIGNED_INT, "SCALAR")}}
        primitives, start = [], 0
        for count, mat in runs or [(len(data.indices), material)]:
            indices = self.accessor(data.indices[start:start + count].reshape(-1), component,
                                    "SCALAR", target=ELEMENT_ARRAY_BUFFER)
            primitives.append(g.Primitive(attributes=attributes, indices=indices,
                                          mode=TRIANGLES, material=mat, extras=source))
            start += count
        self.gltf.meshes.append(g.Mesh(name=name, primitives=primitives))
        return len(self.gltf.meshes) - 1

    def texture(self, texture: Texture) -> int:
        """The image in the binary buffer (its bytes as read: never re-encoded), one shared
        sampler (linear, repeat), and the texture that joins them; an image several parts
        show (a robot's four legs) is one texture."""
        key = (texture.image, texture.name)
        if key in self._textures:
            return self._textures[key]
        g = self.g
        self.gltf.bufferViews.append(g.BufferView(buffer=0, byteOffset=len(self.blob),
                                                  byteLength=len(texture.image)))
        self.blob += texture.image + b"\0" * (-len(texture.image) % 4)
        self.gltf.images.append(g.Image(name=texture.name, mimeType=texture.mime,
                                        bufferView=len(self.gltf.bufferViews) - 1))
        if not self.gltf.samplers:
            self.gltf.samplers.append(g.Sampler(magFilter=LINEAR, minFilter=LINEAR_MIPMAP_LINEAR,
                                                wrapS=REPEAT, wrapT=REPEAT))
        self.gltf.textures.append(g.Texture(sampler=0, source=len(self.gltf.images) - 1))
        self._textures[key] = len(self.gltf.textures) - 1
        return len(self.gltf.textures) - 1

    def node(self, name: str, **fields) -> int:
        self.gltf.nodes.append(self.g.Node(name=name, **fields))
        return len(self.gltf.nodes) - 1

    def glb(self) -> bytes:
        """The GLB bytes pygltflib's ``save_to_bytes`` gives, without its cost: it deep-copies
        every value while converting to JSON, which took ~85% of an export's time. Same
        JSON (its ``delete_empty_keys`` on a plain copy), same chunk layout (GLB 2.0 spec)."""
        # (no buffer and no binary chunk for an object of no meshes: glTF refuses an empty
        # buffer, byteLength >= 1)
        self.gltf.buffers = [self.g.Buffer(byteLength=len(self.blob))] if self.blob else []
        data = self.g.delete_empty_keys(_plain(self.gltf, self.g.Attributes))
        text = json.dumps(data, allow_nan=False, separators=(",", ":")).encode("utf-8")
        text += b" " * (-(12 + len(text)) % 4)  # the binary chunk starts 4-aligned
        blob = bytes(self.blob)
        chunks = [struct.pack("<I", len(text)), b"JSON", text]
        if blob:
            chunks += [struct.pack("<I", len(blob)), b"BIN\0", blob]
        body = b"".join(chunks)
        return b"".join([b"glTF", struct.pack("<II", 2, 12 + len(body)), body])


_LEAVES = frozenset({int, float, str, bool, type(None)})
_FIELDS: dict[type, tuple[str, ...] | None] = {}


def _plain(value, attributes_type: type):
    """pygltflib's ``gltf_asdict`` without deep copies: dataclasses and Attributes as dicts,
    containers copied, leaves shared (they are only serialised)."""
    cls = type(value)
    if cls in _LEAVES:
        return value
    if cls is list or cls is tuple:
        return cls(v if type(v) in _LEAVES else _plain(v, attributes_type) for v in value)
    if cls is dict:
        return {k: v if type(v) in _LEAVES else _plain(v, attributes_type) for k, v in value.items()}
    if cls is attributes_type:
        return dict(value.__dict__)
    if cls not in _FIELDS:
        _FIELDS[cls] = (tuple(f.name for f in dataclasses.fields(cls))
                        if dataclasses.is_dataclass(cls) else None)
    names = _FIELDS[cls]
    if names is None:
        return value
    return {name: _plain(getattr(value, name), attributes_type) for name in names}


def _floats(values) -> list[float]:
    return [float(v) for v in np.asarray(values, dtype=float).reshape(-1)]


def _part_extras(part: Part) -> dict:
    out: dict = {"part": part.name, "color": _floats(part.color)}
    if part.visual is not None and part.visual.primitives:
        out["visual_shapes"] = [shape_json(s) for s in part.visual.primitives]
    if part.inertial is not None:
        out["inertial"] = {"mass": part.inertial.mass, "com": _floats(part.inertial.com),
                           "inertia": part.inertial.inertia.tolist()}
    return {EXTRAS_KEY: out}


def _joint_extras(joint: Joint) -> dict:
    out: dict = {
        "joint": joint.name, "type": joint.type.value, "parent": joint.parent, "child": joint.child,
        "origin": {"translation": _floats(joint.origin[:3, 3]),
                   "rotation": joint.origin[:3, :3].tolist()},
        "axis": _floats(joint.axis),
        "dynamics": {k: float(getattr(joint.dynamics, k))
                     for k in ("damping", "friction", "stiffness", "spring_ref", "armature")},
        "state": joint.state,
    }
    if joint.mimic is not None:
        out["mimic"] = mimic_json(joint.mimic)
    if joint.limits is not None:  # pygltflib drops None values: absent means None
        lim = {"lower": joint.limits.lower, "upper": joint.limits.upper}
        for key in ("effort", "velocity"):
            if getattr(joint.limits, key) is not None:
                lim[key] = float(getattr(joint.limits, key))
        out["limits"] = lim
    if joint.drive_limits is not None:  # a joint without a range: effort and velocity
        out["drive_limits"] = {k: float(v) for k in ("effort", "velocity")
                               if (v := getattr(joint.drive_limits, k)) is not None}
    if joint.cone_limit is not None:
        out["cone_limit"] = float(joint.cone_limit)
    if joint.drive is not None:  # (KHR_physics_rigid_bodies' drives hold the joint damping)
        out["drive"] = drive_json(joint.drive)
    return {EXTRAS_KEY: out}


def motion_trs(joint: Joint, q: float) -> dict:
    """The child part node's local TRS at joint value ``q`` (the joint motion)."""
    if joint.type.angular:
        return {"rotation": axis_angle_xyzw(joint.axis, q)}
    if joint.type is JointType.PRISMATIC:
        return {"translation": _floats(joint.axis * q)}
    return {}


def sweep(joint: Joint) -> tuple[np.ndarray, np.ndarray]:
    """Key times (s) and joint values of a joint's animation."""
    if joint.limits is None and joint.type.angular:  # continuous: one full turn from the state
        n = int(math.ceil(2 * math.pi / MAX_KEY_STEP))
        values = joint.state + np.linspace(0.0, 2 * math.pi, n + 1)
        return np.linspace(0.0, 2 * SWEEP_SECONDS, n + 1), values
    span = UNBOUNDED_SLIDE_SPAN
    lo, hi = (joint.limits.lower, joint.limits.upper) if joint.limits is not None else \
        (joint.state - span, joint.state + span)
    if not joint.type.angular and hi - lo > 2 * span:  # a slide "limited" at +-1e16
        lo, hi = max(lo, joint.state - span), min(hi, joint.state + span)
    if joint.type.angular and hi - lo > 2 * math.pi:
        # A range wider than a turn (rotors limited to +-1e16): one turn, from the state's
        # half turn back, shows every pose; the range itself is kept in the extras.
        lo = max(lo, joint.state - math.pi)
        hi = lo + 2 * math.pi
    n = max(1, int(math.ceil((hi - lo) / MAX_KEY_STEP))) if joint.type.angular else 1
    leg = np.linspace(lo, hi, n + 1)
    values = np.concatenate([leg, leg[-2::-1]])
    return np.linspace(0.0, 2 * SWEEP_SECONDS, 2 * n + 1), values


def _animations(b: _Builder, obj: ArticulatedObject, animated: list[tuple[Joint, int]]) -> None:
    """First one animation that plays every joint together (importers such as Blender's
    make the first animation the active one, so pressing play moves the whole object), then
    one per joint; both share each joint's key accessors."""
    g = b.g
    order = {joint.name: k for k, joint in enumerate(obj.joints)}
    animated = sorted(animated, key=lambda pair: order[pair[0].name])  # the model's order
    samplers, channels = [], []
    for joint, node in animated:
        times, values = sweep(joint)
        if joint.type.angular:
            keys = np.array([axis_angle_xyzw(joint.axis, q) for q in values], dtype=np.float32)
            path, type_ = "rotation", "VEC4"
        else:
            keys = (values[:, None] * joint.axis[None, :]).astype(np.float32)
            path, type_ = "translation", "VEC3"
        samplers.append(g.AnimationSampler(
            input=b.accessor(times.astype(np.float32), FLOAT, "SCALAR", bounds=True),
            output=b.accessor(keys, FLOAT, type_), interpolation="LINEAR"))
        channels.append((g.AnimationChannelTarget(node=node, path=path), _floats(values)))
    if not animated:
        return
    b.gltf.animations.append(g.Animation(
        name=f"{obj.name} all joints", samplers=samplers,
        channels=[g.AnimationChannel(sampler=k, target=target)
                  for k, (target, _) in enumerate(channels)],
        extras={EXTRAS_KEY: {"joints": [joint.name for joint, _ in animated]}}))
    for (joint, _), sampler, (target, values) in zip(animated, samplers, channels, strict=True):
        b.gltf.animations.append(g.Animation(
            name=joint.name, samplers=[sampler],
            channels=[g.AnimationChannel(sampler=0, target=target)],
            extras={EXTRAS_KEY: {"joint": joint.name, "values": values}}))


def build(obj: ArticulatedObject) -> bytes:
    b = _Builder()
    g = b.g
    tree = obj.tree()
    bodies = physics.bodies(tree)  # part -> what its motion states
    physics_joints: list[dict] = []
    shapes: list[dict] = []  # KHR_implicit_shapes, for box collision pieces
    animated: list[tuple[Joint, int]] = []  # each movable joint and the node it moves
    shared = shared_assets(obj)  # mesh assets placed more than once: instanced by nodes
    asset_meshes: dict[tuple[int, int], int] = {}  # (id(asset), material) -> glTF mesh
    encoded: dict[int, VertexData] = {}  # id(asset) -> its vertex data (normals once)

    def material(part: Part, rgba=None) -> int:
        color = _floats(part.color if rgba is None else rgba)
        maps = part.maps
        # the factors multiply the maps: 1 where a map gives the values
        pbr = g.PbrMetallicRoughness(baseColorFactor=color,
                                     metallicFactor=1.0 if "metallic_roughness" in maps else 0.0,
                                     roughnessFactor=1.0 if "metallic_roughness" in maps else 0.8)
        if part.texture is not None:  # the factor multiplies the image: ours is its tint
            pbr.baseColorTexture = g.TextureInfo(index=b.texture(part.texture))
        if "metallic_roughness" in maps:
            pbr.metallicRoughnessTexture = g.TextureInfo(
                index=b.texture(maps["metallic_roughness"]))
        material = g.Material(
            name=part.name, doubleSided=True,  # scans may have inconsistent winding
            alphaMode="BLEND" if color[3] < 1.0 else "OPAQUE", alphaCutoff=None,
            pbrMetallicRoughness=pbr)
        if "normal" in maps:
            material.normalTexture = g.NormalMaterialTexture(index=b.texture(maps["normal"]))
        if "occlusion" in maps:
            material.occlusionTexture = g.OcclusionTextureInfo(
                index=b.texture(maps["occlusion"]))
        if "emissive" in maps:
            material.emissiveTexture = g.TextureInfo(index=b.texture(maps["emissive"]))
            material.emissiveFactor = [1.0, 1.0, 1.0]
        b.gltf.materials.append(material)
        return len(b.gltf.materials) - 1

    def add_part(part: Part, joint: Joint | None) -> tuple[int, int | None]:
        """The part's node and, if it is its own rigid body, its joint attachment node."""
        mesh = None
        pieces = placed_pieces(part.visual, part, shared) if part.visual is not None \
            and shared and not part.visual.primitives else None
        if part.visual is not None and pieces is None:
            # shapes tessellated (glTF has none), kept in extras
            colours = {rgba: None for _, rgba in part.visual.colors}  # a material per colour
            for rgba in colours:
                colours[rgba] = material(part, rgba)
            runs = [(n, colours[rgba]) for n, rgba in part.visual.colors] or None
            mesh = b.mesh(part.name, encode_visual(part.visual),
                          None if runs else material(part), runs)
        fields = motion_trs(joint, joint.state) if joint is not None else {}
        node = b.node(part.name, mesh=mesh, extras=_part_extras(part), **fields)
        children = b.gltf.nodes[node].children
        materials: dict = {}  # the part's colour (None) or a run's -> its material
        for k, (placement, rgba) in enumerate(pieces or ()):
            if rgba not in materials:
                materials[rgba] = material(part, rgba)
            children.append(b.node(
                f"{part.name}_mesh_{k}", mesh=asset_mesh(placement.asset, materials[rgba]),
                translation=_floats(placement.pose[:3, 3]),
                rotation=quat_xyzw(placement.pose[:3, :3]),
                extras={EXTRAS_KEY: {"placement": k}}))
        attach = None
        body = part.name in bodies
        if body:
            b.gltf.nodes[node].extensions = {KHR_PHYSICS: {
                "motion": physics.motion(bodies[part.name])}}
        for k, piece in enumerate(part.collision):
            children.append(add_collider(part, k, piece))
        if body:
            attach = b.node(f"{joint.name}_attach_child",
                            rotation=quat_xyzw(physics.attachment_rotation(joint)),
                            extras={EXTRAS_KEY: {"attachment": joint.name}})
            children.append(attach)
        for child_joint in tree.children[part.name]:
            children.append(add_joint(child_joint))
        return node, attach

    def asset_mesh(asset: Mesh, mat: int) -> int:
        """The glTF mesh of a placed asset in material ``mat``: one per pair, every one
        reading the asset's one copy of vertex data (accessors are shared by content)."""
        key = (id(asset), mat)
        if key not in asset_meshes:
            if id(asset) not in encoded:
                encoded[id(asset)] = encode_visual(asset)
            name = f"mesh_{list(encoded).index(id(asset))}"
            asset_meshes[key] = b.mesh(name, encoded[id(asset)], mat)
        return asset_meshes[key]

    def add_collider(part: Part, k: int, piece: Mesh) -> int:
        name = f"{part.name}_collision_{k}"
        mesh = b.mesh(name, encode_collision(piece), None)
        extras = {"collision": k}
        if piece.primitive is not None:
            extras["shape"] = shape_json(piece.primitive)
        box = physics.as_box(piece)
        if box is None:
            geometry = b.node(f"{name}_geometry", mesh=mesh)
            return b.node(name, extras={EXTRAS_KEY: extras}, extensions={KHR_PHYSICS: {
                "collider": {"geometry": {"node": geometry, "convexHull": True}}}})
        # a box: an implicit shape, so no mesh node for viewers to show; our extras keep the
        # piece's own vertices (a mesh no node uses) for a lossless read
        size, pose = box
        shapes.append({"type": "box", "box": {"size": size}})
        extras["mesh"] = mesh
        return b.node(name, translation=_floats(pose[:3, 3]), rotation=quat_xyzw(pose[:3, :3]),
                      extras={EXTRAS_KEY: extras},
                      extensions={KHR_PHYSICS: {"collider": {"geometry": {
                          "shape": len(shapes) - 1}}}})

    def add_joint(joint: Joint) -> int:
        node = b.node(joint.name, translation=_floats(joint.origin[:3, 3]),
                      rotation=quat_xyzw(joint.origin[:3, :3]), extras=_joint_extras(joint))
        child = tree.parts[joint.child]
        attach = joint_index = None
        # A floating part is a free body: a rigid body no physics joint holds.
        if child.name in bodies and joint.type is not JointType.FLOATING:
            attach = b.node(f"{joint.name}_attach_parent",
                            rotation=quat_xyzw(physics.attachment_rotation(joint)),
                            extras={EXTRAS_KEY: {"attachment": joint.name}})
            b.gltf.nodes[node].children.append(attach)
            joint_index = len(physics_joints)
            physics_joints.append(physics.joint_description(joint))
        child_node, connected = add_part(child, joint)
        b.gltf.nodes[node].children.append(child_node)
        if attach is not None:
            b.gltf.nodes[attach].extensions = {KHR_PHYSICS: {"joint": {
                "connectedNode": connected, "joint": joint_index}}}
        if joint.type.movable:
            animated.append((joint, child_node))
        return node

    root = b.node(obj.name, rotation=list(ROOT_ROTATION_XYZW), extras={EXTRAS_KEY: {
        "schema": SCHEMA, "schema_version": SCHEMA_VERSION, "object": obj.name,
        # metadata as JSON text: pygltflib drops empty values from extras, which would lose them
        "metadata_json": metadata_json(obj)}})
    b.gltf.nodes[root].children.append(add_part(obj.root, None)[0])
    _animations(b, obj, animated)
    b.gltf.scenes.append(g.Scene(name=obj.name, nodes=[root]))
    b.gltf.scene = 0
    uses_physics = physics_joints or any(n.extensions for n in b.gltf.nodes)
    if physics_joints:
        b.gltf.extensions = {KHR_PHYSICS: {"physicsJoints": physics_joints}}
    if shapes:
        b.gltf.extensions = {**(b.gltf.extensions or {}), KHR_SHAPES: {"shapes": shapes}}
    if uses_physics:  # used, not required: viewers may ignore them
        b.gltf.extensionsUsed = [KHR_PHYSICS] + ([KHR_SHAPES] if shapes else [])
    return b.glb()


def save(obj: ArticulatedObject, out_dir: str | Path, *, write_meshes: bool = True) -> Path:
    """Write ``out_dir/<name>.glb`` (and, if ``write_meshes``, the shared mesh files)."""
    validate(obj)
    driven = [j.name for j in obj.joints if j.drive is not None]
    if driven:  # KHR_physics_rigid_bodies' joint drives hold the joints' damping
        warn(f"glTF: {obj.name!r}: joint drives (actuators) kept in the joints' extras only, "
             f"read by our reader: {', '.join(driven)}")
    out_dir = Path(out_dir)
    if write_meshes:
        write_object_meshes(obj, out_dir)
    return atomic.write_bytes(output_file("gltf", out_dir, obj.name), build(obj))
