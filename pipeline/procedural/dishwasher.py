"""Dishwashers: an under-counter tub on a recessed kick, a full-height door hinged at its
bottom front edge (it drops to horizontal), and up to three baskets inside that roll out
on rails: the lower basket, the upper basket and a shallow cutlery tray at the top.

The door carries the handle along its top (a bar, or a pull under a control strip).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ._build import (
    DENSITY,
    Assembly,
    Box,
    Primitive,
    choice,
    make_part,
    pick_color,
    prismatic,
    revolute,
    shell,
    uniform,
)
from ._fronts import door, door_dynamics, front_style, rack_dynamics

PART_RANGE = (2, 5)  # the tub and the door, and up to three baskets
BASKETS = ("lower", "upper", "cutlery")


def build(rng: np.random.Generator, n_parts: int) -> Assembly:
    n_baskets = n_parts - 2
    kinds = list(BASKETS[:n_baskets]) if n_baskets != 1 else [choice(rng, BASKETS[:2])]
    width = choice(rng, ("narrow", "full"), p=[0.25, 0.75])
    width = uniform(rng, 0.44, 0.46) if width == "narrow" else uniform(rng, 0.59, 0.61)
    height, depth = uniform(rng, 0.81, 0.87), uniform(rng, 0.55, 0.6)
    tw = uniform(rng, 0.02, 0.035)
    style = front_style(rng, thickness=(0.04, 0.06), density=DENSITY["insulated"], shaker_p=0.0,
                        bar_length=(0.25, 0.45))
    style = dataclasses.replace(style, handle=choice(rng, ("bar", "pull"), p=[0.6, 0.4]))
    gap = uniform(rng, 0.003, 0.006)
    xb = -depth / 2
    xf = depth / 2 - style.thickness - gap
    kick = uniform(rng, 0.08, 0.12)
    recess = uniform(rng, 0.04, 0.07)
    wall = DENSITY["insulated"]

    body: list[Primitive] = shell((xb, -width / 2, kick), (xf, width / 2, height), tw, wall, "front")
    body.append(Box((xb, -width / 2 + 0.01, 0.0), (xf - recess, width / 2 - 0.01, kick), wall))
    yl, yr = -width / 2 + tw, width / 2 - tw
    zl, zh = kick + tw, height - tw  # inside the tub

    swatch, color = pick_color(rng, "appliance")
    out = Assembly(style={"handle": style.handle, "color": swatch, "size": [depth, width, height]})
    # Each basket: its bottom and top as fractions of the tub's height, on rails.
    span = {"lower": (0.03, 0.3), "upper": (0.45, 0.7), "cutlery": (0.86, 0.96)}
    bx0, bx1 = xb + tw + uniform(rng, 0.02, 0.04), xf - uniform(rng, 0.02, 0.04)
    baskets = []
    for kind in reversed(kinds):  # top to bottom, as fronts are numbered
        f0, f1 = span[kind]
        z0, z1 = zl + f0 * (zh - zl), zl + f1 * (zh - zl)
        rail = 0.006
        for y0, y1 in ((yl, yl + rail), (yr - rail, yr)):  # the rails it rolls on
            body.append(Box((xb + tw, y0, z0 - 0.0015 - rail), (xf - 0.01, y1, z0 - 0.0015),
                            DENSITY["plastic"]))
        baskets.append((kind, z0, z1))
    out.add(make_part("body", body, np.zeros(3), color), "body")

    g = style.gap
    hinged = door(style, -width / 2 + g, width / 2 - g, kick + gap, height - g, xf + gap, "bottom",
                  hinge_at_front=True)
    joint = revolute(rng, "door_0_hinge", "door_0", hinged.hinge, hinged.axis,
                     uniform(rng, 1.45, 1.6), **door_dynamics(rng))
    out.add(make_part("door_0", hinged.primitives, hinged.hinge, color), "door", joint, "bottom")
    _, basket_color = pick_color(rng, "plastic")
    wire = uniform(rng, 0.004, 0.007)
    out.style["baskets"] = [kind for kind, *_ in baskets]
    for k, (_, z0, z1) in enumerate(baskets):
        name = f"rack_{k}"
        rest = np.array([bx1, 0.0, z0])
        prims = shell((bx0, yl + 0.0015, z0), (bx1, yr - 0.0015, z1), wire, DENSITY["plastic"], "top")
        joint = prismatic(rng, f"{name}_slide", name, rest, uniform(rng, 0.6, 0.85) * (bx1 - bx0),
                          **rack_dynamics(rng))
        out.add(make_part(name, prims, rest, basket_color), "rack", joint)
    return out
