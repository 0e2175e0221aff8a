"""Storage furniture: a carcass with a grid of bays holding doors and drawers.

The carcass (sides, top, bottom, back, dividers, shelves, a plinth or feet) is one root
part. Its front opening is cut into bays in two levels, columns then rows or rows then
columns, like most real cabinets, dressers, sideboards and wardrobes. Every bay but an
occasional open shelf holds one front: a drawer (short bays, mostly) or a door (tall
bays; wide, short ones sometimes get a top- or bottom-hinged flap). Side-hinged doors hinge
on the edge nearer the cabinet's side, so neighbours form double doors; a pair of doors
meeting in the middle of a row may share one bay without a divider between them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import pairwise

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
    uniform,
)
from ._fronts import door, door_dynamics, drawer, drawer_dynamics, front_style

PART_RANGE = (2, 15)
MIN_BAY_WIDTH = 0.2
MIN_BAY_HEIGHT = 0.1
MAX_ROWS = 6  # bays stacked in one column
MAX_COLUMNS = 4  # bays side by side in one row


@dataclass
class Bay:
    """A clear opening in the carcass front (object frame)."""

    y0: float
    y1: float
    z0: float
    z1: float
    kind: str = "open"  # "door", "drawer" or "open"
    side: str = ""  # a door's hinge side

    @property
    def width(self) -> float:
        return self.y1 - self.y0

    @property
    def height(self) -> float:
        return self.z1 - self.z0


def _compose(rng: np.random.Generator, total: int, groups: int, cap: int) -> list[int]:
    """``total`` bays spread over ``groups`` groups, each holding 1..``cap``."""
    counts = [1] * groups
    for _ in range(total - groups):
        open_groups = [i for i, c in enumerate(counts) if c < cap]
        counts[open_groups[int(rng.integers(len(open_groups)))]] += 1
    return counts


def _split(rng: np.random.Generator, start: float, stop: float, n: int, wall: float,
           minimum: float) -> list[tuple[float, float]]:
    """``n`` intervals filling [start, stop] with ``wall`` between neighbours, each at least
    ``minimum`` long: equal (like a stack of drawers) or of random sizes."""
    room = (stop - start) - (n - 1) * wall
    weights = np.ones(n) if rng.random() < 0.5 else rng.uniform(0.6, 1.6, n)
    sizes = minimum + (room - n * minimum) * weights / weights.sum()
    out, at = [], start
    for s in sizes:
        out.append((at, at + float(s)))
        at += float(s) + wall
    out[-1] = (out[-1][0], stop)  # no round-off gap at the end
    return out


def build(rng: np.random.Generator, n_parts: int) -> Assembly:
    fronts = n_parts - 1
    open_bays = 1 if fronts <= 13 and rng.random() < 0.2 else 0
    bays_total = fronts + open_bays
    columns_first = bool(rng.random() < 0.5)
    if columns_first:
        k = int(rng.integers(math.ceil(bays_total / MAX_ROWS), min(MAX_COLUMNS, bays_total) + 1))
        counts = _compose(rng, bays_total, k, MAX_ROWS)
        n_y, n_z = k, max(counts)
    else:
        k = int(rng.integers(math.ceil(bays_total / MAX_COLUMNS), min(MAX_ROWS, bays_total) + 1))
        counts = _compose(rng, bays_total, k, MAX_COLUMNS)
        n_y, n_z = max(counts), k

    # -- dimensions (m) --------------------------------------------------------------------
    t = uniform(rng, 0.015, 0.022)  # carcass panels
    tb = uniform(rng, 0.004, 0.010)  # back panel
    depth = uniform(rng, 0.32, 0.62)
    base = choice(rng, ("flush", "plinth", "feet"), p=[0.25, 0.45, 0.30])
    pb = {"flush": 0.0, "plinth": uniform(rng, 0.06, 0.12), "feet": uniform(rng, 0.08, 0.16)}[base]
    top_style = choice(rng, ("inset", "overlay"))
    tt = t if top_style == "inset" else uniform(rng, 0.02, 0.035)
    # Rows-first: a row with few bays has wide ones; keep those under about a metre.
    widest = 2.0 if columns_first else min(2.0, 2 * t + max(0.95 * min(counts), 0.25 * n_y))
    width = float(np.clip(n_y * uniform(rng, 0.30, 0.55) + 2 * t, 0.35, widest))
    row_h = uniform(rng, 0.16, 0.42) if rng.random() < 0.7 else uniform(rng, 0.35, 0.9)
    height = float(np.clip(pb + t + n_z * row_h + tt, 0.4, 2.0))

    x0, x1 = -depth / 2, depth / 2  # back and front planes
    yl, yr = -width / 2 + t, width / 2 - t  # inside the sides
    zb, zt = pb + t, height - tt  # on the bottom, under the top
    body_density = DENSITY["particleboard"]

    def board(lo, hi) -> Box:
        return Box(lo, hi, body_density)

    # -- bays ------------------------------------------------------------------------------
    rows_of_bays: list[list[Bay]] = []  # rows-first: bays per row, for pairing doors
    body: list[Primitive] = []
    dividers: dict[tuple[int, int], Box] = {}  # rows-first: (row, boundary) -> divider
    if columns_first:
        bays = []
        cols = _split(rng, yl, yr, k, t, MIN_BAY_WIDTH)
        for (ya, yb), n_rows in zip(cols, counts, strict=True):
            rows = _split(rng, zb, zt, n_rows, t, MIN_BAY_HEIGHT)
            bays += [Bay(ya, yb, za, zc) for za, zc in rows]
            body += [board((x0 + tb, ya, r0[1]), (x1, yb, r1[0])) for r0, r1 in pairwise(rows)]
        body += [board((x0 + tb, c0[1], zb), (x1, c1[0], zt)) for c0, c1 in pairwise(cols)]
    else:
        rows = _split(rng, zb, zt, k, t, MIN_BAY_HEIGHT)
        for r, ((za, zc), n_cols) in enumerate(zip(rows, counts, strict=True)):
            cols = _split(rng, yl, yr, n_cols, t, MIN_BAY_WIDTH)
            rows_of_bays.append([Bay(ya, yb, za, zc) for ya, yb in cols])
            for i, (c0, c1) in enumerate(pairwise(cols)):
                dividers[r, i] = board((x0 + tb, c0[1], za), (x1, c1[0], zc))
        body += [board((x0 + tb, yl, r0[1]), (x1, yr, r1[0])) for r0, r1 in pairwise(rows)]
        bays = [b for row in rows_of_bays for b in row]

    # -- what each bay holds ---------------------------------------------------------------
    p_drawer = uniform(rng, 0.15, 0.85)
    order = rng.permutation(len(bays))
    for i in order[:open_bays]:
        bays[int(i)].kind = "open"
    for i in order[open_bays:]:
        bay = bays[int(i)]
        if bay.width > 1.0 or bay.height > 0.5:
            bay.kind = "door"
        elif bay.height < 0.2:
            bay.kind = "drawer" if rng.random() < 0.9 else "door"
        else:
            bay.kind = "drawer" if rng.random() < p_drawer else "door"
        if bay.kind == "door":
            yc = 0.5 * (bay.y0 + bay.y1)
            if bay.width > 1.15 * bay.height and rng.random() < 0.6:
                # A drop-down flap (bottom hinge) only at desk height, where it can open.
                bay.side = "bottom" if bay.z0 > 0.3 and rng.random() < 0.5 else "top"
            elif abs(yc) > 0.01:
                bay.side = "left" if yc < 0 else "right"
            else:
                bay.side = choice(rng, ("left", "right"))
    # Double doors: a left- and a right-hinged door side by side may share one bay.
    for r, row in enumerate(rows_of_bays):
        for i, (a, b) in enumerate(pairwise(row)):
            if (a.kind, a.side, b.kind, b.side) == ("door", "left", "door", "right") \
                    and rng.random() < 0.7:
                divider = dividers.pop((r, i))
                a.y1 = b.y0 = 0.5 * (divider.lo[1] + divider.hi[1])
    body += list(dividers.values())

    # -- carcass ---------------------------------------------------------------------------
    style = front_style(rng)
    side_lo = pb if base == "feet" else 0.0
    side_hi = height if top_style == "inset" else height - tt
    body += [
        board((x0, -width / 2, side_lo), (x1, yl, side_hi)),
        board((x0, yr, side_lo), (x1, width / 2, side_hi)),
        board((x0, yl, pb), (x1, yr, zb)),  # bottom
        board((x0, yl, zb), (x0 + tb, yr, zt)),  # back
    ]
    if top_style == "inset":
        body.append(board((x0, yl, zt), (x1, yr, height)))
    else:
        side_over, front_over = uniform(rng, 0.0, 0.025), uniform(rng, 0.0, 0.025)
        body.append(board((x0, -width / 2 - side_over, zt), (x1 + front_over, width / 2 + side_over,
                                                             height)))
    if base == "plinth":
        recess = uniform(rng, 0.02, 0.06)
        body.append(board((x1 - recess - t, yl, 0.0), (x1 - recess, yr, pb)))
    elif base == "feet":
        size, inset, round_feet = uniform(rng, 0.03, 0.06), uniform(rng, 0.0, 0.04), rng.random() < 0.5
        for sx in (-1, 1):
            for sy in (-1, 1):
                cx = sx * (depth / 2 - inset - size / 2)
                cy = sy * (width / 2 - inset - size / 2)
                if round_feet:
                    body.append(Cylinder((cx, cy, pb / 2), 2, size / 2, pb, DENSITY["wood"]))
                else:
                    body.append(Box((cx - size / 2, cy - size / 2, 0.0),
                                    (cx + size / 2, cy + size / 2, pb), DENSITY["wood"]))
    for bay in bays:  # loose shelves behind tall doors and in open bays
        if bay.kind == "drawer" or bay.height <= 0.45:
            continue
        front = x1 - 0.02 - (style.thickness if bay.kind == "door" else 0.0)
        n = 1 if bay.height < 0.9 else 2
        for j in range(n):
            z = bay.z0 + (j + 1) * bay.height / (n + 1) - t / 2
            body.append(board((x0 + tb, bay.y0, z), (front, bay.y1, z + t)))

    material = choice(rng, ("wood", "paint"))
    body_swatch, body_color = pick_color(rng, material)
    if rng.random() < 0.5:
        front_swatch, front_color = body_swatch, body_color
    else:
        front_swatch, front_color = pick_color(rng, choice(rng, ("wood", "paint")))
    out = Assembly(style={
        "layout": "columns" if columns_first else "rows", "bays": len(bays), "base": base,
        "top": top_style, "handle": style.handle, "shaker": style.shaker,
        "body_color": body_swatch, "front_color": front_swatch,
        "size": [depth, width, height],
    })
    out.add(make_part("body", body, np.zeros(3), body_color), "body")

    # -- fronts, named top to bottom, then left to right -----------------------------------
    movable = sorted((b for b in bays if b.kind != "open"), key=lambda b: (-b.z0, b.y0))
    for index, bay in enumerate(movable):
        g = style.gap
        if bay.kind == "door":
            name = f"door_{index}"
            hinged = door(style, bay.y0 + g, bay.y1 - g, bay.z0 + g, bay.z1 - g,
                          x1 - style.thickness, bay.side, hinge_at_front=True)
            upper = {"left": (1.5, 2.0), "right": (1.5, 2.0), "top": (1.2, 1.55),
                     "bottom": (1.35, math.pi / 2)}[bay.side]
            joint = revolute(rng, f"{name}_hinge", name, hinged.hinge, hinged.axis,
                             uniform(rng, *upper), **door_dynamics(rng))
            out.add(make_part(name, hinged.primitives, hinged.hinge, front_color), "door", joint,
                    bay.side)
        else:
            name = f"drawer_{index}"
            slide = drawer(rng, style, bay.y0, bay.y1, bay.z0, bay.z1, x1, depth - tb)
            joint = prismatic(rng, f"{name}_slide", name, slide.rest,
                              uniform(rng, 0.6, 0.85) * slide.depth, **drawer_dynamics(rng))
            out.add(make_part(name, slide.primitives, slide.rest, front_color), "drawer", joint)
    return out
