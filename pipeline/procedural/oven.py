"""Ovens: a free-standing range (cooktop on top, sometimes a storage drawer below) or a
built-in wall oven, with a drop-down door, shelves inside and control knobs.

The door covers the cavity's front and hinges at its bottom front edge, opening down to
about horizontal; it carries a window and a bar along its top. Wire shelves slide out of
the cavity on rails. Knobs sit in a row on a control strip above the door or, on a range,
on a backguard rising behind the cooktop; each turns about its own axis (the front normal).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ._build import (
    DENSITY,
    Assembly,
    Box,
    Cylinder,
    Primitive,
    choice,
    make_part,
    pick_color,
    prismatic,
    revolute,
    shell,
    uniform,
)
from ._fronts import (
    door,
    door_dynamics,
    drawer,
    drawer_dynamics,
    front_style,
    knob,
    knob_dynamics,
    rack_dynamics,
    wire_rack,
)

PART_RANGE = (2, 12)  # the body and the door, then a drawer, up to two shelves, knobs
MAX_KNOBS = {"range": 8, "wall": 6}
MAX_SHELVES = 2
SHELF_COLOR = (0.45, 0.45, 0.46, 1.0)  # chromed steel, linear RGBA


def _counts(rng: np.random.Generator, n_parts: int) -> tuple[str, int, int, int]:
    """The kind of oven and how many drawers, shelves and knobs its extra parts are."""
    extra = n_parts - 2
    kind = "range" if extra > MAX_KNOBS["wall"] + MAX_SHELVES else \
        choice(rng, ("range", "wall"), p=[0.65, 0.35])
    drawers = 1 if kind == "range" and extra >= 1 and rng.random() < 0.4 else 0
    shelves = int(rng.integers(0, min(MAX_SHELVES, extra - drawers) + 1))
    shelves = max(shelves, extra - drawers - MAX_KNOBS[kind])
    return kind, drawers, shelves, extra - drawers - shelves


def build(rng: np.random.Generator, n_parts: int) -> Assembly:
    kind, n_drawers, n_shelves, n_knobs = _counts(rng, n_parts)
    if kind == "range":
        width, top, depth = uniform(rng, 0.5, 0.77), uniform(rng, 0.85, 0.93), uniform(rng, 0.56, 0.66)
        control = choice(rng, ("front", "back")) if n_knobs else "front"
    else:
        width, top, depth = uniform(rng, 0.55, 0.6), uniform(rng, 0.56, 0.6), uniform(rng, 0.53, 0.57)
        control = "front"
    tw = uniform(rng, 0.025, 0.04)  # insulated walls
    style = front_style(rng, thickness=(0.04, 0.06), density=DENSITY["insulated"], shaker_p=0.0,
                        bar_length=(0.35, 0.6))
    style = dataclasses.replace(style, handle=choice(rng, ("bar", "pull"), p=[0.85, 0.15]),
                                standoff=uniform(rng, 0.03, 0.045))
    gap = uniform(rng, 0.003, 0.006)  # between the body's front and the door
    xb = -depth / 2
    xf = depth / 2 - style.thickness - gap  # the body's front plane
    wall = DENSITY["insulated"]
    yl, yr = -width / 2 + tw, width / 2 - tw

    # Heights, bottom up: a kick (or the drawer), the door, the control strip, the cooktop.
    kick = uniform(rng, 0.02, 0.06) if kind == "range" else uniform(rng, 0.02, 0.04)
    drawer_h = uniform(rng, 0.12, 0.18) if n_drawers else 0.0
    if kind == "range" and not n_drawers:
        kick += uniform(rng, 0.06, 0.12)  # a plinth panel where no drawer is
    cook = uniform(rng, 0.02, 0.035) if kind == "range" else 0.0
    strip = uniform(rng, 0.07, 0.11) if control == "front" else uniform(rng, 0.015, 0.03)
    z_door0 = kick + drawer_h + gap
    z_door1 = top - cook - strip
    zc0 = kick + drawer_h + tw  # the cavity
    zc1 = z_door1 - uniform(rng, 0.03, 0.05)

    body: list[Primitive] = shell((xb, -width / 2, zc0 - tw), (xf, width / 2, zc1 + tw), tw, wall,
                                  "front")
    body += [
        Box((xb, -width / 2, 0.0), (xf, width / 2, kick), wall),  # the kick or plinth
        Box((xb, -width / 2, zc1 + tw), (xf, width / 2, top - cook), wall),  # the control block
    ]
    if n_drawers:  # the drawer's compartment, between the kick and the cavity
        body += [
            Box((xb, -width / 2, kick), (xf, yl, kick + drawer_h), wall),
            Box((xb, yr, kick), (xf, width / 2, kick + drawer_h), wall),
            Box((xb, yl, kick), (xb + tw, yr, kick + drawer_h), wall),
        ]
    if cook:
        body.append(Box((xb, -width / 2, top - cook), (xf, width / 2, top), DENSITY["glass"]))
        for sx in (-1, 1):  # four burners
            for sy in (-1, 1):
                r = uniform(rng, 0.05, 0.09)
                c = (sx * (depth / 4) - 0.02, sy * width / 4, top + 0.002)
                body.append(Cylinder(c, 2, r, 0.004, DENSITY["steel"]))
    if control == "back":
        guard_h, guard_t = uniform(rng, 0.1, 0.18), uniform(rng, 0.04, 0.07)
        body.append(Box((xb, -width / 2, top), (xb + guard_t, width / 2, top + guard_h), wall))
        knob_face, knob_z, knob_room = xb + guard_t, top + guard_h / 2, guard_h
    else:
        knob_face, knob_z, knob_room = xf, 0.5 * (z_door1 + top - cook), strip

    # Shelves on rails, evenly up the cavity.
    bar = uniform(rng, 0.005, 0.007)
    rx0, rx1 = xb + tw + uniform(rng, 0.02, 0.04), xf - uniform(rng, 0.02, 0.04)
    shelf_z = [zc0 + (k + 1) * (zc1 - zc0) / (n_shelves + 1) for k in range(n_shelves)]
    for z in shelf_z:
        for y0, y1 in ((yl, yl + 0.008), (yr - 0.008, yr)):
            body.append(Box((xb + tw, y0, z - 0.0015 - bar), (xf - 0.01, y1, z - 0.0015),
                            DENSITY["steel"]))

    swatch, color = pick_color(rng, "appliance")
    out = Assembly(style={"kind": kind, "control": control, "handle": style.handle,
                          "color": swatch, "size": [depth, width, top]})
    out.add(make_part("body", body, np.zeros(3), color), "body")

    g = style.gap
    hinged = door(style, -width / 2 + g, width / 2 - g, z_door0, z_door1 - g, xf + gap, "bottom",
                  hinge_at_front=True)
    face = xf + gap + style.thickness
    h = z_door1 - g - z_door0
    window = Box((face, -0.35 * width, z_door0 + 0.2 * h), (face + 0.002, 0.35 * width,
                                                           z_door0 + 0.7 * h), DENSITY["glass"])
    joint = revolute(rng, "door_0_hinge", "door_0", hinged.hinge, hinged.axis,
                     uniform(rng, 1.4, 1.6), **door_dynamics(rng))
    out.add(make_part("door_0", [*hinged.primitives, window], hinged.hinge, color), "door", joint,
            "bottom")
    if n_drawers:
        slide = drawer(rng, style, yl, yr, kick, kick + drawer_h, xf, xf - xb - tw)
        joint = prismatic(rng, "drawer_0_slide", "drawer_0", slide.rest,
                          uniform(rng, 0.6, 0.85) * slide.depth, **drawer_dynamics(rng))
        out.add(make_part("drawer_0", slide.primitives, slide.rest, color), "drawer", joint)
    for k, z in enumerate(reversed(shelf_z)):  # top to bottom
        name = f"rack_{k}"
        rest = np.array([rx1, 0.0, z])
        joint = prismatic(rng, f"{name}_slide", name, rest, uniform(rng, 0.4, 0.6) * (rx1 - rx0),
                          **rack_dynamics(rng))
        out.add(make_part(name, wire_rack(rx0, rx1, yl + 0.0015, yr - 0.0015, z, bar,
                                          int(rng.integers(4, 9))), rest, SHELF_COLOR), "rack",
                joint)
    if n_knobs:
        margin = uniform(rng, 0.06, 0.1)
        ys = np.linspace(-width / 2 + margin, width / 2 - margin, n_knobs) if n_knobs > 1 else \
            np.array([width / 2 - margin])
        spacing = (width - 2 * margin) / max(1, n_knobs - 1)
        radius = min(uniform(rng, 0.015, 0.025), 0.4 * knob_room, 0.4 * spacing)
        length = uniform(rng, 0.02, 0.03)
        _, knob_color = pick_color(rng, "plastic")
        for k, y in enumerate(ys):
            name = f"knob_{k}"
            turned = knob(knob_face, float(y), knob_z, radius, length)
            joint = revolute(rng, f"{name}_hinge", name, turned.hinge, turned.axis,
                             uniform(rng, 4.0, 5.5), **knob_dynamics(rng))
            out.add(make_part(name, turned.primitives, turned.hinge, knob_color), "knob", joint)
    return out

