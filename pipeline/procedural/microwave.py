"""Microwave ovens: a countertop box on small feet, the cooking cavity on the left and a
control panel on the right; a side-hinged door over the cavity (hinged on the left, as
nearly all are), a glass turntable on the cavity floor and up to two dials on the panel.

The door is an overlay door with a dark window, hinged at its back outer corner so it
swings out past the side. The turntable and the dials turn about their own axes.
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
    revolute,
    shell,
    uniform,
)
from ._fronts import door, door_dynamics, front_style, knob, knob_dynamics

PART_RANGE = (2, 5)  # the body and the door, then a turntable and up to two dials


def build(rng: np.random.Generator, n_parts: int) -> Assembly:
    extra = n_parts - 2
    turntable = extra == 3 or (extra >= 1 and rng.random() < 0.7)
    n_knobs = extra - int(turntable)
    width, height, depth = uniform(rng, 0.45, 0.6), uniform(rng, 0.26, 0.36), uniform(rng, 0.33, 0.45)
    tw = uniform(rng, 0.012, 0.02)  # sheet steel over a frame
    feet = uniform(rng, 0.008, 0.015)
    style = front_style(rng, thickness=(0.025, 0.04), density=DENSITY["plastic"], shaker_p=0.0,
                        bar_length=(0.12, 0.22))
    style = dataclasses.replace(style, handle=choice(rng, ("bar", "pull"), p=[0.5, 0.5]))
    gap = uniform(rng, 0.002, 0.004)
    xb = -depth / 2
    xf = depth / 2 - style.thickness - gap
    panel_w = width * uniform(rng, 0.22, 0.3)  # the control panel on the right
    ys = width / 2 - panel_w  # the cavity's right wall
    steel = DENSITY["steel"] * 0.1  # thin sheet over air: a tenth of solid steel

    body: list[Primitive] = shell((xb, -width / 2, feet), (xf, ys, feet + height), tw, steel, "front")
    body += [
        Box((xb, ys, feet), (xf, width / 2, feet + tw), steel),  # under, over and behind
        Box((xb, ys, feet + height - tw), (xf, width / 2, feet + height), steel),
        Box((xb, width / 2 - tw, feet + tw), (xf, width / 2, feet + height - tw), steel),
        Box((xf - 0.015, ys, feet + tw), (xf, width / 2 - tw, feet + height - tw), steel),  # panel
    ]
    for sx in (-1, 1):
        for sy in (-1, 1):
            c = (sx * (depth / 2 - 0.05), sy * (width / 2 - 0.04), feet / 2)
            c = (min(c[0], xf - 0.03), c[1], c[2])
            body.append(Cylinder(c, 2, 0.01, feet, DENSITY["plastic"]))

    swatch, color = pick_color(rng, "appliance")
    side = "left" if rng.random() < 0.9 else "right"
    out = Assembly(style={"handle": style.handle, "hinge": side, "turntable": bool(turntable),
                          "color": swatch, "size": [depth, width, height + feet]})
    out.add(make_part("body", body, np.zeros(3), color), "body")

    g = style.gap
    hinged = door(style, -width / 2 + g, ys - g, feet + g, feet + height - g, xf + gap, side,
                  hinge_at_front=False)
    face = xf + gap + style.thickness
    dw, dh = ys - g - (-width / 2 + g), height - 2 * g
    y_win = (-width / 2 + 0.12 * dw, ys - 0.3 * dw) if side == "left" else \
        (-width / 2 + 0.3 * dw, ys - 0.12 * dw)
    window = Box((face, y_win[0], feet + 0.15 * dh), (face + 0.002, y_win[1], feet + 0.85 * dh),
                 DENSITY["glass"])
    joint = revolute(rng, "door_0_hinge", "door_0", hinged.hinge, hinged.axis,
                     uniform(rng, 1.6, 2.0), **door_dynamics(rng))
    out.add(make_part("door_0", [*hinged.primitives, window], hinged.hinge, color), "door", joint,
            side)
    if turntable:
        # A glass plate on a hub that rides on the cavity floor's roller ring.
        cx = 0.5 * (xb + tw + xf)
        cy = 0.5 * (-width / 2 + tw + ys - tw)
        radius = 0.5 * min(xf - xb - tw, ys - tw - (-width / 2 + tw)) - uniform(rng, 0.015, 0.03)
        floor = feet + tw
        hub, plate = uniform(rng, 0.01, 0.015), uniform(rng, 0.005, 0.007)
        centre = np.array([cx, cy, floor + 0.0015])
        prims = [Cylinder((cx, cy, floor + 0.0015 + hub / 2), 2, 0.03, hub, DENSITY["plastic"]),
                 Cylinder((cx, cy, floor + 0.0015 + hub + plate / 2), 2, radius, plate,
                          DENSITY["glass"])]
        joint = revolute(rng, "turntable_hinge", "turntable", centre, (0.0, 0.0, 1.0),
                         uniform(rng, 5.5, 6.2), damping=uniform(rng, 0.01, 0.05),
                         friction=uniform(rng, 0.01, 0.05), effort=2.0)
        out.add(make_part("turntable", prims, centre, (0.8, 0.85, 0.82, 1.0)), "turntable", joint)
    if n_knobs:
        radius = min(uniform(rng, 0.018, 0.026), 0.3 * panel_w)
        yk = ys + 0.5 * (panel_w - tw)
        zs = [feet + height * f for f in ((0.65, 0.35) if n_knobs == 2 else (0.5,))]
        for k, z in enumerate(zs):
            name = f"knob_{k}"
            turned = knob(xf, yk, z, radius, uniform(rng, 0.015, 0.025))
            joint = revolute(rng, f"{name}_hinge", name, turned.hinge, turned.axis,
                             uniform(rng, 4.0, 5.5), **knob_dynamics(rng))
            out.add(make_part(name, turned.primitives, turned.hinge, color), "knob", joint)
    return out
