"""ArticulatedObject -> URDF text, deterministic and lossless for our own reader.

Each link has its <inertial> (origin at the centre of mass, tensor in link axes), one
<visual> (meshes/<part>.obj with a named material) and one <collision> per convex piece
(meshes/<part>_collision_<k>.obj, marked ``real2code:convex="true"`` so our reader keeps them
as they are); a shape is a <visual>/<collision> of its own (<box>, <cylinder>, <sphere>; a
capsule or ellipsoid, which URDF lacks, its tessellation's mesh marked ``real2code:shape``). Numbers are Python's shortest exact text. What URDF cannot hold goes into
attributes of the ``real2code`` namespace (see :mod:`.conventions`); a <mujoco> block makes MuJoCo
load every link as its own body, with its visual.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from lxml import etree

from ... import atomic
from ... import transforms as tf
from ...errors import ModelError, warn
from ...meshfiles import (
    MESH_DIR,
    MeshLayout,
    obj_bytes,
    warn_maps_not_referenced,
    write_object_meshes,
)
from ...model import (
    UNBOUNDED_LIMIT,
    ArticulatedObject,
    Drive,
    Joint,
    JointType,
    Limits,
    Mesh,
    Part,
    metadata_json,
    sanitize_name,
    validate,
)
from ...primitives import Primitive, ShapeKind
from .. import output_file
from .conventions import (
    ADDED,
    DEFAULT_EFFORT,
    DEFAULT_VELOCITY,
    ELEMENTS_KEY,
    KEPT,
    KEPT_IN,
    NAMESPACE,
    PREFIX,
    UNKNOWN,
    URDFDOM_REQUIRES,
    WORLD_LINK,
    ns,
    number,
    numbers,
)
from .structure import READ_TAGS

URDF_SHAPES = (ShapeKind.BOX, ShapeKind.CYLINDER, ShapeKind.SPHERE)  # URDF 1.0's elements

# MuJoCo's URDF defaults differ from MJCF's (docs: "URDF extensions"): it fuses links joined
# by fixed joints into their parent (we want one body per part, as in the other formats) and
# discards visuals. strippath defaults to false since MuJoCo 3.7 but is set for older ones;
# angle is always radian for URDF, stated for the reader.
MUJOCO_COMPILER = (("angle", "radian"), ("discardvisual", "false"), ("fusestatic", "false"),
                   ("strippath", "false"))


def save(obj: ArticulatedObject, out_dir: str | Path, *, write_meshes: bool = True) -> Path:
    """Write ``out_dir/<obj.name>.urdf`` (and, if ``write_meshes``, the mesh files)."""
    validate(obj)
    warn_maps_not_referenced(obj, "URDF")
    driven = [j.name for j in obj.joints if j.drive is not None]
    if driven:
        warn(f"URDF: {obj.name!r}: joint drives (actuators) have no place in URDF (a "
             "<transmission> holds no gains): kept as <real2code:drive> in their <joint>, "
             f"read by our reader only: {', '.join(driven)}")
    out_dir = Path(out_dir)
    text = to_bytes(obj)
    if write_meshes:
        write_object_meshes(obj, out_dir)
    for relpath, mesh in shape_mesh_files(obj).items():
        (out_dir / relpath).parent.mkdir(parents=True, exist_ok=True)
        atomic.write_bytes(out_dir / relpath, obj_bytes(mesh))
    return atomic.write_bytes(output_file("urdf", out_dir, obj.name), text)


def to_bytes(obj: ArticulatedObject) -> bytes:
    robot = etree.Element("robot", nsmap={PREFIX: NAMESPACE})
    robot.set("name", obj.name)
    elements, nested = _placed_in_elements(obj, _kept_elements(obj))
    metadata = {k: v for k, v in obj.metadata.items() if k != ELEMENTS_KEY}
    if metadata:
        robot.set(ns("metadata"), json.dumps(metadata, sort_keys=True, allow_nan=False))
    compiler = etree.SubElement(etree.SubElement(robot, "mujoco"), "compiler")
    for key, value in MUJOCO_COMPILER:
        compiler.set(key, value)
    layout = MeshLayout(obj)  # an asset placed several times: one file, at each origin
    shared = layout.shared_files()  # equal meshes: one file, read and compiled once
    for part in obj.parts:
        link = _link(part, layout, shared)
        link.extend(nested.get(("link", part.name), []))
        robot.append(link)
    as_meshes = shape_mesh_files(obj)
    if as_meshes:
        kinds = sorted({m.primitives[0].kind.value for m in as_meshes.values()})
        warn(f"URDF: {obj.name!r}: URDF has no {' or '.join(kinds)}: {len(as_meshes)} shape(s) "
             f"written as their tessellation's mesh ({MESH_DIR}/<part>_<visual|collision>_<k>"
             f"_shape.obj), marked {PREFIX}:shape for our reader")
    world = world_link(obj)
    if world is not None:
        link, fixed = world
        robot.append(link)
        robot.append(fixed)
    for joint in obj.joints:
        el = _joint(joint)
        if world is not None and joint.type is JointType.FLOATING:
            el.find("parent").set("link", WORLD_LINK)
        el.extend(nested.get(("joint", joint.name), []))
        robot.append(el)
    robot.extend(elements)
    return etree.tostring(robot, xml_declaration=True, encoding="UTF-8", pretty_print=True)


def world_link(obj: ArticulatedObject) -> tuple[etree._Element, etree._Element] | None:
    """A link ``world`` and a fixed joint from it to the root part, for an object whose free
    bodies (floating joints) hang from a root part of another name (a USD scene: a body the
    world holds, and bodies no joint holds). MuJoCo's URDF import takes a link named
    ``world`` as its world body and allows a floating (free) joint only from it ("free joint
    can only be used on top level"); Pinocchio makes each a free flyer either way. The free
    bodies hang from ``world`` at the same origins (the root part stands at the world's
    origin); both elements are marked ``real2code:added`` and our reader takes them out
    again (None: the object needs neither)."""
    root = obj.root.name
    if root == WORLD_LINK or not any(j.type is JointType.FLOATING for j in obj.joints):
        return None
    if any(p.name == WORLD_LINK for p in obj.parts):
        raise ModelError(f"part {WORLD_LINK!r}", f"URDF: the free bodies of {obj.name!r} hang "
                         f"from its root part {root!r}, which MuJoCo's URDF import allows only "
                         f"from a link named {WORLD_LINK!r}: that name is another part's")
    link = etree.Element("link")
    link.set("name", WORLD_LINK)
    link.set(ns(ADDED), "true")
    joint = etree.Element("joint")
    joint.set("name", sanitize_name(f"{WORLD_LINK}_to_{root}", {j.name for j in obj.joints}))
    joint.set("type", JointType.FIXED.value)
    joint.set(ns(ADDED), "true")
    _sub(joint, "origin", ("xyz", numbers((0.0, 0.0, 0.0))), ("rpy", numbers((0.0, 0.0, 0.0))))
    _sub(joint, "parent", ("link", WORLD_LINK))
    _sub(joint, "child", ("link", root))
    return link, joint


def _kept_elements(obj: ArticulatedObject) -> list[etree._Element]:
    """The URDF elements a reader kept in the metadata (conventions.ELEMENTS_KEY), parsed again."""
    metadata_json(obj)  # the same error as every format for metadata that is not JSON
    texts = obj.metadata.get(ELEMENTS_KEY, [])
    where = f"object {obj.name!r} metadata {ELEMENTS_KEY!r}"
    if not isinstance(texts, list) or not all(isinstance(t, str) for t in texts):
        raise ModelError(where, "must be a list of XML texts")
    out = []
    for k, text in enumerate(texts):
        try:
            el = etree.fromstring(text)
        except etree.XMLSyntaxError as e:
            raise ModelError(f"{where}[{k}]", f"not XML: {e}") from e
        if el.tag in READ_TAGS:  # those are the model's own: never written twice
            raise ModelError(f"{where}[{k}]", f"<{el.tag}> is the model's to write")
        out.append(el)
    return out


def _placed_in_elements(obj: ArticulatedObject, elements: list[etree._Element]
                        ) -> tuple[list[etree._Element], dict[tuple[str, str], list]]:
    """The kept elements for <robot>, and those a reader found in a <link> or <joint>
    (wrapped in <real2code:in>, ``conventions.KEPT_IN``) by (tag, name) of the element they
    go back into; a wrapper naming an element the object no longer has, or holding one
    urdfdom would refuse (``conventions.URDFDOM_REQUIRES``), stays as it is."""
    names = {"link": {p.name for p in obj.parts}, "joint": {j.name for j in obj.joints}}
    top, nested = [], {}
    for el in elements:
        owner = next(((tag, el.get(tag)) for tag in names if el.get(tag) in names[tag]), None) \
            if el.tag == f"{{{NAMESPACE}}}{KEPT_IN}" else None
        refused = any(child.get(attr) is None for child in el
                      for attr in URDFDOM_REQUIRES.get(child.tag, ()))
        if owner is None or refused:
            top.append(el)
            continue
        for child in el:
            child.set(ns(KEPT), "true")  # (our reader keeps it again without a warning)
            nested.setdefault(owner, []).append(child)
    return top, nested


def _sub(parent: etree._Element, tag: str, *attrs: tuple[str, str]) -> etree._Element:
    el = etree.SubElement(parent, tag)
    for key, value in attrs:
        el.set(key, value)
    return el


def _mesh_geometry(parent: etree._Element, filename: str) -> etree._Element:
    return _sub(_sub(parent, "geometry"), "mesh", ("filename", filename))


def _origin(parent: etree._Element, transform: np.ndarray) -> None:
    _sub(parent, "origin", ("xyz", numbers(transform[:3, 3])),
         ("rpy", numbers(stable_rpy(transform[:3, :3]))))


def _shape_geometry(parent: etree._Element, part: Part, shape: Primitive, relpath: str) -> None:
    """URDF's own element for a box, cylinder or sphere; a shape URDF has no element for
    (capsule, ellipsoid) is its tessellation's mesh file, marked for our reader (warned)."""
    _origin(parent, shape.pose)
    s = shape.size
    if shape.kind is ShapeKind.BOX:
        _sub(_sub(parent, "geometry"), "box", ("size", numbers(s)))
    elif shape.kind is ShapeKind.SPHERE:
        _sub(_sub(parent, "geometry"), "sphere", ("radius", number(s[0])))
    elif shape.kind is ShapeKind.CYLINDER:
        _sub(_sub(parent, "geometry"), "cylinder", ("radius", number(s[0])),
             ("length", number(s[1])))
    else:  # (said once per object by to_bytes)
        mesh = _mesh_geometry(parent, relpath)
        mesh.set(ns("shape"), shape.kind.value)
        mesh.set(ns("size"), numbers(s))


def shape_mesh_files(obj: ArticulatedObject) -> dict[str, Mesh]:
    """The mesh files of the shapes URDF has no element for (relpath -> tessellation in the
    shape's own frame): the URDF writes them itself, no other format needs them."""
    out = {}
    for part in obj.parts:
        for relpath, shape in _mesh_shapes(part):
            out[relpath] = Mesh(*Primitive(shape.kind, shape.size).tessellation(),
                                primitives=(Primitive(shape.kind, shape.size),))
    return out



def _mesh_shapes(part: Part) -> list[tuple[str, Primitive]]:
    visual = part.visual.primitives if part.visual is not None else ()
    items = [(shape_relpath(part.name, "visual", k), s) for k, s in enumerate(visual)]
    items += [(shape_relpath(part.name, "collision", k), m.primitive)
              for k, m in enumerate(part.collision) if m.primitive is not None]
    return [(rel, s) for rel, s in items if s.kind not in URDF_SHAPES]


def shape_relpath(part_name: str, role: str, k: int) -> str:
    return f"{MESH_DIR}/{part_name}_{role}_{k}_shape.obj"


def _link(part: Part, layout: MeshLayout, shared: dict[str, str]) -> etree._Element:
    link = etree.Element("link")
    link.set("name", part.name)
    # A part with a visual but deliberately no inertial or no collision: say so, or our reader
    # would make them from the visual as it does for other people's files.
    if part.visual is not None and part.inertial is None:
        link.set(ns("inertial"), UNKNOWN)
    if part.visual is not None and not part.collision:
        link.set(ns("collision"), UNKNOWN)
    if part.color_not_first_run:  # (the reader gives a part of several colours the first)
        link.set(ns("color"), numbers(part.color))
    if part.inertial is not None:
        i = part.inertial.inertia
        el = _sub(link, "inertial")
        _sub(el, "origin", ("xyz", numbers(part.inertial.com)), ("rpy", numbers((0.0, 0.0, 0.0))))
        _sub(el, "mass", ("value", number(part.inertial.mass)))
        _sub(el, "inertia", *((k, number(v)) for k, v in (
            ("ixx", i[0, 0]), ("ixy", i[0, 1]), ("ixz", i[0, 2]),
            ("iyy", i[1, 1]), ("iyz", i[1, 2]), ("izz", i[2, 2]))))
    # (element, colour): a visual of several colours or placed meshes is one <visual> per
    # colour or placement
    visuals = []
    for g in layout.visuals[part.name]:
        visuals.append((el := _sub(link, "visual", ("name", g.name)), g.rgba))
        if g.pose is not None:
            _origin(el, g.pose)
        _mesh_geometry(el, shared[g.relpath])
    shapes = part.visual.primitives if part.visual is not None else ()
    for k, (shape, colour) in enumerate(zip(shapes, part.visual.shape_colors() if shapes
                                            else (), strict=True)):
        visuals.append((el := _sub(link, "visual", ("name", f"{part.name}_visual_{k}")),
                        part.color if colour is None else colour))
        _shape_geometry(el, part, shape, shape_relpath(part.name, "visual", k))
    colours = list(dict.fromkeys(colour for _, colour in visuals))
    for el, colour in visuals:  # one named material per colour
        k = colours.index(colour)
        material = _sub(el, "material", ("name", f"{part.name}_material"
                                         + (f"_{k}" if k else "")))
        _sub(material, "color", ("rgba", numbers(colour)))
    meshes = dict(layout.collisions[part.name])
    for k, piece in enumerate(part.collision):
        el = _sub(link, "collision", ("name", f"{part.name}_collision_{k}"), (ns("convex"), "true"))
        if piece.primitive is not None:
            _shape_geometry(el, part, piece.primitive, shape_relpath(part.name, "collision", k))
        else:
            if meshes[k].pose is not None:
                _origin(el, meshes[k].pose)
            _mesh_geometry(el, shared[meshes[k].relpath])
    return link


def _joint(joint: Joint) -> etree._Element:
    el = etree.Element("joint")
    el.set("name", joint.name)
    el.set("type", joint.type.value)
    if joint.type is JointType.BALL:
        warn(f"URDF: joint {joint.name!r}: URDF has no ball joint; written as fixed at its "
             f"reference pose, marked {PREFIX}:type=\"ball\" for our reader"
             + ("" if joint.cone_limit is None else
                f" (its cone limit in {PREFIX}:cone_limit)"))
        el.set("type", JointType.FIXED.value)
        el.set(ns("type"), joint.type.value)
        if joint.cone_limit is not None:
            el.set(ns("cone_limit"), number(joint.cone_limit))
    if joint.type.movable and joint.state != 0.0:
        el.set(ns("state"), number(joint.state))
    _sub(el, "origin", ("xyz", numbers(joint.origin[:3, 3])),
         ("rpy", numbers(stable_rpy(joint.origin[:3, :3]))))
    _sub(el, "parent", ("link", joint.parent))
    _sub(el, "child", ("link", joint.child))
    if joint.type.multi_dof:
        if not joint.dynamics.is_zero():
            _dynamics(el, joint)
        return el
    if not joint.type.movable:
        return el
    axis = joint.axis
    norm = float(np.linalg.norm(axis))
    if abs(norm - 1.0) > 1e-12:  # our reader keeps near-unit axes as written: make it unit
        axis = axis / norm
    _sub(el, "axis", ("xyz", numbers(axis)))
    if joint.type in (JointType.REVOLUTE, JointType.PRISMATIC) or \
            joint.drive_limits is not None:
        # URDF requires a prismatic <limit>: a slide without limits gets SDF's "no limit"; a
        # continuous joint's <limit> holds its effort and velocity (urdfdom ignores its range)
        if joint.type is JointType.CONTINUOUS:
            range_ = ()
        else:
            lim = joint.limits or Limits(-UNBOUNDED_LIMIT, UNBOUNDED_LIMIT)
            range_ = (("lower", number(lim.lower)), ("upper", number(lim.upper)))
        effort, velocity = joint.effort_limit, joint.velocity_limit
        limit = _sub(el, "limit", *range_,
                     ("effort", number(DEFAULT_EFFORT if effort is None else effort)),
                     ("velocity", number(DEFAULT_VELOCITY if velocity is None else velocity)))
        for attr, value in (("effort", effort), ("velocity", velocity)):
            if value is None:
                limit.set(ns(attr), UNKNOWN)
    _dynamics(el, joint)
    if joint.mimic is not None:
        m = joint.mimic
        _sub(el, "mimic", ("joint", m.joint), ("multiplier", number(m.multiplier)),
             ("offset", number(m.offset)))
    if joint.drive is not None:
        el.append(drive_element(joint.drive))
    return el


def drive_element(drive: Drive) -> etree._Element:
    """A joint's drive as ``<real2code:drive>`` in its ``<joint>`` (URDF has no actuator with
    gains: a ``<transmission>``'s standard form names a joint and an interface only),
    SI units, radians; attributes left out are the model's defaults (none: no limit)."""
    el = etree.Element(ns("drive"))
    el.set("kind", drive.kind.value)
    for attr in ("stiffness", "damping", "target", "gear"):
        value = getattr(drive, attr)
        if value != (1.0 if attr == "gear" else 0.0):
            el.set(attr, number(value))
    if drive.force_limit is not None:
        el.set("force_limit", number(drive.force_limit))
    if drive.target_range is not None:
        el.set("target_range", numbers(drive.target_range))
    if drive.name is not None:
        el.set("name", drive.name)
    return el


def _dynamics(el: etree._Element, joint: Joint) -> None:
    d = joint.dynamics
    dynamics = _sub(el, "dynamics", ("damping", number(d.damping)),
                    ("friction", number(d.friction)))
    for attr, value in (("stiffness", d.stiffness), ("springref", d.spring_ref),
                        ("armature", d.armature)):
        if value != 0.0:
            dynamics.set(ns(attr), number(value))


RPY_DECIMALS = 13  # rotation error <= ~1e-13 (URDF tools read these as doubles)


def stable_rpy(rotation: np.ndarray) -> np.ndarray:
    """URDF roll-pitch-yaw of ``rotation``, exact to ~1e-13, chosen so that reading the file
    and writing it again gives the same text (export(import(export)) byte-identical).

    rpy -> matrix -> rpy moves the last bits (and can drift by an ulp per pass), so the
    angles are rounded to RPY_DECIMALS places, which absorbs that; the few rotations that
    land on a rounding boundary settle after a step or two, on a fixed point or a short
    cycle whose smallest member is reached from every start on it."""
    seen: list[tuple[float, ...]] = []
    rpy = _rounded(matrix_to_rpy(rotation))
    for _ in range(8):
        if rpy in seen:
            return np.array(min(seen[seen.index(rpy):]))
        seen.append(rpy)
        rpy = _rounded(matrix_to_rpy(tf.rpy_to_matrix(rpy)))
    return np.array(seen[-1])


def _rounded(rpy: np.ndarray) -> tuple[float, ...]:
    return tuple(float(format(v, f".{RPY_DECIMALS}f")) + 0.0 for v in rpy)  # + 0.0: no -0.0


def matrix_to_rpy(r: np.ndarray) -> np.ndarray:
    """URDF roll-pitch-yaw (R = Rz(yaw) Ry(pitch) Rx(roll)) that reproduces ``r`` to
    round-off everywhere, gimbal lock included.

    The textbook conversion switches to yaw only when |sin(pitch)| > 1 - 1e-12, that is
    within 1.4e-6 rad of pitch = +-pi/2, and there loses up to that much; and it takes roll
    and yaw independently, which near that point costs eps / cos(pitch). Here (as in
    Eigen's eulerAngles) pitch comes from atan2(-r20, hypot(r00, r10)) and roll is solved
    after yaw from Rz(yaw)^T r, so errors in yaw are compensated, not added."""
    r = np.asarray(r, dtype=float)
    yaw = np.arctan2(r[1, 0], r[0, 0])
    pitch = np.arctan2(-r[2, 0], np.hypot(r[0, 0], r[1, 0]))
    sy, cy = np.sin(yaw), np.cos(yaw)
    # Row 1 of Rz(yaw)^T r = Ry Rx is (0, cos(roll), -sin(roll)).
    roll = np.arctan2(sy * r[0, 2] - cy * r[1, 2], cy * r[1, 1] - sy * r[0, 1])
    return np.array([roll, pitch, yaw])
