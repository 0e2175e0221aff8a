"""Refrigerators: an insulated cabinet on levelling feet with one or two overlay doors.

Two doors are a freezer on top, a freezer below, or side by side (freezer on the left).
Overlay doors cover the cabinet's front and hinge at their back outer corner, so they swing
out past the cabinet's side. Inside: a compartment divider and glass shelves.
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
    uniform,
)
from ._fronts import door, door_dynamics, front_style

PART_RANGE = (2, 3)


def build(rng: np.random.Generator, n_parts: int) -> Assembly:
    layout = "single" if n_parts == 2 else choice(
        rng, ("top_freezer", "bottom_freezer", "side_by_side"), p=[0.4, 0.35, 0.25])
    width = uniform(rng, 0.85, 0.95) if layout == "side_by_side" else uniform(rng, 0.5, 0.8)
    height = uniform(rng, 0.8, 1.9) if layout == "single" else uniform(rng, 1.5, 1.95)
    body_depth = uniform(rng, 0.5, 0.68)
    tw = uniform(rng, 0.035, 0.06)  # insulated walls
    feet = uniform(rng, 0.015, 0.04)
    style = front_style(rng, thickness=(0.04, 0.07), density=DENSITY["insulated"], shaker_p=0.0,
                        bar_length=(0.2, 0.6))
    style = dataclasses.replace(style, handle=choice(rng, ("bar", "pull"), p=[0.8, 0.2]),
                                standoff=uniform(rng, 0.03, 0.045))
    front_gap = uniform(rng, 0.003, 0.006)  # between the cabinet and the doors
    door_gap = uniform(rng, 0.004, 0.008)  # between two doors
    total_depth = body_depth + front_gap + style.thickness
    xb, xf = -total_depth / 2, total_depth / 2 - style.thickness - front_gap
    yl, yr = -width / 2 + tw, width / 2 - tw
    wall = DENSITY["insulated"]

    def panel(lo, hi) -> Box:
        return Box(lo, hi, wall)

    body: list[Primitive] = [
        panel((xb, -width / 2, feet), (xf, yl, height)),
        panel((xb, yr, feet), (xf, width / 2, height)),
        panel((xb, yl, feet), (xf, yr, feet + tw)),
        panel((xb, yl, height - tw), (xf, yr, height)),
        panel((xb, yl, feet + tw), (xb + tw, yr, height - tw)),
    ]
    radius = uniform(rng, 0.015, 0.025)
    for sx in (-1, 1):
        for sy in (-1, 1):
            c = (sx * (total_depth / 2 - 0.1), sy * (width / 2 - 0.06), feet / 2)
            c = (min(c[0], xf - 0.05), c[1], c[2])
            body.append(Cylinder(c, 2, radius, feet, DENSITY["steel"]))

    # Compartments: (y0, y1, z0, z1) of each inner space, fresh food first.
    zi0, zi1 = feet + tw, height - tw
    shelf_front = xf - uniform(rng, 0.02, 0.05)
    doors: list[tuple[float, float, float, float]] = []  # y0, y1, z0, z1 of each door
    if layout == "single":
        spaces = [(yl, yr, zi0, zi1)]
        doors.append((-width / 2, width / 2, feet, height))
    elif layout == "side_by_side":
        ys = -width / 2 + uniform(rng, 0.38, 0.45) * width
        body.append(panel((xb + tw, ys - tw / 2, zi0), (xf, ys + tw / 2, zi1)))
        spaces = [(ys + tw / 2, yr, zi0, zi1), (yl, ys - tw / 2, zi0, zi1)]
        doors += [(-width / 2, ys - door_gap / 2, feet, height),
                  (ys + door_gap / 2, width / 2, feet, height)]
    else:
        share = uniform(rng, 0.25, 0.33) if layout == "top_freezer" else uniform(rng, 0.3, 0.4)
        zs = height - share * (height - feet) if layout == "top_freezer" else \
            feet + share * (height - feet)
        body.append(panel((xb + tw, yl, zs - tw / 2), (xf, yr, zs + tw / 2)))
        below, above = (yl, yr, zi0, zs - tw / 2), (yl, yr, zs + tw / 2, zi1)
        spaces = [below, above] if layout == "top_freezer" else [above, below]
        doors += [(-width / 2, width / 2, zs + door_gap / 2, height),
                  (-width / 2, width / 2, feet, zs - door_gap / 2)]
    n_shelves = [int(rng.integers(2, 5))] + [1] * (len(spaces) - 1)
    for (y0, y1, z0, z1), n in zip(spaces, n_shelves, strict=True):
        for j in range(n):
            z = z0 + (j + 1) * (z1 - z0) / (n + 1)
            body.append(Box((xb + tw, y0, z - 0.003), (shelf_front, y1, z + 0.003), DENSITY["glass"]))

    swatch, color = pick_color(rng, "appliance")
    door_swatch, door_color = (swatch, color) if rng.random() < 0.8 else \
        pick_color(rng, "appliance")
    if layout == "side_by_side":
        sides = ["left", "right"]
    else:
        sides = [choice(rng, ("left", "right"))] * len(doors)
    out = Assembly(style={"layout": layout, "handle": style.handle, "body_color": swatch,
                          "door_color": door_swatch, "size": [total_depth, width, height]})
    out.add(make_part("body", body, np.zeros(3), color), "body")
    for i, ((y0, y1, z0, z1), side) in enumerate(zip(doors, sides, strict=True)):
        name = f"door_{i}"
        hinged = door(style, y0, y1, z0, z1, xf + front_gap, side, hinge_at_front=False)
        joint = revolute(rng, f"{name}_hinge", name, hinged.hinge, hinged.axis,
                         uniform(rng, 1.7, 2.1), **door_dynamics(rng))
        out.add(make_part(name, hinged.primitives, hinged.hinge, door_color), "door", joint, side)
    return out
