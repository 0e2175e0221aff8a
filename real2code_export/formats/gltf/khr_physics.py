"""Read a glTF without our extras from its KHR_physics_rigid_bodies description.

Bodies are the ``motion`` nodes plus the static world (nodes under no motion), which is the
root part. A joint between two bodies becomes a model joint when it leaves exactly one
degree of freedom (see ``physics.free_axis``); the kinematic tree is grown from the root
along the joints. A child part's frame has its body node's orientation and sits at the
child attachment point, so the joint axis passes through the part origin as the model
requires: with child attachment B (pose T_CB in body node C) and parent attachment A,

    part frame F = W_C [I, t_CB],   origin = F_parent^-1 W_A [R_CB^T, 0],   axis = R_CB e_i

and the joint value is the twist (or slide) of B relative to A about (along) e_i.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from ... import transforms as tf
from ...errors import FormatError, warn
from ...model import (
    ArticulatedObject,
    Inertial,
    Joint,
    JointType,
    Limits,
    Mesh,
    Part,
    sanitize_name,
)
from .conventions import KHR_PHYSICS, KHR_SHAPES, khr, node_matrix, rotation_from_xyzw
from .document import Document, rigid
from .physics import FreeAxis, box_mesh, drive_dynamics, free_axis

WORLD = -1  # the static world body


def _implicit_shape(doc: Document, index, el: str) -> Mesh:
    """A KHR_implicit_shapes shape, tessellated (shapes are Y-aligned, centred)."""
    import trimesh

    shapes = khr(doc.gltf.extensions, KHR_SHAPES).get("shapes", [])
    if not isinstance(index, int) or not 0 <= index < len(shapes):
        raise FormatError(doc.path, el, f"collider shape {index!r} does not exist")
    shape = shapes[index]
    kind = shape.get("type")
    params = shape.get(kind, {}) if isinstance(kind, str) else {}
    if kind == "box":
        return box_mesh(params.get("size", [1.0, 1.0, 1.0]), np.eye(4))
    elif kind == "sphere":
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=params.get("radius", 0.5))
    elif kind in ("cylinder", "capsule"):
        h = float(params.get("height", 0.5))
        top, bottom = float(params.get("radiusTop", 0.25)), float(params.get("radiusBottom", 0.25))
        ring = np.linspace(0, 2 * np.pi, 24, endpoint=False)
        circle = np.stack([np.cos(ring), np.zeros_like(ring), np.sin(ring)], axis=1)
        points = [circle * top + [0, h / 2, 0], circle * bottom - [0, h / 2, 0]]
        if kind == "capsule":  # hull of the two end spheres
            ball = trimesh.creation.icosphere(subdivisions=1).vertices
            points = [ball * top + [0, h / 2, 0], ball * bottom - [0, h / 2, 0]]
        mesh = trimesh.Trimesh(np.concatenate(points)).convex_hull
    else:
        raise FormatError(doc.path, el, f"unsupported collider shape type {kind!r}")
    return Mesh.from_trimesh(mesh)


def _collider(doc: Document, i: int) -> tuple[Mesh, np.ndarray] | None:
    """A collider node's geometry and the world transform of that geometry."""
    geometry = khr(doc.nodes[i].extensions).get("collider", {}).get("geometry", {})
    el = doc.element(i)
    if "shape" in geometry:
        return _implicit_shape(doc, geometry["shape"], el), doc.world(i)
    g = geometry.get("node")
    if not isinstance(g, int) or not 0 <= g < len(doc.nodes) or doc.nodes[g].mesh is None:
        warn(f"{doc.path}: {el}: collider geometry without a mesh node; skipped")
        return None
    # a geometry node outside the scene is expressed in the collider node's frame
    frame = doc.world(g) if g in doc.in_scene else doc.world(i) @ node_matrix(doc.nodes[g])
    return doc.mesh(doc.nodes[g].mesh, doc.element(g)), frame


def _twist(rel: np.ndarray, axis: FreeAxis) -> float:
    i = axis.axis
    if axis.kind == "linear":
        return float(rel[i, 3])
    j, k = (i + 1) % 3, (i + 2) % 3
    r = rel[:3, :3]
    return math.atan2(r[k, j] - r[j, k], r[j, j] + r[k, k])


def load_khr(doc: Document) -> ArticulatedObject:
    nodes = doc.nodes

    def body_of(i: int) -> int:
        j: int | None = i
        while j is not None:
            if "motion" in khr(nodes[j].extensions):
                return j
            j = doc.parent[j]
        return WORLD

    bodies = [WORLD] + [i for i in doc.scene_order if "motion" in khr(nodes[i].extensions)]
    descriptions = khr(doc.gltf.extensions).get("physicsJoints", [])
    edges: dict[int, list[tuple[int, int, int, dict]]] = {b: [] for b in bodies}
    for i in doc.scene_order:
        jd = khr(nodes[i].extensions).get("joint")
        if jd is None:
            continue
        el = doc.element(i)
        b_node, d_index = jd.get("connectedNode"), jd.get("joint")
        if not isinstance(b_node, int) or b_node not in doc.in_scene:
            raise FormatError(doc.path, el, f"joint connectedNode {b_node!r} is not a scene node")
        if not isinstance(d_index, int) or not 0 <= d_index < len(descriptions):
            raise FormatError(doc.path, el, f"joint description {d_index!r} does not exist")
        ba, bb = body_of(i), body_of(b_node)
        if ba == bb:
            warn(f"{doc.path}: {el}: joint connects a body to itself; skipped")
            continue
        edges[ba].append((bb, i, b_node, descriptions[d_index]))
        edges[bb].append((ba, b_node, i, descriptions[d_index]))  # seen from the other side

    world_meshes = [i for i in doc.scene_order if body_of(i) == WORLD and nodes[i].mesh is not None]
    root = WORLD if edges[WORLD] or world_meshes or len(bodies) == 1 else bodies[1]
    if root != WORLD:  # nothing in the static world: the first body is the fixed root
        bodies.remove(WORLD)
    taken: set[str] = set()
    names = {b: sanitize_name(nodes[b].name or f"body_{b}", taken) for b in bodies if b != WORLD}
    if WORLD in bodies:  # named after its first mesh node (our root part), else the file
        names[WORLD] = sanitize_name(nodes[world_meshes[0]].name if world_meshes and
                                     nodes[world_meshes[0]].name else doc.path.stem, taken)
    frames = {root: np.eye(4)}
    joints: list[Joint] = []
    queue = deque([root])
    while queue:  # grow the tree from the root along the joints, parents first
        parent = queue.popleft()
        for child, a_node, b_node, desc in edges[parent]:
            if child in frames:
                continue
            joint = _joint(doc, desc, parent, child, a_node, b_node, frames, names, taken)
            joints.append(joint)
            queue.append(child)
    for b in bodies:
        if b not in frames:
            warn(f"{doc.path}: body {names[b]!r} is connected to nothing; fixed to {names[root]!r}")
            frames[b] = rigid(doc.world(b))
            joints.append(Joint(name=sanitize_name(f"{names[b]}_fixed", taken), type=JointType.FIXED,
                                parent=names[root], child=names[b], origin=frames[b]))
    parts = [_body_part(doc, b, names[b], frames[b], [i for i in doc.scene_order if body_of(i) == b])
             for b in bodies]
    warn(f"{doc.path}: no real2code metadata; {len(parts)} part(s) and {len(joints)} joint(s) "
         f"read from {KHR_PHYSICS}")
    return ArticulatedObject(name=sanitize_name(doc.path.stem), parts=parts, joints=joints,
                             metadata={"source": str(doc.path)})


def _joint(doc: Document, desc: dict, parent: int, child: int, a_node: int, b_node: int,
           frames: dict, names: dict, taken: set[str]) -> Joint:
    """The model joint from the parent attachment ``a_node`` to the child's ``b_node``
    (``frames[child]`` is set here)."""
    el = doc.element(a_node)
    is_owner = "joint" in khr(doc.nodes[a_node].extensions)
    sign = 1.0 if is_owner else -1.0  # read from the connected side: the motion is inverted
    axis = free_axis(desc)
    name = sanitize_name(desc.get("name") or doc.nodes[a_node if is_owner else b_node].name
                         or "joint", taken)
    w_a, w_b = doc.world(a_node), doc.world(b_node)
    w_c = doc.world(child) if child != WORLD else np.eye(4)
    t_cb = rigid(tf.inverse(w_c) @ w_b)
    frames[child] = rigid(w_c) @ tf.make(translation=t_cb[:3, 3])
    origin = tf.inverse(frames[parent]) @ w_a @ tf.make(rotation=t_cb[:3, :3].T)
    origin = tf.make(rotation=tf.orthonormalize(origin[:3, :3]), translation=origin[:3, 3])
    if axis is None or (axis.kind == "linear" and (axis.lower is None or axis.upper is None)):
        warn(f"{doc.path}: {el}: physics joint leaves more than one degree of freedom or an "
             "unbounded slide; read as fixed at its current pose")
        origin = tf.inverse(frames[parent]) @ frames[child]
        return Joint(name=name, type=JointType.FIXED, parent=names[parent], child=names[child],
                     origin=origin)
    if axis.kind == "fixed":
        return Joint(name=name, type=JointType.FIXED, parent=names[parent], child=names[child],
                     origin=origin)
    state = _twist(rigid(tf.inverse(w_a) @ w_b), axis)
    limits = None
    jtype = JointType.PRISMATIC if axis.kind == "linear" else JointType.CONTINUOUS
    if axis.lower is not None and axis.upper is not None:
        lo, hi = (axis.lower, axis.upper) if sign > 0 else (-axis.upper, -axis.lower)
        limits = Limits(lo, hi)
        jtype = JointType.REVOLUTE if axis.kind == "angular" else JointType.PRISMATIC
        if not lo <= state <= hi:
            warn(f"{doc.path}: {el}: joint value {state} outside [{lo}, {hi}]; clamped")
            state = min(max(state, lo), hi)
    dynamics, skipped = drive_dynamics(desc, axis, sign)
    for what in skipped:
        warn(f"{doc.path}: {el}: {what} cannot be represented; ignored")
    return Joint(name=name, type=jtype, parent=names[parent], child=names[child], origin=origin,
                 axis=t_cb[:3, :3][:, axis.axis], limits=limits,
                 dynamics=dynamics, state=state)


def _body_part(doc: Document, body: int, name: str, frame: np.ndarray,
               members: list[int]) -> Part:
    to_part = tf.inverse(frame)
    visuals, collision, color, textures = [], [], None, []
    for i in members:
        node = doc.nodes[i]
        if node.mesh is not None:
            mesh = doc.mesh(node.mesh, doc.element(i), to_part @ doc.world(i))
            if len(mesh.faces):
                visuals.append(mesh)
                color = color or doc.color(node.mesh)
                textures.append(doc.images(node.mesh))
        if "collider" in khr(node.extensions):
            found = _collider(doc, i)
            if found is not None:
                mesh, world = found
                collision.append(mesh.transformed(to_part @ world))
    inertial = None
    motion = khr(doc.nodes[body].extensions).get("motion") if body != WORLD else None
    if motion is not None:
        body_to_part = to_part @ rigid(doc.world(body))
        if "mass" not in motion:
            warn(f"{doc.path}: {doc.element(body)}: motion without mass; 1 kg assumed")
        rot = rotation_from_xyzw(motion.get("inertiaOrientation", [0, 0, 0, 1]))
        inertia = rot @ np.diag(motion.get("inertiaDiagonal", [1e-3, 1e-3, 1e-3])) @ rot.T
        r = body_to_part[:3, :3]
        com = r @ np.asarray(motion.get("centerOfMass", [0, 0, 0]), float) \
            + body_to_part[:3, 3]
        inertial = Inertial(mass=float(motion.get("mass", 1.0)), com=com, inertia=r @ inertia @ r.T)
    visual = Mesh.concatenate(visuals) if visuals else None
    images = _body_images(doc, textures, visual,
                          doc.element(body) if body != WORLD else "the static world")
    return Part(name=name, visual=visual, collision=collision, inertial=inertial,
                color=color or (0.7, 0.7, 0.7, 1.0), texture=images.pop("texture", None),
                maps=images)


def _body_images(doc: Document, per_mesh: list[dict], visual: Mesh | None, el: str) -> dict:
    """The images (base colour and maps) a body's meshes share. A part holds one material, so
    a body whose meshes carry different images, or some none, keeps none, and says so."""
    if not any(per_mesh):
        return {}
    keys = [{role: t.image for role, t in images.items()} for images in per_mesh]
    if any(k != keys[0] for k in keys) or visual is None or visual.uv is None:
        warn(f"{doc.path}: {el}: its meshes do not share one material's images with "
             "TEXCOORD_0 on every primitive; a part holds one, so the images are not kept")
        return {}
    return dict(per_mesh[0])
