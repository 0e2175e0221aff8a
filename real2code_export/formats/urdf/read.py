"""URDF file -> :class:`ArticulatedObject`, repairing what real files get wrong.

We parse the XML ourselves (lxml) rather than through urdfdom, the parser Pinocchio and ROS
use: urdfdom refuses files we must repair (PartNet's ``<limit>`` without ``effort``) and
reports no line numbers, while lxml keeps every element's line, so each error reads
``file:line: <joint name='x'>: what is wrong``.

Repairs (each warned about): limits without effort/velocity are kept as unknown; links
without inertials get mass properties from their visual meshes; links without collision
get convex pieces from their visual meshes; non-unit axes are normalised; names that are
not identifiers are sanitised; mimic tags are ignored; a zero mass means massless; inertia
tensors off positive definiteness or the triangle inequality are balanced, massless parts
that a joint moves get a negligible mass (``repairs``); a revolute joint without <limit> is
continuous, as is one with lower == upper (MuJoCo loads both unlimited); a prismatic one with
lower == upper is fixed at that value. Everything else that is wrong is
a :class:`FormatError`.

URDF has no observed joint state: it is q = 0, or the nearest limit when the range excludes 0
(unless our own ``real2code:state`` says otherwise).
"""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path

import numpy as np
from lxml import etree

from ... import transforms as tf
from ...collision import collision_pieces, thickened
from ...errors import FormatError, ModelError
from ...inertia import DEFAULT_DENSITY, inertial_from_meshes
from ...model import (
    AXIS_UNIT_TOLERANCE,
    DEFAULT_COLOR,
    UNBOUNDED_LIMIT,
    WHITE,
    ArticulatedObject,
    Drive,
    DriveKind,
    DriveLimits,
    Dynamics,
    Inertial,
    Joint,
    JointType,
    Limits,
    Mesh,
    Mimic,
    Part,
    Texture,
    sanitize_name,
    validate,
    validate_inertial,
)
from ...repairs import (
    balanced_inertia,
    composed_mimic_chains,
    floating_joints_from_the_root,
    massless_moving_parts,
    unusable_mimics,
)
from .context import Context, label
from .conventions import (
    ELEMENTS_KEY,
    KEPT,
    KEPT_IN,
    NAMESPACE,
    PREFIX,
    UNKNOWN,
    URDFDOM_REQUIRES,
    ns,
)
from .geometry import (
    average_color,
    file_colors,
    material_color,
    material_image,
    origin_matrix,
    read_meshes_ahead,
    robot_materials,
    shape_mesh,
)
from .structure import (
    BALL_TYPE,
    PLANAR,
    check_tree,
    fold_added_world,
    identifiers,
    joint_elements,
    joint_ends,
    link_elements,
    parse,
    unread_children,
    unread_in,
    unread_in_parts,
)

# An axis this close to unit length is kept as written, so that what we write reads back
# bit for bit; beyond it we normalise (and warn beyond the model's tolerance).
_AXIS_EXACT = 1e-12


def load(path: str | Path, *, faithful_collision: bool = False,
         hull_collision: bool = True) -> ArticulatedObject:
    """Read a URDF file (meshes relative to it, or ``package://``) into the model.

    ``faithful_collision``: for links whose collision is their visual geometry (see
    ``_from_visual``; PartNet-Mobility's), split hollow pieces so that they keep their
    insides and cut the parts' pieces apart (``collision_separation``). Off by default:
    on a robot's detailed meshes it takes minutes (g1: 120 s instead of 3 s), and a robot's
    links are meant to overlap at their joints.

    ``hull_collision=False`` (and not ``faithful_collision``): no hulls are computed; each
    ``<collision>`` mesh (or visual mesh, for a link without collision) is kept as it is,
    standing for its convex hull, for writers whose consumers take that hull themselves
    (``formats.hulls_collision``)."""
    path = Path(path)
    if not path.is_file():
        raise FormatError(path, None, "file not found")
    ctx = Context(path)
    robot = parse(ctx)
    compiler = robot.find("mujoco/compiler")
    if compiler is not None:
        ctx.meshdir = compiler.get("meshdir") or compiler.get("assetdir")
    links = link_elements(ctx, robot)
    joints = joint_elements(ctx, robot, links)
    check_tree(ctx, links, joints)
    fold_added_world(ctx, links, joints)
    name = _robot_name(ctx, robot)
    part_names = identifiers(ctx, links)
    joint_names = identifiers(ctx, joints)
    materials = robot_materials(ctx, robot)
    read_meshes_ahead(ctx, links.values())
    parts = [_part(ctx, el, part_names[raw], materials, faithful_collision,
                   hull_collision or faithful_collision) for raw, el in links.items()]
    joint_list, joint_el = [], {}  # (the element each joint of the model comes from)
    for raw, el in joints.items():
        if el.get("type") == PLANAR:
            chain, between = _planar(ctx, el, joint_names[raw], part_names, joint_names)
            parts += between
        else:
            chain = [_joint(ctx, el, joint_names[raw], part_names, joint_names)]
        joint_list += chain
        joint_el.update((j.name, el) for j in chain)
    _report_notes(ctx)
    dropped = unread_in_parts(links.values())
    if dropped:
        ctx.warn(None, "not read (in a visual, collision or inertial, which the model merges "
                 "into its part: no element to keep them in): " + ", ".join(
                     f"<{etree.QName(el).localname}> in the <{el.getparent().tag}> of "
                     f"{label(el.getparent().getparent())} (line {el.sourceline})"
                     for el in dropped))
    metadata = _with_unread_elements(ctx, robot, _metadata(ctx, robot))
    unread = unread_in([*links.values(), *joints.values()])
    found = [el for el in unread if el.get(ns(KEPT)) is None]  # (not our writer's)
    if found:  # (no other format has a place for them; the URDF writer writes them back)
        ctx.warn(None, f"kept as metadata {ELEMENTS_KEY!r} (the URDF writer writes them back "
                 "into their element; no other format acts on them): " + ", ".join(
                     f"<{etree.QName(el).localname}> in {label(el.getparent())} "
                     f"(line {el.sourceline})" for el in found))
    for el in found:
        missing = [a for a in URDFDOM_REQUIRES.get(el.tag, ()) if el.get(a) is None]
        if missing:
            ctx.warn(label(el.getparent()), f"<{el.tag}> without {', '.join(missing)} "
                     "(urdfdom refuses the file for it): kept, written back beside the "
                     "joints, not in this one", el.sourceline)
    if unread:
        names = {"link": {raw: part_names[raw] for raw in links},
                 "joint": {raw: joint_names[raw] for raw in joints}}
        metadata = {**metadata, ELEMENTS_KEY: [*metadata.get(ELEMENTS_KEY, []), *(
            _kept_in(el, names) for el in unread)]}
    obj = ArticulatedObject(name=name, parts=parts, joints=joint_list, metadata=metadata)
    for joint_name, message in (floating_joints_from_the_root(obj)
                                + massless_moving_parts(obj) + composed_mimic_chains(obj)
                                + unusable_mimics(obj)):
        el = joint_el[joint_name]
        ctx.warn(label(el), message, el.sourceline)
    lines = {f"part {part_names[r]!r}": el for r, el in links.items()}
    lines.update({f"joint {joint_names[r]!r}": el for r, el in joints.items()})
    try:
        validate(obj)
    except ModelError as e:
        el, rest = _element_of(e.element, lines)
        owner = label(el) + rest if el is not None else e.element
        raise FormatError(path, owner, e.message, el.sourceline if el is not None else None) from e
    built = {part_names[raw] for raw, el in links.items()
             if faithful_collision and _from_visual(el)}
    return _separated(ctx, obj, built) if built else obj


def _from_visual(link: etree._Element) -> bool:
    """Whether the link's collision is its visual geometry: no <collision> (made from the
    visuals) or the same shapes as its <visual>s, as PartNet-Mobility writes them. Those
    pieces are ours to make faithful (hollow pieces split, parts kept apart); collision a
    robot's author modelled on purpose is only made convex, piece by piece."""
    collisions = list(link.iterchildren("collision"))
    visuals = list(link.iterchildren("visual"))
    if not collisions:
        return bool(visuals) and link.get(ns("collision")) != UNKNOWN
    if all(c.get(ns("convex")) == "true" for c in collisions):
        return False  # our own convex pieces, kept exactly
    return _shapes(collisions) <= _shapes(visuals)


def _shapes(elements: list[etree._Element]) -> set[tuple[str, str]]:
    """Each element's <origin> and <geometry>, as text (whitespace aside) to compare."""
    def text(el: etree._Element | None) -> str:
        return "" if el is None else "".join(etree.tostring(el, encoding="unicode").split())
    return {(text(e.find("origin")), text(e.find("geometry"))) for e in elements}


def _separated(ctx: Context, obj: ArticulatedObject, parts: set[str]) -> ArticulatedObject:
    """The pieces we made cut apart where two parts' pieces overlap (source meshes often
    interpenetrate): a URDF has no contact exclusions, so overlapping pieces would collide."""
    from ...collision_separation import separate  # only where pieces were made: not for USD

    out, cuts = separate(obj, parts=parts)
    for outcome, what in (("cut", "cut back"), ("dropped", "removed"),
                          ("carved", "split around another"),
                          ("left", "left overlapping (too much would go)")):
        found = [c for c in cuts if c.outcome == outcome]
        if found:
            pairs = sorted({(c.part, c.other_part) for c in found})
            deepest = max(c.depth for c in found) * 1000
            ctx.warn(None, f"collision pieces {what} where they overlapped another part's "
                           f"({len(found)} times, deepest {deepest:.1f} mm): "
                           + ", ".join(f"{a} against {b}" for a, b in pairs))
    return out


def _element_of(element: str,
                lines: dict[str, etree._Element]) -> tuple[etree._Element | None, str]:
    """The XML element a model error names ("joint 'x'", "part 'y' visual", ...)."""
    m = re.match(r"^((?:part|joint) '[^']*')(.*)$", element)
    if m and m.group(1) in lines:
        return lines[m.group(1)], m.group(2)
    return None, ""


def _robot_name(ctx: Context, robot: etree._Element) -> str:
    raw = robot.get("name")
    if not raw:
        name = sanitize_name(ctx.path.stem)
        ctx.warn(label(robot), f"has no name; using {name!r}", robot.sourceline)
        return name
    name = sanitize_name(raw)
    if name != raw:
        ctx.note("renamed", f"{raw!r} -> {name!r}")
    return name


def _metadata(ctx: Context, robot: etree._Element) -> dict:
    text = robot.get(ns("metadata"))
    if text is None:
        return {}
    try:
        data = json.loads(text)
    except json.JSONDecodeError as e:
        raise ctx.error(label(robot), f"real2code:metadata is not JSON: {e.msg}",
                        robot.sourceline) from e
    if not isinstance(data, dict):
        raise ctx.error(label(robot), "real2code:metadata must be a JSON object", robot.sourceline)
    return data


def _with_unread_elements(ctx: Context, robot: etree._Element, metadata: dict) -> dict:
    """The metadata with the children of <robot> the model has no place for, as XML text."""
    unread = unread_children(robot)
    if not unread:
        return metadata
    ctx.warn(None, f"kept as metadata {ELEMENTS_KEY!r} (the URDF writer writes them back; no "
             "other format acts on them): " + ", ".join(
                 f"<{etree.QName(el).localname}> (line {el.sourceline})" for el in unread))
    return {**metadata, ELEMENTS_KEY: [_element_text(el) for el in unread]}


def _kept_in(el: etree._Element, names: dict[str, dict[str, str]]) -> str:
    """A child of a <link> or <joint> the model has no place for, as XML text wrapped in
    <real2code:in link|joint="NAME"> (``conventions.KEPT_IN``; NAME the model's)."""
    owner = el.getparent()
    wrapper = etree.Element(f"{{{NAMESPACE}}}{KEPT_IN}", nsmap={PREFIX: NAMESPACE})
    wrapper.set(owner.tag, names[owner.tag][owner.get("name")])
    kept = copy.deepcopy(el)
    kept.attrib.pop(ns(KEPT), None)
    wrapper.append(kept)
    return _element_text(wrapper)


def _element_text(el: etree._Element) -> str:
    """An element as XML text, without the layout whitespace between elements (a writer
    indents it again) or namespace declarations it does not use."""
    el = copy.deepcopy(el)
    for sub in el.iter():
        if sub.text is not None and not sub.text.strip() and len(sub):
            sub.text = None
        if sub.tail is not None and not sub.tail.strip():
            sub.tail = None
    etree.cleanup_namespaces(el)
    return etree.tostring(el, encoding="unicode", with_tail=False)


def _report_notes(ctx: Context) -> None:
    messages = {
        "renamed": "names changed to identifiers: {}",
        "limit": "<limit> without effort and/or velocity (urdfdom refuses that) in joints {}: "
                 "kept as unknown",
        "half_range": "<limit> with one bound in joints {}: the other is 0, as the URDF "
                      "specification and urdfdom (ROS, Pinocchio) read it (MuJoCo's import "
                      "leaves such a joint unlimited)",
        "limit_dropped": "<limit> ignored on fixed joints {}",
        "swing_dropped": "<limit> ignored on spherical joints {} (Bullet's swing spans and "
                         "twist: no format holds them, the ball is free)",
        "range_dropped": "<limit> lower and upper ignored on continuous joints {} (as urdfdom "
                         "ignores them; effort and velocity kept)",
        "inertial": "no <inertial> in links {}: mass properties computed from their visual "
                    f"meshes at {DEFAULT_DENSITY} kg/m^3",
        "collision": "no <collision> in links {}: convex collision pieces made from their "
                     "visual meshes",
        "meshdir": f"<mujoco><compiler meshdir={ctx.meshdir!r}>: mesh files {{}} found in that "
                   "folder, where MuJoCo looks for them, not beside the URDF",
        "colours": "visuals of several colours, some faces of no stated colour (no <material>, "
                   "none in the mesh file), in links {}: "
                   "the part's colour is their area-weighted mean (the meshes are kept; the "
                   "colours per visual are not)",
    }
    for kind, names in ctx.notes.items():
        ctx.warn(None, messages[kind].format(", ".join(names)))
    for root, names in ctx.asset_roots.items():
        ctx.warn(None, f"mesh files {', '.join(names)} not found beside the URDF: taken from "
                 f"{root}, the nearest folder above it (or on the search path, --package-path) "
                 "holding their paths (the asset root they are written from)")


# -- links ----------------------------------------------------------------------------------------
def _placed(mesh: Mesh, transform: np.ndarray) -> Mesh:
    """A <visual>'s or <collision>'s mesh at its origin, saying which mesh file's mesh it
    places (``Mesh.placements``: a file several elements name is written once where a format
    can place it)."""
    return Mesh.placed(mesh, None if np.array_equal(transform, np.eye(4)) else transform)


def _part(ctx: Context, el: etree._Element, name: str, materials: dict,
          faithful_collision: bool, hull_collision: bool) -> Part:
    owner = label(el)
    robot = el.getparent()
    visuals: list[Mesh] = []
    colored = []
    runs: list[list] = []  # each visual's colours over its faces (None: it states none)
    stated = []  # each visual's <material> colour (None: it states none)
    textures = []  # each visual's image (None: it has none)
    tints = []  # each visual's colour (an image's tint; None: it states none)
    looks = []  # each visual's file's images and colours where it has several (MeshFile)
    for v in el.iterchildren("visual"):
        mesh, file = shape_mesh(ctx, v, owner)
        if mesh is None:
            continue
        image = material_image(ctx, v, robot, owner, mesh)
        looks.append(ctx.files[file].looks if file is not None else ())
        if image is not None and file is not None and (ctx.files[file].texture is not None
                                                       or looks[-1]):
            ctx.warn(owner, f"<material> image {image.name!r} not used: the mesh file brings "
                     "its own (as rviz draws it)", v.sourceline)
            image = None
        textures.append(image or (ctx.files[file].texture if file is not None else None))
        mesh = _placed(mesh, origin_matrix(ctx, v, owner))
        visuals.append(mesh)
        color = material_color(ctx, v, materials, owner)
        color = None if color is None else tuple(float(c) for c in color)
        stated.append(color)
        if color is None and file is not None and textures[-1] is None and not looks[-1]:
            runs.append(file_colors(ctx, file, len(mesh.faces)))  # as viewers show the file
        else:  # (an image: it and its tint, in the part's colour)
            runs.append([(len(mesh.faces), color)])
        if color is None and file is not None:
            color = ctx.files[file].color
        tints.append(color)
        if color is not None:
            colored.append((color, mesh))
    collision = _collision(ctx, el, name, visuals, faithful_collision and _from_visual(el),
                           hull_collision)
    inertial = _link_inertial(ctx, el, name, visuals)
    # colours that differ, each face's stated (by its visual's <material>, or its untextured
    # mesh file's MTL or Collada materials): kept per face
    colours = {c for piece in runs for _, c in piece}
    per_face = None not in colours and len(colours) > 1
    if per_face and len(visuals) == 1 and len(runs[0]) > 1:  # one file of several colours:
        # cut at its runs, as the URDF writer's file per colour reads back (join_colored
        # keeps one visual whole, as USD's and glTF's subsets of one mesh hold it)
        one = visuals[0]
        cut = Mesh(one.vertices, one.faces, one.uv, colors=runs[0]).color_pieces()
        visuals, runs = [m for m, _ in cut], [[(len(m.faces), c)] for m, c in cut]
    visual = Mesh.join_colored(visuals, runs) if visuals else None
    texture = next((t for t in textures if t is not None), None)
    if any(looks) or texture is not None and (
            visual.uv is None or len({t.image for t in textures if t is not None}) > 1
            or len({c for piece in runs for _, c in piece}) > 1):
        visual, texture = _one_image(ctx, owner, visuals, textures, tints, runs, looks,
                                     stated)
        colored = [(WHITE, visual)]
    if len({c for c, _ in colored}) > 1 and not per_face:
        ctx.note("colours", f"{name!r} ({len({c for c, _ in colored})})")
    # The part's one colour (what a renderer of one colour per part draws) as before mesh
    # files' colours were kept per face: the first run's where the <material>s alone differ,
    # else the area-weighted mean of the visuals' colours (a file's: its faces' mean).
    by_material = None not in stated and len(set(stated)) > 1
    color = visual.colors[0][1] if by_material and visual.colors else average_color(colored)
    if el.get(ns("color")) is not None and visual is not None and visual.colors:
        color = tuple(float(c) for c in np.clip(  # ours, beside the runs (the URDF writer)
            ctx.floats(el, ns("color"), owner, count=4), 0.0, 1.0))
    return Part(name=name, visual=visual, collision=collision, inertial=inertial,
                color=color or DEFAULT_COLOR, texture=texture)


def _one_image(ctx: Context, owner: str, visuals: list[Mesh], textures: list, tints: list,
               runs: list[list], looks: list, stated: list) -> tuple[Mesh, Texture]:
    """A link's visuals drawn from several images, or from an image beside colours, as one
    mesh with one image (:mod:`...texture_atlas`; a part holds one): each image tinted by its
    visual's colour, each other colour a tile of its own; a file of several images and
    colours (``MeshFile.looks``) run by run, its <material>'s colour, where stated, over
    them as over any file's own colours."""
    from ...texture_atlas import AtlasPiece, faces_of, pack

    pieces = []
    for mesh, texture, tint, piece_runs, file_looks, colour in zip(
            visuals, textures, tints, runs, looks, stated, strict=True):
        if file_looks:
            start = 0
            for n, image, own in file_looks:
                pieces.append(AtlasPiece(faces_of(mesh, start, start + n), image,
                                         colour or own))
                start += n
            continue
        if texture is not None:
            pieces.append(AtlasPiece(mesh, texture, tint or WHITE))
            continue
        for sub, rgba in Mesh(mesh.vertices, mesh.faces, colors=[
                (n, c or DEFAULT_COLOR) for n, c in piece_runs]).color_pieces():
            pieces.append(AtlasPiece(sub, None, rgba))
    atlas = pack(pieces)
    images = len({p.texture.image for p in pieces if p.texture is not None})
    ctx.warn(owner, f"{images} image(s) and {len({p.color for p in pieces if not p.texture})} "
             "other colour(s) over its visuals packed into one image (a part holds one)"
             + (f": {'; '.join(atlas.notes)}" if atlas.notes else ", every pixel kept"))
    return atlas.mesh, atlas.texture


def _collision(ctx: Context, el: etree._Element, name: str, visuals: list[Mesh],
               split_hollow: bool, hull: bool) -> list[Mesh]:
    owner = label(el)
    elements = list(el.iterchildren("collision"))
    shaped = [(shape_mesh(ctx, c, owner)[0], c) for c in elements]
    source = [_placed(mesh, origin_matrix(ctx, c, owner)) for mesh, c in shaped
              if mesh is not None]
    if elements and all(c.get(ns("convex")) == "true" for c in elements):
        return source  # written by us: already convex pieces, kept exactly
    if not source:
        if elements or not visuals or el.get(ns("collision")) == UNKNOWN:
            return []
        ctx.note("collision", repr(name))
        source = visuals
    # Shapes (box, cylinder, ...) are convex: each is a piece as it is. Only meshes are cut.
    shapes = [Mesh.of_primitive(p) for m in source for p in m.primitives]
    meshes = [r for r in (m.remainder() for m in source) if r is not None]
    if not meshes:
        return shapes
    if not hull:
        return [thickened(piece) for piece in meshes if len(piece.faces)] + shapes
    try:
        return collision_pieces(Mesh.concatenate(meshes), "pieces", source_pieces=meshes,
                                split_hollow=split_hollow) + shapes
    except ValueError as e:
        raise ctx.error(owner, f"cannot make convex collision pieces: {e}", el.sourceline) from e


def _link_inertial(ctx: Context, el: etree._Element, name: str,
                   visuals: list[Mesh]) -> Inertial | None:
    owner = label(el)
    inertial_el = el.find("inertial")
    if inertial_el is not None and inertial_el.find("mass") is None:
        # urdfdom (Pinocchio, ROS) drops such an <inertial> and loads the link; MuJoCo refuses
        ctx.warn(owner, "<inertial> has no <mass>: read as a link without <inertial>, as "
                 "urdfdom drops it", inertial_el.sourceline)
        inertial_el = None
    if inertial_el is not None:
        return _inertial(ctx, inertial_el, owner)
    if not visuals or el.get(ns("inertial")) == UNKNOWN:
        return None  # an empty link (PartNet's base) stays massless
    ctx.note("inertial", repr(name))
    try:
        return inertial_from_meshes(visuals, density=DEFAULT_DENSITY)
    except ValueError as e:
        raise ctx.error(owner, f"cannot compute mass properties: {e}", el.sourceline) from e


def _inertial(ctx: Context, el: etree._Element, owner: str) -> Inertial | None:
    mass_el = el.find("mass")
    mass = ctx.number(mass_el, "value", owner)
    if mass == 0.0:
        ctx.warn(owner, "<mass value='0'>: the link is treated as massless (no inertial)",
                 mass_el.sourceline)
        return None
    inertia_el = el.find("inertia")
    if inertia_el is None:
        # urdfdom logs an error and keeps the mass (Pinocchio loads the link with no
        # rotational inertia); MuJoCo refuses the file. Read as a zero tensor, which the
        # balancing below repairs as any zero tensor, warned.
        ctx.warn(owner, "<inertial> has no <inertia>: read as a zero tensor, as Pinocchio "
                 "reads it", el.sourceline)
        ixx = ixy = ixz = iyy = iyz = izz = 0.0
        inertia_el = el  # the element the repairs below name
    else:
        ixx, ixy, ixz, iyy, iyz, izz = (ctx.number(inertia_el, a, owner)
                                        for a in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"))
    tensor = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    frame = origin_matrix(ctx, el, owner)
    rot = frame[:3, :3]
    if not np.array_equal(rot, np.eye(3)):  # the tensor is given in the rotated origin axes
        tensor = rot @ tensor @ rot.T
        tensor = 0.5 * (tensor + tensor.T)
    inertial = Inertial(mass=mass, com=frame[:3, 3], inertia=tensor)
    if not np.all(np.isfinite(tensor)):
        raise ctx.error(owner, "<inertia> is not finite", inertia_el.sourceline)
    if mass < 0:
        raise ctx.error(owner, f"<mass value='{mass_el.get('value')}'> is negative",
                        mass_el.sourceline)
    try:
        inertial, change = balanced_inertia(inertial)
    except ValueError as e:
        raise ctx.error(owner, str(e), inertia_el.sourceline) from e
    if change is not None:
        ctx.warn(owner, change, inertia_el.sourceline)
    try:
        validate_inertial(inertial, owner)
    except ModelError as e:
        raise ctx.error(owner, e.message, el.sourceline) from e
    return inertial


# -- joints ---------------------------------------------------------------------------------------
def _joint(ctx: Context, el: etree._Element, name: str, part_names: dict[str, str],
           joint_names: dict[str, str]) -> Joint:
    owner = label(el)
    jtype = JointType.BALL if el.get("type") == BALL_TYPE else JointType(el.get("type"))
    if jtype is JointType.FIXED and el.get(ns("type")) == JointType.BALL.value:
        jtype = JointType.BALL  # our writer's ball joint (URDF has none)
    parent, child = joint_ends(el)
    joint = Joint(name=name, type=jtype, parent=part_names[parent], child=part_names[child],
                  origin=origin_matrix(ctx, el, owner),
                  mimic=_mimic(ctx, el, owner, joint_names), drive=_drive(ctx, el, owner))
    if jtype.multi_dof:
        joint.dynamics = _dynamics(ctx, el, owner)
    if jtype is JointType.BALL and el.get(ns("cone_limit")) is not None:
        joint.cone_limit = ctx.number(el, ns("cone_limit"), owner)
    if jtype.movable:
        joint.axis = _axis(ctx, el, owner)
        joint.dynamics = _dynamics(ctx, el, owner)
        joint.state = ctx.number(el, ns("state"), owner, default=0.0)
    limit = el.find("limit")
    if jtype is JointType.REVOLUTE and limit is None:
        # urdfdom refuses it; MuJoCo's URDF import makes an unlimited hinge, as we do.
        ctx.warn(owner, "a revolute joint without <limit>: imported as continuous",
                 el.sourceline)
        joint.type = jtype = JointType.CONTINUOUS
    if jtype in (JointType.REVOLUTE, JointType.PRISMATIC):
        if limit is None:
            raise ctx.error(owner, f"a {jtype.value} joint needs a <limit>", el.sourceline)
        joint.limits = _limits(ctx, limit, owner, name)
        lim = joint.limits
        if jtype is JointType.PRISMATIC and lim.lower <= -UNBOUNDED_LIMIT <= UNBOUNDED_LIMIT \
                <= lim.upper:
            return _unbounded_slide(ctx, joint, owner, limit)
        if joint.limits.lower == joint.limits.upper:
            return _empty_range(ctx, joint, owner, limit)
        if joint.limits.lower > joint.limits.upper:
            return _inverted_range(ctx, joint, owner, limit)
        if el.get(ns("state")) is None:
            # URDF has no observed state; q = 0 is the rest pose, or the nearest limit when the
            # range excludes 0 (PartNet has such drawers).
            joint.state = min(max(0.0, joint.limits.lower), joint.limits.upper)
    elif limit is not None and jtype is JointType.CONTINUOUS:
        # urdfdom reads a continuous joint's effort and velocity and ignores its range
        if any(float(limit.get(a) or 0.0) != 0.0 for a in ("lower", "upper")
               if _is_number(limit.get(a))):
            ctx.note("range_dropped", repr(name))
        joint.drive_limits = _drive_limits(ctx, limit, owner, name)
    elif limit is not None:
        ctx.note("swing_dropped" if jtype is JointType.BALL else "limit_dropped", repr(name))
    return joint


def _planar(ctx: Context, el: etree._Element, name: str, part_names: dict[str, str],
            joint_names: dict[str, str]) -> tuple[list[Joint], list[Part]]:
    """A planar joint (motion in the plane normal to its axis) as MuJoCo's URDF import makes
    it: slides ``<name>_TX`` and ``<name>_TY`` along the plane's axes (x and y of the joint
    frame turned so that z is the axis) and a hinge ``<name>_RZ`` about the axis, through
    two massless intermediate parts ``<child>_<name>_TX``/``_TY``, each with the joint's
    dynamics; unlimited (urdfdom ignores a planar joint's <limit>). Pinocchio's planar
    joint moves in x and y whatever the axis."""
    owner = label(el)
    parent, child = joint_ends(el)
    axis = _axis(ctx, el, owner)
    turn = tf.rotation_between([0.0, 0.0, 1.0], axis)
    dynamics = _dynamics(ctx, el, owner)
    taken = set(part_names.values()) | set(joint_names.values())
    names = [sanitize_name(f"{name}_{k}", taken) for k in ("TX", "TY", "RZ")]
    between = [sanitize_name(f"{part_names[child]}_{n}", taken) for n in names[:2]]
    ends = [part_names[parent], *between, part_names[child]]
    origins = [origin_matrix(ctx, el, owner), np.eye(4), np.eye(4)]
    kinds = (JointType.PRISMATIC, JointType.PRISMATIC, JointType.CONTINUOUS)
    axes = (turn[:, 0], turn[:, 1], axis)
    chain = [Joint(name=n, type=kind, parent=a, child=b, origin=o, axis=ax,
                   dynamics=copy.copy(dynamics))
             for n, kind, a, b, o, ax in zip(names, kinds, ends[:-1], ends[1:], origins, axes,
                                             strict=True)]
    ctx.warn(owner, f"a planar joint: read as MuJoCo imports it, slides {names[0]!r} and "
             f"{names[1]!r} and hinge {names[2]!r} through massless parts "
             f"{', '.join(map(repr, between))}", el.sourceline)
    return chain, [Part(name=n) for n in between]


def _is_number(text: str | None) -> bool:
    try:
        float(text)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return False
    return True


def _drive_limits(ctx: Context, el: etree._Element, owner: str,
                  name: str) -> DriveLimits | None:
    """A joint without a range's effort and velocity (None when the <limit> gives neither)."""
    known = _effort_velocity(ctx, el, owner, name)
    return None if known["effort"] is None and known["velocity"] is None else \
        DriveLimits(**known)


def _drive(ctx: Context, el: etree._Element, owner: str) -> Drive | None:
    """Our writer's ``<real2code:drive>`` in a ``<joint>`` (``write.drive_element``)."""
    found = el.find(ns("drive"))
    if found is None:
        return None
    kind = found.get("kind")
    if kind not in {k.value for k in DriveKind}:
        raise ctx.error(owner, f"<real2code:drive> kind {kind!r} is not one of "
                        f"{[k.value for k in DriveKind]}", found.sourceline)
    values = {attr: ctx.number(found, attr, owner, default=1.0 if attr == "gear" else 0.0)
              for attr in ("stiffness", "damping", "target", "gear")}
    limit = None if found.get("force_limit") is None else \
        ctx.number(found, "force_limit", owner)
    target_range = None if found.get("target_range") is None else \
        tuple(float(v) for v in ctx.floats(found, "target_range", owner, count=2))
    drive = Drive(DriveKind(kind), force_limit=limit, target_range=target_range,
                  name=found.get("name"), **values)
    problem = drive.problem()
    if problem is not None:
        raise ctx.error(owner, f"<real2code:drive>: {problem}", found.sourceline)
    return drive


def _mimic(ctx: Context, el: etree._Element, owner: str,
           joint_names: dict[str, str]) -> Mimic | None:
    """``<mimic joint= multiplier= offset=>`` (urdfdom's defaults 1 and 0), the leader named
    as this reader names joints (identifiers)."""
    mimic = el.find("mimic")
    if mimic is None:
        return None
    leader = mimic.get("joint")
    if not leader:
        raise ctx.error(owner, "<mimic> names no joint", mimic.sourceline)
    return Mimic(joint_names.get(leader, leader),
                 ctx.number(mimic, "multiplier", owner, default=1.0),
                 ctx.number(mimic, "offset", owner, default=0.0))


def _unbounded_slide(ctx: Context, joint: Joint, owner: str, limit: etree._Element) -> Joint:
    """A slide limited at +-1e16 or beyond: SDF's "no limit" (our writer's, for a slide without
    limits, since URDF requires a prismatic <limit>): read without limits."""
    lim = joint.limits
    joint.limits = None
    if lim.effort is not None or lim.velocity is not None:  # kept without the range
        joint.drive_limits = DriveLimits(lim.effort, lim.velocity)
    return joint


def _inverted_range(ctx: Context, joint: Joint, owner: str, limit: etree._Element) -> Joint:
    """``lower > upper``: Bullet's "no limit" (pybullet's planar bases), which urdfdom loads
    as written and MuJoCo refuses: read without a range, as Bullet simulates it."""
    kind = "continuous" if joint.type is JointType.REVOLUTE else "a slide without limits"
    ctx.warn(owner, f"<limit> lower={limit.get('lower')} > upper={limit.get('upper')}: "
             f"Bullet's \"no limit\"; imported as {kind} (its effort and velocity kept)",
             limit.sourceline)
    lim = joint.limits
    if joint.type is JointType.REVOLUTE:
        joint.type = JointType.CONTINUOUS
    joint.limits = None
    if lim.effort is not None or lim.velocity is not None:
        joint.drive_limits = DriveLimits(lim.effort, lim.velocity)
    return joint


def _empty_range(ctx: Context, joint: Joint, owner: str, limit: etree._Element) -> Joint:
    """``lower == upper`` (often a <limit> giving only effort and velocity, its range left at
    urdfdom's 0): MuJoCo loads such a hinge unlimited, so does this reader (continuous); a
    slide, which the model needs limited, is fixed at that value."""
    value = joint.limits.lower
    if joint.type is JointType.REVOLUTE:
        ctx.warn(owner, f"<limit> lower == upper == {value:g}: an empty range, which MuJoCo "
                 "loads unlimited; imported as continuous (its effort and velocity kept)",
                 limit.sourceline)
        lim = joint.limits
        joint.type, joint.limits = JointType.CONTINUOUS, None
        if lim.effort is not None or lim.velocity is not None:
            joint.drive_limits = DriveLimits(lim.effort, lim.velocity)
        return joint
    ctx.warn(owner, f"<limit> lower == upper == {value:g}: the slide cannot move; imported as "
             f"a fixed joint at q = {value:g}", limit.sourceline)
    joint.origin = joint.transform(value)
    joint.type, joint.limits, joint.state = JointType.FIXED, None, 0.0
    joint.dynamics = Dynamics()
    return joint


def _axis(ctx: Context, el: etree._Element, owner: str) -> np.ndarray:
    axis_el = el.find("axis")
    if axis_el is None:
        return np.array([1.0, 0.0, 0.0])  # the URDF default
    axis = ctx.floats(axis_el, "xyz", owner, count=3, default=(1.0, 0.0, 0.0))
    norm = float(np.linalg.norm(axis))
    if norm < 1e-12:
        raise ctx.error(owner, f"<axis> xyz={axis_el.get('xyz')!r} has zero length",
                        axis_el.sourceline)
    if abs(norm - 1.0) > _AXIS_EXACT:
        if abs(norm - 1.0) > AXIS_UNIT_TOLERANCE:
            ctx.warn(owner, f"<axis> xyz={axis_el.get('xyz')!r} has length {norm:.9g}; "
                     "normalised", axis_el.sourceline)
        axis = axis / norm
    return axis


def _limits(ctx: Context, el: etree._Element, owner: str, name: str) -> Limits:
    lower = ctx.number(el, "lower", owner, default=0.0)
    upper = ctx.number(el, "upper", owner, default=0.0)
    missing = [a for a in ("lower", "upper") if el.get(a) is None]
    if len(missing) == 1:  # (neither: an empty range, read as MuJoCo reads it)
        ctx.note("half_range", f"{name!r} ({missing[0]} 0)")
    return Limits(lower=lower, upper=upper, **_effort_velocity(ctx, el, owner, name))


def _effort_velocity(ctx: Context, el: etree._Element, owner: str,
                     name: str) -> dict[str, float | None]:
    """A <limit>'s effort and velocity, None where it gives none (noted) or where our writer
    marked the value written as a default."""
    known: dict[str, float | None] = {}
    for attr in ("effort", "velocity"):
        if el.get(ns(attr)) == UNKNOWN:  # our own marker: the value written is a default
            known[attr] = None
        elif el.get(attr) is None:
            known[attr] = None
            if repr(name) not in ctx.notes.get("limit", []):
                ctx.note("limit", repr(name))
        else:
            value = ctx.number(el, attr, owner)
            if value < 0:
                raise ctx.error(owner, f"<limit> {attr}={el.get(attr)} is negative", el.sourceline)
            known[attr] = value
    return known


def _dynamics(ctx: Context, el: etree._Element, owner: str) -> Dynamics:
    d = el.find("dynamics")
    if d is None:
        return Dynamics()
    values = {
        "damping": ctx.number(d, "damping", owner, default=0.0),
        "friction": ctx.number(d, "friction", owner, default=0.0),
        "stiffness": ctx.number(d, ns("stiffness"), owner, default=0.0),
        "spring_ref": ctx.number(d, ns("springref"), owner, default=0.0),
        "armature": ctx.number(d, ns("armature"), owner, default=0.0),
    }
    for attr in ("damping", "friction", "stiffness", "armature"):
        if values[attr] < 0:
            raise ctx.error(owner, f"<dynamics> {attr} must be >= 0, got {values[attr]}",
                            d.sourceline)
    return Dynamics(**values)
