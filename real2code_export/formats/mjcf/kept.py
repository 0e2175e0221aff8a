"""What an MJCF file holds that the model has no place for (actuators, tendons, sensors,
equality constraints other than the mimics the reader takes), kept as MuJoCo writes it.

The sections are taken from MuJoCo's own XML of the compiled spec (``MjSpec.to_xml``:
includes resolved, every name as in the file) and stored in the object's metadata under
:data:`ELEMENTS_KEY` (tag -> XML text), which every format carries. No writer writes them
back: they name the file's own bodies, sites and classes, which an export does not keep.
"""

from __future__ import annotations

ELEMENTS_KEY = "mjcf_elements"
KEPT_TAGS = ("actuator", "tendon", "sensor", "equality")


def unread_sections(spec, mimics: set[tuple[str, str]]) -> dict[str, str]:
    """Tag -> XML text of each kept section that has something left once the joint
    equalities read as mimics, ``(joint1, joint2)`` as named in the file, are taken out."""
    from lxml import etree

    try:
        root = etree.fromstring(spec.to_xml().encode("utf-8"))
    except (ValueError, etree.XMLSyntaxError):  # MuJoCo cannot write this spec back
        return {}
    out = {}
    for tag in KEPT_TAGS:
        section = root.find(tag)
        if section is None:
            continue
        for el in list(section):
            if tag == "equality" and el.tag == "joint" and \
                    (el.get("joint1"), el.get("joint2")) in mimics:
                section.remove(el)
        if len(section):
            etree.indent(section, space="  ")
            out[tag] = etree.tostring(section, encoding="unicode", with_tail=False)
    return out
