"""The shape of a URDF document: parsed XML, named links and joints, one tree.

Checked before anything is built, so a broken structure is reported at its own element
and line, not as a consequence later.
"""

from __future__ import annotations

import re

from lxml import etree

from ...model import NAME_PATTERN, sanitize_name
from .context import Context, label
from .conventions import ADDED, NAMESPACE, PREFIX, ns
from .xacro_file import document

# URDF's own joint kinds the model holds (a ball joint is ours: a fixed one marked
# real2code:type="ball"); planar is read as two slides and a hinge.
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating")
# Not URDF, but written by pybullet's files and read as a ball joint by MuJoCo and Bullet.
BALL_TYPE = "spherical"
# The children of <robot> the reader uses, and <mujoco>: MuJoCo's compiler hints for loading
# the file (our writer emits one), which describe no part of the object.
READ_TAGS = ("link", "joint", "material", "mujoco")
# the children of <link> and <joint> the reader reads (URDF 1.0 and 1.1's capsule aside)
LINK_TAGS = ("inertial", "visual", "collision")
JOINT_TAGS = ("origin", "parent", "child", "axis", "limit", "dynamics", "mimic")
DRIVE_TAG = ns("drive")  # our writer's joint drive (write.drive_element)


def parse(ctx: Context) -> etree._Element:
    """The <robot> element. lxml, not urdfdom (ROS's and Pinocchio's parser): urdfdom refuses
    files we must repair (PartNet's <limit> without effort) and reports no line numbers;
    lxml keeps every element's source line for our messages."""
    parser = etree.XMLParser(remove_comments=True, remove_pis=True, resolve_entities=False,
                             no_network=True)
    try:
        robot, repairs = read_past(document(ctx.path), parser, base_url=str(ctx.path))
    except etree.XMLSyntaxError as e:
        raise ctx.error(None, f"malformed XML: {e.msg}", e.lineno) from e
    for message, line in repairs:
        ctx.warn(None, message, line)
    namespace = etree.QName(robot).namespace
    if namespace is not None and etree.QName(robot).localname == "robot":
        # urdfdom (TinyXML) reads tags without namespaces, so ROS and Pinocchio load a
        # <robot xmlns="..."> as a plain URDF: read it the same way, and say so.
        ctx.warn(None, f"the default XML namespace {namespace!r} of <robot> is ignored, as "
                 "urdfdom ignores it", robot.sourceline)
        for el in robot.iter(f"{{{namespace}}}*"):
            el.tag = etree.QName(el).localname
        etree.cleanup_namespaces(robot)
    if robot.tag != "robot":
        raise ctx.error(label(robot), "the root element must be <robot>", robot.sourceline)
    return robot


_UNDECLARED = re.compile(r"Namespace prefix (\S+) (?:on|for) (\S+) is not defined")
_ROOT_TAG = re.compile(rb"<robot(?=[\s/>])")


def read_past(data: bytes, parser=None, base_url: str | None = None
              ) -> tuple[etree._Element, list[tuple[str, int | None]]]:
    """The root element of ``data`` parsed past what urdfdom's TinyXML2 (ROS, Pinocchio) and
    MuJoCo read past and libxml2 refuses, and each such repair as (message, line): the
    prologue's (:func:`tolerated_prologue`), and a namespace prefix used but never declared
    (``<sensor:camera>`` in old Gazebo extensions), declared on <robot> (the elements stay
    unread, as any Gazebo tag). Any other syntax error is raised."""
    repairs: list[tuple[str, int | None]] = []
    try:
        return etree.fromstring(data, parser, base_url=base_url), repairs
    except etree.XMLSyntaxError:
        data, what = tolerated_prologue(data)
        if what:
            repairs.append(("; ".join(what) + ", as urdfdom (TinyXML2) and MuJoCo ignore it",
                            None))
    declared: set[str] = set()
    while True:
        try:
            return etree.fromstring(data, parser, base_url=base_url), repairs
        except etree.XMLSyntaxError as e:
            match = _UNDECLARED.search(e.msg or "")
            root = _ROOT_TAG.search(data)
            if match is None or root is None or match.group(1) in declared:
                raise
            prefix, name = match.groups()
            repairs.append((f"the XML namespace prefix {prefix!r} (of {prefix}:{name}) is "
                            "not declared: declared on <robot> to read the file, as urdfdom "
                            "(TinyXML2) and MuJoCo read past it", e.lineno))
            declared.add(prefix)
            # On the <robot> tag's own line, so every element keeps its line number.
            declaration = f' xmlns:{prefix}="urn:real2code:undeclared:{prefix}"'.encode()
            data = data[:root.end()] + declaration + data[root.end():]


_DECLARATION = re.compile(rb"<\?xml\s[^?]*\?>")


def tolerated_prologue(data: bytes) -> tuple[bytes, list[str]]:
    """The document with what urdfdom's TinyXML2 (ROS, Pinocchio) and MuJoCo load past and
    libxml2 refuses blanked out, and what that was: an XML declaration whose version is not
    1.0 (pybullet's files say "0.0") or that is not at the very start (blank lines before
    it), and NUL bytes after the document (TinyXML2 reads up to the first)."""
    what = []
    declaration = _DECLARATION.search(data)
    at_start = declaration is not None and data[:declaration.start()] in (b"", b"\xef\xbb\xbf")
    if declaration is not None and (
            not at_start or b'version="1.' not in declaration.group().replace(b"'", b'"')):
        where = "not version 1.x" if at_start else "not at the start of the file"
        what.append(f"its XML declaration {declaration.group().decode(errors='replace')!r} is "
                    f"{where}: ignored")
        # Blanked, not removed, so every element keeps its line number.
        blank = re.sub(rb"[^\n]", b" ", declaration.group())
        data = data[:declaration.start()] + blank + data[declaration.end():]
    if data.rstrip(b"\x00 \t\r\n") != data.rstrip(b" \t\r\n"):
        what.append("NUL bytes after the document: ignored")
        data = data.rstrip(b"\x00 \t\r\n") + b"\n"
    return data, what


def unread_children(robot: etree._Element) -> list[etree._Element]:
    """The children of <robot> the model has no place for: transmissions, Gazebo tags,
    Drake frames... (kept in the metadata by the reader, never dropped in silence)."""
    return [el for el in robot.iterchildren(etree.Element) if el.tag not in READ_TAGS]


# What urdfdom reads in a link's <inertial>, <visual> and <collision>
PART_TAGS = {"inertial": ("origin", "mass", "inertia"),
             "visual": ("origin", "geometry", "material"),
             "collision": ("origin", "geometry")}


def unread_in_parts(links) -> list[etree._Element]:
    """The children of the <inertial>, <visual> and <collision> of the <link> elements
    ``links`` that no reader reads (custom data a tool put there; elements of our own
    namespace excepted), for a warning: they belong to a visual the model merges into its
    part, so no element is there to write them back into."""
    return [child for link in links for el in link.iterchildren(*PART_TAGS)
            for child in el.iterchildren(etree.Element)
            if child.tag not in PART_TAGS[el.tag] and etree.QName(child).namespace != NAMESPACE]


def unread_in(elements) -> list[etree._Element]:
    """The children of <link> and <joint> ``elements`` the model has no place for (a joint's
    <safety_controller> and <calibration>, a link's <self_collision_checking>, ...)."""
    known = {"link": LINK_TAGS, "joint": (*JOINT_TAGS, DRIVE_TAG)}
    return [child for el in elements for child in el.iterchildren(etree.Element)
            if child.tag not in known[el.tag]]


def _named(ctx: Context, robot: etree._Element, tag: str) -> dict[str, etree._Element]:
    out: dict[str, etree._Element] = {}
    for el in robot.iterchildren(tag):
        name = el.get("name")
        if not name:
            raise ctx.error(label(el), f"<{tag}> has no name", el.sourceline)
        if name in out:
            raise ctx.error(label(el), f"duplicate {tag} name (first defined at line "
                            f"{out[name].sourceline})", el.sourceline)
        out[name] = el
    return out


def link_elements(ctx: Context, robot: etree._Element) -> dict[str, etree._Element]:
    links = _named(ctx, robot, "link")
    if not links:
        raise ctx.error(label(robot), "has no <link>" + (_xacro_calls(robot) or _srdf(robot)),
                        robot.sourceline)
    return links


# What a MoveIt SRDF (semantic robot description; its root is <robot> too) holds instead
SRDF_ELEMENTS = ("group", "group_state", "end_effector", "virtual_joint", "disable_collisions",
                 "passive_joint", "disable_default_collisions")


def _srdf(robot: etree._Element) -> str:
    """A URDF without links that is an SRDF (``robot.srdf``, ``srdf/robot.xml``: MoveIt's
    groups and collision pairs of a robot, whose links are in its URDF)."""
    found = sorted({el.tag for el in robot if isinstance(el.tag, str) and el.tag in SRDF_ELEMENTS})
    if not found:
        return ""
    return (f" (it holds {', '.join(f'<{t}>' for t in found)}: an SRDF, MoveIt's semantic "
            "description of a robot, not the robot; convert the URDF it describes)")


XACRO_NAMESPACE = "http://ros.org/wiki/xacro"


def _xacro_calls(robot: etree._Element) -> str:
    """What a URDF without links holds in their place: xacro macro calls left unexpanded
    (a .xacro saved as .urdf; urdfdom and MuJoCo refuse it as a robot without links)."""
    calls = [el for el in robot.iter(etree.Element)  # (declared or not: ``read_past``)
             if etree.QName(el).namespace == XACRO_NAMESPACE or el.prefix == "xacro"]
    if not calls:
        return ""
    first = calls[0]
    return (f" (it holds {len(calls)} unexpanded xacro element(s), the first "
            f"<xacro:{etree.QName(first).localname}> at line {first.sourceline}: expand the "
            "file with xacro first)")


PLANAR = "planar"  # read as MuJoCo imports it: two slides and a hinge (``read._planar``)


def joint_elements(ctx: Context, robot: etree._Element,
                    links: dict[str, etree._Element]) -> dict[str, etree._Element]:
    joints = _named(ctx, robot, "joint")
    for el in joints.values():
        owner = label(el)
        jtype = el.get("type")
        if jtype == BALL_TYPE:
            ctx.warn(owner, f"type {jtype!r} is not URDF (urdfdom refuses it): read as a ball "
                     "joint, as MuJoCo and Bullet read it", el.sourceline)
        elif jtype not in JOINT_TYPES and jtype != PLANAR:
            raise ctx.error(owner, f"unknown joint type {jtype!r} (expected one of "
                            f"{', '.join(JOINT_TYPES)})", el.sourceline)
        for role in ("parent", "child"):
            sub = el.find(role)
            if sub is None or not sub.get("link"):
                raise ctx.error(owner, f"<{role} link=...> is missing",
                                (sub if sub is not None else el).sourceline)
            if sub.get("link") not in links:
                raise ctx.error(owner, f"<{role}> link {sub.get('link')!r} is not a link of "
                                "this robot", sub.sourceline)
    return joints


def joint_ends(el: etree._Element) -> tuple[str, str]:
    return el.find("parent").get("link"), el.find("child").get("link")


def check_tree(ctx: Context, links: dict[str, etree._Element],
                joints: dict[str, etree._Element]) -> None:
    """One tree: every link has at most one parent joint, no cycles, exactly one root."""
    parent_joint: dict[str, etree._Element] = {}
    for el in joints.values():
        child = joint_ends(el)[1]
        if child in parent_joint:
            first = parent_joint[child]
            raise ctx.error(label(el), f"link {child!r} already has parent joint "
                            f"{first.get('name')!r} (line {first.sourceline}); a URDF is a tree",
                            el.sourceline)
        parent_joint[child] = el
    for start in links:
        walk: list[str] = []
        link = start
        while link in parent_joint:
            if link in walk:
                cycle = [parent_joint[n] for n in reversed(walk[walk.index(link):])]
                k = min(range(len(cycle)), key=lambda i: cycle[i].sourceline)
                cycle = cycle[k:] + cycle[:k]  # parent to child, from the first in the file
                steps = ", ".join(f"{j.get('name')} ({' -> '.join(joint_ends(j))})" for j in cycle)
                raise ctx.error(label(cycle[0]), f"joints form a cycle: {steps}",
                                cycle[0].sourceline)
            walk.append(link)
            link = joint_ends(parent_joint[link])[0]
    roots = [name for name in links if name not in parent_joint]
    if len(roots) > 1:
        second = links[roots[1]]
        raise ctx.error(label(second), f"a second root: this link has no parent joint and link "
                        f"{roots[0]!r} (line {links[roots[0]].sourceline}) is already the root; "
                        f"a URDF is one tree (roots: {roots})", second.sourceline)


def fold_added_world(ctx: Context, links: dict[str, etree._Element],
                     joints: dict[str, etree._Element]) -> None:
    """Take out the ``world`` link and fixed joint our writer adds above a root part whose
    free bodies hang from it (``write.world_link``, both marked ``real2code:added``): the
    floating joints from ``world`` hang from that root part again, at the same origins.
    Marks that do not describe exactly that (an edited file) are warned about and the file
    is read as it stands. Changes ``links`` and ``joints`` (and the joints' <parent>)."""
    for name, link in list(links.items()):
        if link.get(ns(ADDED)) != "true":
            continue
        added = [el for el in joints.values()
                 if el.get(ns(ADDED)) == "true" and joint_ends(el)[0] == name]
        below = [el for el in joints.values() if joint_ends(el)[0] == name]
        fixed = added[0] if len(added) == 1 else None
        if (fixed is None or fixed.get("type") != "fixed" or len(link)
                or any(joint_ends(el)[1] == name for el in joints.values())
                or not _identity_origin(fixed)
                or any(el.get("type") != "floating" for el in below if el is not fixed)):
            ctx.warn(label(link), f"marked {PREFIX}:{ADDED} but not as our writer adds it (a "
                     "bare root link, one fixed joint at the origin to the root part, floating "
                     "joints): read as it stands", link.sourceline)
            continue
        root = joint_ends(fixed)[1]
        for el in below:
            if el is not fixed:
                el.find("parent").set("link", root)
        del links[name]
        del joints[fixed.get("name")]


def _identity_origin(joint: etree._Element) -> bool:
    origin = joint.find("origin")
    if origin is None:
        return True
    try:
        values = [float(v) for key in ("xyz", "rpy") for v in (origin.get(key) or "0 0 0").split()]
    except ValueError:
        return False
    return len(values) == 6 and not any(values)


def identifiers(ctx: Context, elements: dict[str, etree._Element]) -> dict[str, str]:
    """Raw name -> identifier; valid names are kept, so a repaired one never takes theirs."""
    taken = {raw for raw in elements if NAME_PATTERN.match(raw)}
    out = {}
    for raw in elements:
        out[raw] = raw if raw in taken else sanitize_name(raw, taken)
        if out[raw] != raw:
            ctx.note("renamed", f"{raw!r} -> {out[raw]!r}")
    return out
