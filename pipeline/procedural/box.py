"""Boxes: an open container (bottom and four walls) with a lid hinged on the back top edge.

The lid is flat, or skirted (a lip down the front and sides, outside the walls, none at the
back where it would hit the back wall when opening), sometimes with a pull tab at the front.
"""

from __future__ import annotations

import numpy as np

from ._build import (
    DENSITY,
    Assembly,
    Box,
    Primitive,
    choice,
    make_part,
    pick_color,
    revolute,
    uniform,
)

PART_RANGE = (2, 2)
WALLS = {"cardboard": (0.003, 0.006), "wood": (0.008, 0.015), "plastic": (0.002, 0.004)}


def build(rng: np.random.Generator, n_parts: int) -> Assembly:
    material = choice(rng, ("cardboard", "wood", "plastic"))
    density = DENSITY[material]
    width = uniform(rng, 0.12, 0.6)  # along y
    depth = uniform(rng, 0.1, 0.45)  # along x
    height = uniform(rng, 0.05, 0.35)
    tw = uniform(rng, *WALLS[material])
    tl = tw * uniform(rng, 1.0, 1.5)
    gap = uniform(rng, 0.0015, 0.003)
    x0, x1, y0, y1 = -depth / 2, depth / 2, -width / 2, width / 2

    def panel(lo, hi) -> Box:
        return Box(lo, hi, density)

    body: list[Primitive] = [
        panel((x0, y0, 0.0), (x1, y1, tw)),
        panel((x0, y0, tw), (x0 + tw, y1, height)),
        panel((x1 - tw, y0, tw), (x1, y1, height)),
        panel((x0 + tw, y0, tw), (x1 - tw, y0 + tw, height)),
        panel((x0 + tw, y1 - tw, tw), (x1 - tw, y1, height)),
    ]

    skirted = bool(rng.random() < 0.5)
    clearance = uniform(rng, 0.0015, 0.003)
    over = tl + clearance if skirted else uniform(rng, 0.0, 0.008)
    hinge = np.array([x0 - over, 0.0, height])
    lx0, lx1, ly0, ly1 = x0 - over, x1 + over, y0 - over, y1 + over
    lz0, lz1 = height + gap, height + gap + tl
    lid: list[Primitive] = [panel((lx0, ly0, lz0), (lx1, ly1, lz1))]
    if skirted:
        lip = uniform(rng, 0.01, min(0.05, 0.4 * height))
        lid += [
            panel((lx1 - tl, ly0, lz0 - lip), (lx1, ly1, lz0)),
            panel((lx0, ly0, lz0 - lip), (lx1 - tl, ly0 + tl, lz0)),
            panel((lx0, ly1 - tl, lz0 - lip), (lx1 - tl, ly1, lz0)),
        ]
    tab = bool(rng.random() < 0.5)
    if tab:
        half = uniform(rng, 0.015, 0.03)
        lid.append(panel((lx1, -half, lz0), (lx1 + uniform(rng, 0.008, 0.015), half, lz1)))

    swatch, color = pick_color(rng, material)
    out = Assembly(style={"material": material, "lid": "skirted" if skirted else "flat",
                          "tab": tab, "color": swatch, "size": [depth, width, height]})
    out.add(make_part("body", body, np.zeros(3), color), "body")
    joint = revolute(rng, "lid_hinge", "lid", hinge, (0.0, -1.0, 0.0), uniform(rng, 1.75, 2.5),
                     damping=uniform(rng, 0.005, 0.05), friction=uniform(rng, 0.01, 0.1), effort=5.0)
    out.add(make_part("lid", lid, hinge, color), "lid", joint, "back")
    return out
