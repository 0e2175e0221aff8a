"""Tables and desks: a top on four legs joined by aprons, with drawers under the top.

The drawers sit side by side in a housing (a bottom board and dividers) under the top at
the front, centred (a table) or against one end (a desk); the rest of the front is apron.
The top, legs, aprons and housing are the root part.
"""

from __future__ import annotations

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
    uniform,
)
from ._fronts import drawer, drawer_dynamics, front_style

PART_RANGE = (2, 5)  # the top with its legs, and one to four drawers


def build(rng: np.random.Generator, n_parts: int) -> Assembly:
    k = n_parts - 1
    width = float(min(2.0, max(uniform(rng, 0.8, 1.8), 0.36 * k + 0.3)))  # along y
    depth = uniform(rng, 0.5, 0.9)  # along x
    height = uniform(rng, 0.70, 0.78)
    tt = uniform(rng, 0.02, 0.04)  # top thickness
    over = uniform(rng, 0.015, 0.06)  # top overhang beyond the legs
    leg = uniform(rng, 0.04, 0.07)
    round_legs = bool(rng.random() < 0.3)
    ta = uniform(rng, 0.018, 0.025)  # apron boards
    ah = uniform(rng, 0.10, 0.16)  # apron height: the drawers' opening
    tdv = uniform(rng, 0.015, 0.02)  # drawer dividers
    tbb = uniform(rng, 0.008, 0.015)  # board the drawers run on
    density = DENSITY["wood"]

    zt = height - tt  # under the top
    zb = zt - ah  # on the drawer board
    xf = depth / 2 - over  # the front plane: outer faces of the front legs and aprons
    yl = width / 2 - over  # outer faces of the side legs
    yi = yl - leg  # inner faces of the legs

    def board(lo, hi) -> Box:
        return Box(lo, hi, density)

    body: list[Primitive] = [board((-depth / 2, -width / 2, zt), (depth / 2, width / 2, height))]
    for sx in (-1, 1):
        for sy in (-1, 1):
            cx, cy = sx * (xf - leg / 2), sy * (yl - leg / 2)
            if round_legs:
                body.append(Cylinder((cx, cy, zt / 2), 2, leg / 2, zt, density))
            else:
                body.append(board((cx - leg / 2, cy - leg / 2, 0.0), (cx + leg / 2, cy + leg / 2, zt)))
    body += [
        board((-xf, -yi, zb), (-xf + ta, yi, zt)),  # back apron
        board((-(xf - leg), -yl, zb), (xf - leg, -yl + ta, zt)),  # side aprons
        board((-(xf - leg), yl - ta, zb), (xf - leg, yl, zt)),
    ]
    if rng.random() < 0.3:  # a low shelf between the legs
        z = uniform(rng, 0.1, 0.2)
        body.append(board((-(xf - leg), -yi, z), (xf - leg, yi, z + 0.018)))

    # The drawer housing: k openings between k + 1 dividers, on a bottom board.
    drawer_w = uniform(rng, 0.3, 0.5)
    zone = min(k * drawer_w + (k + 1) * tdv, 2 * yi)
    place = choice(rng, ("centre", "left", "right"), p=[0.6, 0.2, 0.2])
    y0 = {"centre": -zone / 2, "left": -yi, "right": yi - zone}[place]
    y1 = y0 + zone
    if y0 + yi < 0.01:  # no sliver of apron beside the housing
        y0 = -yi
    if yi - y1 < 0.01:
        y1 = yi
    body.append(board((-xf + ta, y0, zb - tbb), (xf, y1, zb)))
    opening = (y1 - y0 - (k + 1) * tdv) / k
    edges = [y0 + i * (opening + tdv) for i in range(k + 1)]
    body += [board((-xf + ta, e, zb), (xf, e + tdv, zt)) for e in edges]
    if y0 > -yi:
        body.append(board((xf - ta, -yi, zb), (xf, y0, zt)))
    if y1 < yi:
        body.append(board((xf - ta, y1, zb), (xf, yi, zt)))

    material = choice(rng, ("wood", "paint"), p=[0.7, 0.3])
    swatch, color = pick_color(rng, material)
    style = front_style(rng)
    out = Assembly(style={"legs": "round" if round_legs else "square", "drawers": place,
                          "handle": style.handle, "color": swatch,
                          "size": [depth, width, height]})
    out.add(make_part("body", body, np.zeros(3), color), "body")
    for i, e in enumerate(edges[:-1]):
        name = f"drawer_{i}"
        slide = drawer(rng, style, e + tdv, e + tdv + opening, zb, zt, xf, 2 * xf - ta)
        joint = prismatic(rng, f"{name}_slide", name, slide.rest,
                          uniform(rng, 0.6, 0.85) * slide.depth, **drawer_dynamics(rng))
        out.add(make_part(name, slide.primitives, slide.rest, color), "drawer", joint)
    return out
