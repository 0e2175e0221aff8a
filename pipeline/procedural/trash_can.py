"""Trash cans: an open bin with a lid hinged at its top back edge, or a butterfly lid (two
halves hinged at the left and right top edges), and sometimes a foot pedal at the bottom
front that turns down about its back edge.

Lids are skirted: a lip down the sides outside the walls (none along the hinge edge, where
it would hit the wall when opening).
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
    shell,
    uniform,
)

PART_RANGE = (2, 4)  # the bin, one lid or two halves, and a pedal


def _layout(rng: np.random.Generator, n_parts: int) -> tuple[str, bool]:
    """The lid ("single" or "butterfly") and whether there is a pedal."""
    if n_parts == 2:
        return "single", False
    if n_parts == 4:
        return "butterfly", True
    return ("single", True) if rng.random() < 0.6 else ("butterfly", False)


def _lid(x0, x1, y0, y1, z0, t, lip, density, lips: tuple[str, ...]) -> list[Primitive]:
    """A lid over [x0, x1] x [y0, y1] from z0 up by t, with a lip of depth ``lip`` hanging
    from each edge named in ``lips`` (``"front"``/``"back"``: +X/-X, ``"left"``/``"right"``:
    -Y/+Y); side lips run between the front and back ones."""
    prims: list[Primitive] = [Box((x0, y0, z0), (x1, y1, z0 + t), density)]
    xa = x0 + t if "back" in lips else x0
    xb = x1 - t if "front" in lips else x1
    edges = {
        "front": Box((x1 - t, y0, z0 - lip), (x1, y1, z0), density),
        "back": Box((x0, y0, z0 - lip), (x0 + t, y1, z0), density),
        "left": Box((xa, y0, z0 - lip), (xb, y0 + t, z0), density),
        "right": Box((xa, y1 - t, z0 - lip), (xb, y1, z0), density),
    }
    return prims + [edges[e] for e in lips]


def build(rng: np.random.Generator, n_parts: int) -> Assembly:
    lid_kind, pedal = _layout(rng, n_parts)
    material = choice(rng, ("plastic", "steel"), p=[0.6, 0.4])
    density = DENSITY[material] * (1.0 if material == "plastic" else 0.5)
    width = uniform(rng, 0.25, 0.45)  # along y
    depth = uniform(rng, 0.22, 0.4)  # along x
    height = uniform(rng, 0.3, 0.75)
    tw = uniform(rng, 0.003, 0.008) if material == "plastic" else uniform(rng, 0.001, 0.002)
    tl = uniform(rng, 0.004, 0.01)  # lid thickness
    gap = uniform(rng, 0.0015, 0.003)
    clearance = uniform(rng, 0.0015, 0.003)
    lip = uniform(rng, 0.01, min(0.05, 0.2 * height))
    x0, x1, y0, y1 = -depth / 2, depth / 2, -width / 2, width / 2
    body: list[Primitive] = shell((x0, y0, 0.0), (x1, y1, height), tw, density, "top")

    palette = "plastic" if material == "plastic" else "appliance"
    swatch, color = pick_color(rng, palette)
    out = Assembly(style={"material": material, "lid": lid_kind, "pedal": pedal, "color": swatch,
                          "size": [depth, width, height]})
    lids = []
    over = tl + clearance  # the lip stands this far outside the walls
    lz0 = height + gap
    if lid_kind == "single":  # no lip along the hinge, where it would hit the wall
        hinge = np.array([x0 - over, 0.0, height])
        prims = _lid(x0 - over, x1 + over, y0 - over, y1 + over, lz0, tl, lip, density,
                     ("front", "left", "right"))
        lids.append(("lid", prims, hinge, (0.0, -1.0, 0.0), "back"))
    else:  # halves meeting in the middle: lips at the front and back only
        mid = 0.5 * gap
        for name, (ya, yb), side, axis in (("lid_0", (y0 - over, -mid), "left", (1.0, 0.0, 0.0)),
                                           ("lid_1", (mid, y1 + over), "right", (-1.0, 0.0, 0.0))):
            hinge = np.array([0.0, ya if side == "left" else yb, height])
            prims = _lid(x0 - over, x1 + over, ya, yb, lz0, tl, lip, density, ("front", "back"))
            lids.append((name, prims, hinge, axis, side))
    if pedal:  # a pedal plate on a bracket, fixed to the bin's front at the bottom
        pw, pl = uniform(rng, 0.08, 0.16), uniform(rng, 0.05, 0.08)
        zp = uniform(rng, 0.05, 0.065)
        body.append(Box((x1, -pw / 2 - 0.012, zp - 0.012), (x1 + 0.01, -pw / 2 - 0.004, zp + 0.012),
                        DENSITY["steel"]))
        body.append(Box((x1, pw / 2 + 0.004, zp - 0.012), (x1 + 0.01, pw / 2 + 0.012, zp + 0.012),
                        DENSITY["steel"]))
    out.add(make_part("body", body, np.zeros(3), color), "body")
    for name, prims, hinge, axis, side in lids:
        joint = revolute(rng, f"{name}_hinge", name, hinge, axis, uniform(rng, 1.3, 1.75),
                         damping=uniform(rng, 0.005, 0.05), friction=uniform(rng, 0.01, 0.1),
                         effort=5.0)
        out.add(make_part(name, prims, hinge, color), "lid", joint, side)
    if pedal:
        hinge = np.array([x1 + 0.002, 0.0, zp - 0.006])  # its back bottom edge
        prims = [Box((x1 + 0.002, -pw / 2, zp - 0.006), (x1 + 0.002 + pl, pw / 2, zp + 0.006),
                     DENSITY["plastic"])]
        joint = revolute(rng, "pedal_hinge", "pedal", hinge, (0.0, 1.0, 0.0), uniform(rng, 0.25, 0.4),
                         damping=uniform(rng, 0.01, 0.05), friction=uniform(rng, 0.02, 0.1),
                         effort=20.0)
        _, pedal_color = pick_color(rng, "plastic")
        out.add(make_part("pedal", prims, hinge, pedal_color), "pedal", joint, "back")
    return out
