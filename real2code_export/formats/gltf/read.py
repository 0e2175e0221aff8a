"""Read a .glb/.gltf into the model.

- Ours (a root node with real2code extras): lossless from the extras; meshes from the
  binary data (float32 vertices).
- Without our extras but with KHR_physics_rigid_bodies joints: one part per rigid body
  (``motion`` node; the static world is the root), joints from the physics joints
  (see ``khr_physics.py``).
- Anything else: one part per mesh node, joined by fixed joints along the node tree (a
  single mesh node gives a single part); warned, since no joint can be recovered.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ... import transforms as tf
from ...errors import FormatError, ModelError, warn
from ...model import (
    WHITE,
    ArticulatedObject,
    DriveLimits,
    Dynamics,
    Inertial,
    Joint,
    JointType,
    Limits,
    Mesh,
    Part,
    sanitize_name,
    validate,
)
from ...model_json import drive_from_json, mimic_from_json, shape_from_json
from .conventions import KHR_PHYSICS, SCHEMA, SCHEMA_VERSION, khr, node_matrix, ours
from .document import Document, rigid
from .khr_physics import load_khr


def load(path: str | Path) -> ArticulatedObject:
    path = Path(path)
    try:
        return _load(path)
    except (TypeError, ValueError, KeyError, IndexError, AttributeError) as e:
        # a property of the wrong JSON type somewhere the checks above do not look
        raise FormatError(path, None, f"malformed glTF ({type(e).__name__}: {e})") from e


def _load(path: Path) -> ArticulatedObject:
    doc = Document(path)
    root = next((i for i in doc.scene_order if doc.ours(i).get("schema") == SCHEMA), None)
    if root is not None:
        obj = _load_ours(doc, root)
    elif any("joint" in khr(doc.nodes[i].extensions) for i in doc.scene_order):
        obj = load_khr(doc)
    else:
        obj = _load_plain(doc)
    try:
        return validate(obj)
    except ModelError as e:
        raise FormatError(doc.path, e.element, e.message) from e


# -- ours ------------------------------------------------------------------------------------
def _vector(value, n: int, doc: Document, el: str, what: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as e:
        raise FormatError(doc.path, el, f"{what} must be numbers, got {value!r}") from e
    if arr.size != n:
        raise FormatError(doc.path, el, f"{what} must have {n} numbers, got {value!r}")
    return arr.reshape(-1)


def _load_ours(doc: Document, root: int) -> ArticulatedObject:
    info = doc.ours(root)
    if info.get("schema_version") != SCHEMA_VERSION:
        raise FormatError(doc.path, doc.element(root), f"unsupported real2code schema version "
                          f"{info.get('schema_version')!r} (this release reads {SCHEMA_VERSION})")
    try:
        metadata = json.loads(info.get("metadata_json", "{}"))
    except (TypeError, json.JSONDecodeError) as e:
        raise FormatError(doc.path, doc.element(root), f"bad metadata_json: {e}") from e
    part_nodes: dict[str, int] = {}
    joint_nodes: list[int] = []
    for i in doc.scene_order:
        data = doc.ours(i)
        if "part" in data:
            if data["part"] in part_nodes:
                raise FormatError(doc.path, doc.element(i), f"second node for part {data['part']!r}")
            part_nodes[data["part"]] = i
        elif "joint" in data and "type" in data:
            joint_nodes.append(i)
    assets: dict[tuple, Mesh] = {}  # placed mesh data -> its one asset (every part's)
    parts = [_our_part(doc, name, i, assets) for name, i in part_nodes.items()]
    joints = [_our_joint(doc, i, part_nodes) for i in joint_nodes]
    return ArticulatedObject(name=str(info.get("object")), parts=parts, joints=joints,
                             metadata=metadata if isinstance(metadata, dict) else {})


def _our_part(doc: Document, name: str, i: int, assets: dict[tuple, Mesh]) -> Part:
    el = doc.element(i)
    data = doc.ours(i)
    node = doc.nodes[i]
    visual = doc.mesh(node.mesh, el) if node.mesh is not None \
        else _placed_visual(doc, i, name, assets)
    shapes = data.get("visual_shapes", [])
    if visual is not None and isinstance(shapes, list) and shapes:
        visual = _with_shapes(visual, [shape_from_json(d, doc.path, f"{el} visual_shapes"
                                                             f"[{k}]") for k, d in enumerate(shapes)])
    pieces: dict[int, tuple[int, str]] = {}  # k -> (glTF mesh, its element)
    shapes_of: dict[int, object] = {}  # collision piece -> its shape (extras)
    for c in node.children or []:
        k = doc.ours(c).get("collision")
        if k is None:
            continue
        if not isinstance(k, int) or k in pieces:
            raise FormatError(doc.path, doc.element(c), f"collision piece {k!r} of part "
                              f"{name!r} is not a new piece number")
        pieces[k] = _collision_mesh(doc, c, name)
        if doc.ours(c).get("shape") is not None:
            shapes_of[k] = doc.ours(c)["shape"]
    if sorted(pieces) != list(range(len(pieces))):
        raise FormatError(doc.path, el, f"collision pieces {sorted(pieces)} are not numbered 0..n-1")
    collision = [doc.mesh(*pieces[k]) for k in range(len(pieces))]
    for k, c in enumerate(collision):
        shape = shapes_of.get(k)
        if shape is not None:
            collision[k] = _with_shapes(c, [shape_from_json(shape, doc.path, el)])
    inertial = None
    if "inertial" in data:
        ind = data["inertial"]
        if not isinstance(ind, dict) or "mass" not in ind:
            raise FormatError(doc.path, el, "inertial must hold mass, com and inertia")
        inertial = Inertial(mass=float(ind["mass"]),
                            com=_vector(ind.get("com", [0, 0, 0]), 3, doc, el, "centre of mass"),
                            inertia=_vector(ind.get("inertia"), 9, doc, el, "inertia").reshape(3, 3))
    color = tuple(_vector(data.get("color", [0.7, 0.7, 0.7, 1.0]), 4, doc, el, "colour"))
    return Part(name=name, visual=visual, collision=collision, inertial=inertial, color=color,
                **_part_images(_images(doc, node.mesh, visual, el)))


def _placed_visual(doc: Document, i: int, name: str,
                   assets: dict[tuple, Mesh]) -> Mesh | None:
    """A part node's visual as its placement children (extras ``placement`` k, 0..n-1) each
    place: one mesh asset per glTF vertex data (``assets``, across parts: a glTF mesh per
    material reads the same accessors), at the child's TRS, in the child's material colour;
    None without any."""
    placed: dict[int, int] = {}
    for c in doc.nodes[i].children or []:
        k = doc.ours(c).get("placement")
        if k is None:
            continue
        if not isinstance(k, int) or k in placed or doc.nodes[c].mesh is None:
            raise FormatError(doc.path, doc.element(c), f"placement {k!r} of part {name!r} is "
                              "not a new placement number with a mesh")
        placed[k] = c
    if not placed:
        return None
    if sorted(placed) != list(range(len(placed))):
        raise FormatError(doc.path, doc.element(i), f"placements {sorted(placed)} of part "
                          f"{name!r} are not numbered 0..n-1")
    pieces, colours = [], []
    for k in range(len(placed)):
        c = placed[k]
        node = doc.nodes[c]
        primitives = doc.gltf.meshes[node.mesh].primitives or [] \
            if 0 <= node.mesh < len(doc.gltf.meshes or []) else []
        key = tuple((p.attributes.POSITION, p.indices, ours(p.extras).get("source_vertex"),
                     getattr(p.attributes, "TEXCOORD_0", None)) for p in primitives)
        if key not in assets:
            read = doc.mesh(node.mesh, doc.element(c))
            assets[key] = Mesh(read.vertices, read.faces, read.uv)
        pose = node_matrix(node)
        if not tf.is_rotation(pose[:3, :3]):
            raise FormatError(doc.path, doc.element(c), "a placement must be rigid (no scale)")
        pieces.append(Mesh.placed(assets[key], pose))
        colours.append(doc.material_color(primitives[0].material) if primitives else None)
    if None in colours or len(set(colours)) < 2:
        return Mesh.concatenate(pieces)
    return Mesh.concatenate(pieces, colours)


def _collision_mesh(doc: Document, c: int, name: str) -> tuple[int, str]:
    """The glTF mesh holding collider node ``c``'s piece: our extras name it for a box (an
    implicit shape in the file), the collider's geometry node holds it otherwise."""
    mesh = doc.ours(c).get("mesh")
    if mesh is not None:
        if not isinstance(mesh, int) or not 0 <= mesh < len(doc.gltf.meshes or []):
            raise FormatError(doc.path, doc.element(c), f"collision piece of part {name!r} "
                              f"names mesh {mesh!r}, which does not exist")
        return mesh, f"meshes[{mesh}]"
    geometry = khr(doc.nodes[c].extensions).get("collider", {}).get("geometry", {})
    g = geometry.get("node")
    if not isinstance(g, int) or not 0 <= g < len(doc.nodes) or doc.nodes[g].mesh is None:
        raise FormatError(doc.path, doc.element(c), f"collision piece of part {name!r} has no "
                          f"{KHR_PHYSICS} collider geometry node with a mesh")
    return doc.nodes[g].mesh, doc.element(g)


def _part_images(images: dict) -> dict:
    """Part's ``texture`` and ``maps`` fields from :func:`_images`."""
    return {"texture": images.pop("texture", None), "maps": images}


def _images(doc: Document, mesh_index: int | None, visual, el: str) -> dict:
    """The mesh's base colour image ("texture") and material maps, where its vertices have
    the coordinates to place them."""
    images = doc.images(mesh_index)
    if images and (visual is None or visual.uv is None):
        warn(f"{doc.path}: {el}: textures ({', '.join(images)}) without TEXCOORD_0 on every "
             "primitive; they are not kept")
        return {}
    return images


def _atlas(doc: Document, mesh_index: int | None, el: str, transform=None):
    """Where the primitives of glTF mesh ``mesh_index`` are drawn by different base colour
    images, or an image beside other colours, them as one mesh with one image
    (:mod:`...texture_atlas`; a part holds one), each image tinted by its material's base
    colour factor, as glTF draws it; else None (one image, or none; or an image without
    TEXCOORD_0, or maps beside the images: warned, as :func:`_images` does)."""
    from ...texture_atlas import AtlasPiece, needs_atlas, pack

    if mesh_index is None:
        return None
    looks = []
    for mesh, k in doc.primitive_meshes(mesh_index, el, transform):
        images = doc.material_images(k)
        if set(images) - {"texture"} or (images and mesh.uv is None):
            return None
        looks.append(AtlasPiece(mesh, images.get("texture"),
                                doc.material_color(k) or (1.0, 1.0, 1.0, 1.0)))
    if not needs_atlas(looks):
        return None
    atlas = pack(looks)
    warn(f"{doc.path}: {el}: the images and colours of its {len(looks)} primitives packed "
         "into one image (a part holds one)"
         + (f": {'; '.join(atlas.notes)}" if atlas.notes else ", every pixel kept"))
    return atlas


def _with_shapes(mesh: Mesh, shapes: list) -> Mesh:
    """The mesh read (float32) with its shapes restored: its own triangles as read, the
    shapes' tessellations exactly (our writer puts them at the end)."""
    own = Mesh(mesh.vertices, mesh.faces, mesh.uv, tuple(shapes)).remainder() \
        if len(mesh.vertices) >= sum(s.counts()[0] for s in shapes) else None
    out = Mesh.concatenate(([own] if own is not None else []) +
                           [Mesh.of_primitive(s) for s in shapes])
    if mesh.colors and len(out.faces) == len(mesh.faces):  # (the faces in the same order)
        out = Mesh(out.vertices, out.faces, out.uv, out.primitives, mesh.colors)
    return out


def _our_joint(doc: Document, i: int, part_nodes: dict[str, int]) -> Joint:
    el = doc.element(i)
    d = doc.ours(i)
    name = d["joint"]
    for role in ("parent", "child"):
        if d.get(role) not in part_nodes:
            raise FormatError(doc.path, el, f"joint {name!r} names {role} part {d.get(role)!r}, "
                                            "which has no node")
    if doc.parent[i] != part_nodes[d["parent"]] or doc.parent[part_nodes[d["child"]]] != i:
        raise FormatError(doc.path, el, f"joint {name!r}: the node tree does not put it between "
                                        f"parts {d['parent']!r} and {d['child']!r}")
    if d.get("type") not in {t.value for t in JointType}:
        raise FormatError(doc.path, el, f"unknown joint type {d.get('type')!r}")
    try:
        origin = tf.make(
            rotation=_vector(d["origin"]["rotation"], 9, doc, el, "origin rotation").reshape(3, 3),
            translation=_vector(d["origin"]["translation"], 3, doc, el, "origin translation"))
        limits = None
        if "limits" in d:
            ld = d["limits"]
            limits = Limits(float(ld["lower"]), float(ld["upper"]),
                            None if ld.get("effort") is None else float(ld["effort"]),
                            None if ld.get("velocity") is None else float(ld["velocity"]))
        drive = d.get("drive_limits")
        drive_limits = None if drive is None else DriveLimits(
            *(None if drive.get(k) is None else float(drive[k]) for k in ("effort", "velocity")))
        dd = d.get("dynamics", {})
        dynamics = Dynamics(**{k: float(dd.get(k, 0.0))
                               for k in ("damping", "friction", "stiffness", "spring_ref", "armature")})
        mimic = None if d.get("mimic") is None else mimic_from_json(d["mimic"], doc.path, el)
        return Joint(name=name, type=JointType(d["type"]), parent=d["parent"], child=d["child"],
                     origin=origin, axis=_vector(d.get("axis", [0, 0, 1]), 3, doc, el, "axis"),
                     limits=limits, dynamics=dynamics, state=float(d.get("state", 0.0)),
                     mimic=mimic, drive_limits=drive_limits,
                     cone_limit=None if d.get("cone_limit") is None else float(d["cone_limit"]),
                     drive=None if d.get("drive") is None
                     else drive_from_json(d["drive"], doc.path, el))
    except (KeyError, TypeError, ValueError, AttributeError) as e:
        raise FormatError(doc.path, el, f"bad joint metadata ({type(e).__name__}: {e})") from e


# -- plain glTF ------------------------------------------------------------------------------
def _load_plain(doc: Document) -> ArticulatedObject:
    mesh_nodes = [i for i in doc.scene_order if doc.nodes[i].mesh is not None]
    if not mesh_nodes:
        raise FormatError(doc.path, "scene", "has no mesh nodes")
    taken: set[str] = set()
    stem = sanitize_name(doc.path.stem)

    def parent_mesh_node(i: int) -> int | None:
        j = doc.parent[i]
        while j is not None and doc.nodes[j].mesh is None:
            j = doc.parent[j]
        return j

    top = [i for i in mesh_nodes if parent_mesh_node(i) is None]
    frames: dict[int | None, np.ndarray] = {}
    names: dict[int | None, str] = {}
    parts: list[Part] = []
    if len(top) == 1:
        root: int | None = top[0]
    else:  # several top-level meshes hang from one empty root part
        root = None
        names[None] = sanitize_name(stem, taken)
        frames[None] = np.eye(4)
        parts.append(Part(name=names[None]))
    joints = []
    for i in mesh_nodes:
        node = doc.nodes[i]
        names[i] = sanitize_name(node.name or f"node_{i}", taken)
        world = doc.world(i)
        frames[i] = np.eye(4) if i == root else rigid(world)
        mesh = doc.mesh(node.mesh, doc.element(i), tf.inverse(frames[i]) @ world)
        visual = mesh if len(mesh.faces) else None
        color = doc.color(node.mesh) or (0.7, 0.7, 0.7, 1.0)
        atlas = _atlas(doc, node.mesh, doc.element(i), tf.inverse(frames[i]) @ world) \
            if visual is not None else None
        if atlas is not None:
            visual, color, images = atlas.mesh, WHITE, {"texture": atlas.texture}
        else:
            images = _images(doc, node.mesh, visual, doc.element(i))
        parts.append(Part(name=names[i], visual=visual, color=color, **_part_images(images)))
        if i != root:
            parent = parent_mesh_node(i)
            joints.append(Joint(name=sanitize_name(f"{names[i]}_fixed", taken), type=JointType.FIXED,
                                parent=names[parent], child=names[i],
                                origin=tf.inverse(frames[parent]) @ frames[i]))
    warn(f"{doc.path}: no joint metadata (real2code extras or {KHR_PHYSICS} joints): "
         f"{len(mesh_nodes)} mesh node(s) read as {len(parts)} part(s) joined by fixed joints")
    return ArticulatedObject(name=stem, parts=parts, joints=joints,
                             metadata={"source": str(doc.path)})
