"""What an MJCF file holds that the model has no place for (actuators other than the joint
drives the reader takes, :mod:`.actuator`; tendons, sensors, equality constraints other than
the mimics the reader takes, and the default classes those use), kept as the file writes
it, and written back by the MJCF writer.

The sections are read from the file itself (its ``<include>`` files inlined, as MuJoCo
inlines them) and stored in the object's metadata under :data:`ELEMENTS_KEY` (tag -> XML
text), which every format carries. Of ``<default>`` only what these sections use is kept
(the actuator and tendon defaults, every class by name): the model's own bodies, joints and
geoms are written with every value explicit. The writer puts them back and MuJoCo compiles
the result; an element MuJoCo refuses (it names a geom or class an export does not keep, a
name the reader changed) is left out of the file, stays in the metadata, and is warned about.
(MuJoCo's ``MjSpec.to_xml`` would give the sections too, but it writes the whole model,
seconds for a robot with large meshes.)
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from .. import FORMATS

ELEMENTS_KEY = FORMATS["mjcf"].kept_elements
KEPT_TAGS = ("actuator", "tendon", "sensor", "equality")
# what <default> keeps: the defaults of the actuator shortcuts and of tendons
DEFAULT_TAGS = frozenset({"general", "motor", "position", "velocity", "intvelocity", "damper",
                          "cylinder", "muscle", "adhesion", "tendon"})
WRITE_ORDER = ("default", "tendon", "equality", "actuator", "sensor")


def unread_sections(path: Path, mimics: set[tuple[str, str]],
                    renames: dict[str, str] | None = None,
                    moved: dict[str, np.ndarray] | None = None,
                    notes: list[str] | None = None,
                    drives: dict[int, str] | None = None,
                    drive_markers: bool = False) -> dict[str, str]:
    """Tag -> XML text of each kept section (the file's sections of that tag merged) that has
    something left once the joint equalities read as mimics, ``(joint1, joint2)`` as named
    in the file, and the actuators read as drives (``drives``: the actuator's index in the
    file -> the model joint it drives) are taken out; with them, the file's default classes
    (``default``). With ``drive_markers`` each drive's actuator leaves a comment
    (:func:`drive_marker`) where it stood, so that the writer puts it back in the file's
    order among the kept ones (an actuator's index is its ``ctrl`` index). The
    bodies, joints and sites they refer to are named as the model names them (``renames``:
    file name -> model name, for the names the reader changed); points given in the frame of
    a body whose part frame the reader moved (``moved``: file name -> part-from-body
    transform) are moved with it, and what cannot be is said in ``notes``."""
    from lxml import etree

    try:
        root = _inlined(path, etree)
    except (OSError, etree.XMLSyntaxError):  # MuJoCo read it: nothing of ours to report
        return {}
    out = {}
    drives = drives or {}
    for tag in KEPT_TAGS:
        merged = etree.Element(tag)
        index = 0  # the actuator's, in file order (MuJoCo numbers them so)
        for section in root.iter(tag):
            if section.getparent() is not root:
                continue
            for el in section:
                if not isinstance(el.tag, str):  # comments
                    continue
                if tag == "equality" and el.tag == "joint" and \
                        (el.get("joint1"), el.get("joint2")) in mimics:
                    continue
                if tag == "actuator":
                    index += 1
                    if index - 1 in drives:
                        if drive_markers:
                            merged.append(etree.Comment(drive_marker(drives[index - 1])))
                        continue
                merged.append(el)
        if any(isinstance(el.tag, str) for el in merged) or (
                tag == "actuator" and len(merged)):
            _follow_moved_bodies(merged, moved or {}, notes if notes is not None else [])
            _rename_references(merged, renames or {})
            out[tag] = _text(merged, etree)
    if out:
        defaults = etree.Element("default")
        for section in root.iterchildren("default"):
            for el in section:
                kept = _kept_default(el)
                if kept is not None:
                    defaults.append(kept)
        if len(defaults):
            out["default"] = _text(defaults, etree)
    return out


def drive_marker(joint: str) -> str:
    """The comment that stands for the drive of ``joint`` in a kept actuator section."""
    return f" real2code:drive {joint} "


def drive_of_marker(comment: str) -> str | None:
    """The joint a drive marker's text names, or None for another comment."""
    head, _, joint = comment.strip().partition(" ")
    return joint.strip() or None if head == "real2code:drive" else None


def _follow_moved_bodies(section, moved: dict[str, np.ndarray], notes: list[str]) -> None:
    """Equality anchors given in a moved body's frame (connect: body1's, weld: body2's) put in
    its part frame; a weld's relpose and a sensor of a moved body's frame are noted."""
    if not moved:
        return
    for el in section.iter():
        body = {"connect": el.get("body1"), "weld": el.get("body2")}.get(el.tag)
        if body in moved and el.get("anchor") is not None:
            point = np.array([float(v) for v in el.get("anchor").split()] + [1.0])
            el.set("anchor", " ".join(repr(float(v) + 0.0) for v in (moved[body] @ point)[:3]))
        if el.tag == "weld" and el.get("relpose") is not None and (
                el.get("body1") in moved or el.get("body2") in moved):
            notes.append(f"<weld> of {el.get('body1')!r} and {el.get('body2')!r}: relpose is "
                         "in the bodies' frames, which the model moves to their joints")
        if el.get("objtype") in ("body", "xbody") and el.get("objname") in moved:
            notes.append(f"<{el.tag}> of body {el.get('objname')!r}: the model moves the "
                         "body's frame to its joint's anchor; the export's sensor measures "
                         "that frame")


# attributes that name a body, joint or site (MJCF's reference attributes; objname and
# refname only with an objtype / reftype of those kinds)
_REFERENCES = frozenset({"joint", "joint1", "joint2", "jointinparent", "body", "body1",
                         "body2", "site", "site1", "site2", "refsite", "slidersite",
                         "sidesite"})
_TYPED = {"objname": "objtype", "refname": "reftype"}
_RENAMED_KINDS = frozenset({"body", "xbody", "joint", "site"})


def _rename_references(section, renames: dict[str, str]) -> None:
    """References to a renamed body, joint or site, given the model's name."""
    if not renames:
        return
    for el in section.iter():
        for attr, value in el.attrib.items():
            if value not in renames:
                continue
            typed = _TYPED.get(attr)
            if attr in _REFERENCES or (typed and el.get(typed) in _RENAMED_KINDS):
                el.set(attr, renames[value])


def _kept_default(el):
    """A copy of a default-section child with only the defaults :data:`DEFAULT_TAGS` (every
    nested class kept, empty or not: elements refer to it by name); None for the rest."""
    if not isinstance(el.tag, str):
        return None
    if el.tag in DEFAULT_TAGS:
        return _copy(el)
    if el.tag != "default":
        return None
    out = _copy(el, children=False)
    for child in el:
        kept = _kept_default(child)
        if kept is not None:
            out.append(kept)
    return out


def _copy(el, children: bool = True):
    from copy import deepcopy

    from lxml import etree

    return deepcopy(el) if children else etree.Element(el.tag, dict(el.attrib))


def _text(section, etree) -> str:
    etree.indent(section, space="  ")
    return etree.tostring(section, encoding="unicode")


def merge_sections(first: dict[str, str], second: dict[str, str]) -> dict[str, str]:
    """Both sets of sections, a tag's elements from ``first`` then from ``second``."""
    from lxml import etree

    out = dict(first)
    for tag, text in second.items():
        if tag not in out:
            out[tag] = text
            continue
        merged = etree.fromstring(out[tag])
        merged.extend(list(etree.fromstring(text)))
        out[tag] = _text(merged, etree)
    return out


def restore(text: str, sections: dict[str, str], compiles: Callable[[str], None],
            checked_text: str | None = None) -> tuple[str, dict[str, str], list[str]]:
    """``text`` (an MJCF file) with the kept sections written back, the elements MuJoCo
    refuses left out one by one: (the file, the sections left out, what was left out and
    why). ``compiles`` raises MuJoCo's ValueError; it is given ``checked_text`` (the same
    model made cheaper to compile, :func:`without_files`; default ``text``) with the
    sections in it."""
    from lxml import etree

    from .conventions import describe_mujoco_error

    root = etree.fromstring(text.encode("utf-8"))
    checked = etree.fromstring((checked_text or text).encode("utf-8"))
    inserted = []  # (tag, the element in the file, its copy in the checked model)
    for tag in WRITE_ORDER:
        if tag not in sections:
            continue
        target, checked_target = _section(root, tag, etree), _section(checked, tag, etree)
        for el in list(etree.fromstring(sections[tag])):
            copy = _copy(el)
            target.append(el)
            checked_target.append(copy)
            inserted.append((tag, el, copy))
    left: dict[str, list] = {}
    why = []
    for _ in range(len(inserted) + 1):
        etree.indent(checked, space="  ")
        candidate = etree.tostring(checked, encoding="unicode") + "\n"
        try:
            compiles(candidate)
            break
        except ValueError as e:
            message, _name, _tag, line = describe_mujoco_error(str(e))
            culprit = _element_at(checked, candidate, line, [c for *_, c in inserted], etree)
            if culprit is None:  # not one of ours to leave out: leave them all out
                why.append(f"all of them ({message})")
                dropped = list(inserted)
            else:
                dropped = [item for item in inserted if item[2] is culprit]
                tag, el, _ = dropped[0]
                why.append(f"<{tag}> <{el.tag}{_named(el)}> ({message})")
            for tag, el, copy in dropped:
                left.setdefault(tag, []).append(el)
                el.getparent().remove(el)
                copy.getparent().remove(copy)
            inserted = [item for item in inserted if item not in dropped]
    leftover = {}
    for tag, elements in left.items():
        section = etree.Element(tag)
        section.extend(elements)
        leftover[tag] = _text(section, etree)
    etree.indent(root, space="  ")  # the same text whatever the sections' own layout
    return etree.tostring(root, encoding="unicode") + "\n", leftover, why


def _section(root, tag: str, etree):
    """Where kept elements of ``tag`` go: the file's <default>, or a new section at the end."""
    if tag == "default":
        target = root.find("default")
        if target is None:
            target = etree.Element("default")
            root.insert(1, target)
        return target
    return etree.SubElement(root, tag)


def without_files(text: str) -> str:
    """The model with no mesh or image file to read (mesh geoms as small spheres, textures
    left out): what the kept sections name (joints, bodies, sites, tendons, classes) is all
    there, and MuJoCo checks them in a fraction of the compile (no hulls, no decoding)."""
    from lxml import etree

    root = etree.fromstring(text.encode("utf-8"))
    for asset in root.iter("asset"):
        for el in [e for e in asset if e.tag in ("mesh", "texture", "hfield")]:
            asset.remove(el)
        for material in asset.iter("material"):
            material.attrib.pop("texture", None)
            for layer in list(material):
                material.remove(layer)
    for geom in root.iter("geom"):
        if geom.get("mesh") is not None:
            del geom.attrib["mesh"]
            geom.set("type", "sphere")
            geom.set("size", "0.001")
    return etree.tostring(root, encoding="unicode")


def _named(el) -> str:
    name = el.get("name") or el.get("class")
    return f" name='{name}'" if el.get("name") else (f" class='{name}'" if name else "")


def _element_at(root, text: str, line: int | None, candidates: list, etree):
    """The kept element (one of ``candidates``) whose subtree holds line ``line`` of ``text``
    (the serialisation of ``root``)."""
    if line is None:
        return None
    reparsed = etree.fromstring(text.encode("utf-8"))
    originals = list(root.iter())
    at = next((k for k, el in enumerate(reparsed.iter()) if el.sourceline == line), None)
    if at is None:
        return None
    element = originals[at]
    ids = {id(c) for c in candidates}
    while element is not None and id(element) not in ids:
        element = element.getparent()
    return element


def _inlined(path: Path, etree):
    """The file's <mujoco> element with every <include file=...> replaced by the included
    file's children (paths relative to the main file's folder, as MuJoCo resolves them)."""
    parser = etree.XMLParser(remove_comments=True, resolve_entities=False, no_network=True)
    root = etree.parse(str(path), parser).getroot()
    folder = path.parent
    for _ in range(16):  # includes of includes, to a depth no real model reaches
        includes = list(root.iter("include"))
        if not includes:
            break
        for inc in includes:
            included = etree.parse(str(folder / inc.get("file", "")), parser).getroot()
            parent = inc.getparent()
            at = parent.index(inc)
            parent.remove(inc)
            for k, child in enumerate(list(included)):
                parent.insert(at + k, child)
    return root
