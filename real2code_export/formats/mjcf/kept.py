"""What an MJCF file holds that the model has no place for (actuators, tendons, sensors,
equality constraints other than the mimics the reader takes), kept as the file writes it.

The sections are read from the file itself (its ``<include>`` files inlined, as MuJoCo
inlines them) and stored in the object's metadata under :data:`ELEMENTS_KEY` (tag -> XML
text), which every format carries. No writer writes them back: they name the file's own
bodies, sites and default classes, which an export does not keep. (MuJoCo's ``MjSpec.to_xml``
would give them too, but it writes the whole model, seconds for a robot with large meshes.)
"""

from __future__ import annotations

from pathlib import Path

ELEMENTS_KEY = "mjcf_elements"
KEPT_TAGS = ("actuator", "tendon", "sensor", "equality")


def unread_sections(path: Path, mimics: set[tuple[str, str]]) -> dict[str, str]:
    """Tag -> XML text of each kept section (the file's sections of that tag merged) that has
    something left once the joint equalities read as mimics, ``(joint1, joint2)`` as named
    in the file, are taken out."""
    from lxml import etree

    try:
        root = _inlined(path, etree)
    except (OSError, etree.XMLSyntaxError):  # MuJoCo read it: nothing of ours to report
        return {}
    out = {}
    for tag in KEPT_TAGS:
        merged = etree.Element(tag)
        for section in root.iter(tag):
            if section.getparent() is not root:
                continue
            for el in section:
                if not isinstance(el.tag, str):  # comments
                    continue
                if tag == "equality" and el.tag == "joint" and \
                        (el.get("joint1"), el.get("joint2")) in mimics:
                    continue
                merged.append(el)
        if len(merged):
            etree.indent(merged, space="  ")
            out[tag] = etree.tostring(merged, encoding="unicode")
    return out


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
