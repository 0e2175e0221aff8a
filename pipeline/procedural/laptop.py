"""Laptops: a base with keyboard and touchpad, and a screen lid hinged at the back edge.

Closed (q = 0), the lid lies on the base with a small gap; it opens upward about the hinge
line along the base's top back edge.
"""

from __future__ import annotations

import numpy as np

from ._build import (
    DENSITY,
    Assembly,
    Box,
    Cylinder,
    Primitive,
    make_part,
    pick_color,
    revolute,
    uniform,
)

PART_RANGE = (2, 2)
KEY_RELIEF = 0.0005  # keyboard and display stand this far proud of their surfaces


def build(rng: np.random.Generator, n_parts: int) -> Assembly:
    width = uniform(rng, 0.28, 0.40)  # along y
    depth = width * uniform(rng, 0.62, 0.72)  # along x
    tb = uniform(rng, 0.012, 0.024)  # base thickness
    tl = uniform(rng, 0.004, 0.009)  # lid thickness
    gap = uniform(rng, 0.0018, 0.003)  # between the base and the closed lid
    bezel = uniform(rng, 0.006, 0.015)
    has_feet = bool(rng.random() < 0.6)
    foot = 0.002 if has_feet else 0.0
    base_d, lid_d = DENSITY["laptop_base"], DENSITY["laptop_lid"]
    x0, x1 = -depth / 2, depth / 2
    top = foot + tb

    body: list[Primitive] = [Box((x0, -width / 2, foot), (x1, width / 2, top), base_d)]
    if has_feet:
        for sx in (-1, 1):
            for sy in (-1, 1):
                c = (sx * (depth / 2 - 0.03), sy * (width / 2 - 0.03), foot / 2)
                body.append(Cylinder(c, 2, 0.006, foot, DENSITY["plastic"]))
    kx0 = x0 + uniform(rng, 0.015, 0.03)
    kx1 = kx0 + depth * uniform(rng, 0.42, 0.5)
    margin = uniform(rng, 0.012, 0.03)
    body.append(Box((kx0, -width / 2 + margin, top), (kx1, width / 2 - margin, top + KEY_RELIEF),
                    base_d))
    pad_w = width * uniform(rng, 0.25, 0.4) / 2
    pad_x1 = min(x1 - 0.01, kx1 + 0.012 + depth * uniform(rng, 0.25, 0.35))
    body.append(Box((kx1 + 0.012, -pad_w, top), (pad_x1, pad_w, top + KEY_RELIEF / 2), base_d))

    # The lid in the object frame, closed; its frame is the hinge at the top back edge.
    hinge = np.array([x0, 0.0, top])
    z_disp = top + gap
    lid: list[Primitive] = [
        Box((x0 + bezel, -width / 2 + bezel, z_disp), (x1 - bezel, width / 2 - bezel,
                                                        z_disp + KEY_RELIEF), lid_d),
        Box((x0, -width / 2, z_disp + KEY_RELIEF), (x1, width / 2, z_disp + KEY_RELIEF + tl), lid_d),
    ]
    swatch, color = pick_color(rng, "laptop")
    out = Assembly(style={"color": swatch, "feet": has_feet, "size": [depth, width, top + gap + tl]})
    out.add(make_part("body", body, np.zeros(3), color), "body")
    # Laptop hinges are friction hinges: they hold the screen where it is left.
    joint = revolute(rng, "screen_hinge", "screen", hinge, (0.0, -1.0, 0.0), uniform(rng, 1.9, 2.5),
                     damping=uniform(rng, 0.01, 0.05), friction=uniform(rng, 0.2, 0.6), effort=5.0)
    out.add(make_part("screen", lid, hinge, color), "lid", joint, "back")
    return out
