"""Doors in their frames: a room door (one leaf, or a pair of French doors) hinged at a jamb,
or a barn-style sliding door hung from a rail on the wall.

The root is the frame (two jambs, a head and sometimes a threshold), often with a piece of
the wall around it. Hinged leaves sit in the frame's opening flush with its front and swing
out to the front (+X) about their front edge; a sliding leaf hangs in front of the wall
and the opening and slides along the wall (along Y) to one side. Handles are at the
height a hand reaches for (about 1 m), on the free edge.
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
    uniform,
)
from ._fronts import door, door_dynamics, front_style

PART_RANGE = (2, 3)  # the frame, and one or two leaves


def build(rng: np.random.Generator, n_parts: int) -> Assembly:
    leaves = n_parts - 1
    layout = choice(rng, ("hinged", "sliding"), p=[0.75, 0.25])
    leaf_w = uniform(rng, 0.7, 0.95) if leaves == 1 else uniform(rng, 0.5, 0.8)
    leaf_h = uniform(rng, 1.95, 2.1)
    depth = uniform(rng, 0.09, 0.16)  # the frame's (and wall's) depth, along x
    jamb = uniform(rng, 0.04, 0.09)  # face width of the frame
    threshold = uniform(rng, 0.01, 0.02) if rng.random() < 0.4 else 0.0
    style = front_style(rng, thickness=(0.035, 0.045), density=DENSITY["hollow_core"],
                        shaker_p=0.5, bar_length=(0.1, 0.16))
    style = dataclasses.replace(style, handle=choice(rng, ("bar", "knob"), p=[0.7, 0.3]),
                                frame_width=uniform(rng, 0.1, 0.16))
    g = uniform(rng, 0.003, 0.005)
    floor_gap = uniform(rng, 0.008, 0.015)
    opening_w = leaves * leaf_w + (leaves + 1) * g
    opening_h = threshold + floor_gap + leaf_h + g
    wall = layout == "sliding" or rng.random() < 0.5
    # A sliding leaf runs over the wall beside the opening: the wall must be that wide.
    beside = (uniform(rng, 0.95, 1.15) * leaf_w if layout == "sliding"
              else uniform(rng, 0.1, 0.4)) if wall else 0.0
    above = uniform(rng, 0.15, 0.4) if wall else 0.0
    wood = DENSITY["wood"]
    x0, x1 = -depth / 2, depth / 2
    yo = opening_w / 2  # the opening is [-yo, yo] x [0, opening_h]
    outer = yo + jamb + beside
    height = opening_h + jamb + above

    body: list[Primitive] = [
        Box((x0, -yo - jamb, 0.0), (x1, -yo, opening_h), wood),  # jambs
        Box((x0, yo, 0.0), (x1, yo + jamb, opening_h), wood),
        Box((x0, -yo - jamb, opening_h), (x1, yo + jamb, opening_h + jamb), wood),  # head
    ]
    if threshold:
        body.append(Box((x0, -yo, 0.0), (x1, yo, threshold), wood))
    if wall:
        plaster = DENSITY["plaster"]
        if beside:
            body += [Box((x0, -outer, 0.0), (x1, -yo - jamb, height), plaster),
                     Box((x0, yo + jamb, 0.0), (x1, outer, height), plaster)]
        body.append(Box((x0, -yo - jamb, opening_h + jamb), (x1, yo + jamb, height), plaster))

    material = choice(rng, ("wood", "paint"), p=[0.4, 0.6])
    swatch, color = pick_color(rng, material)
    frame_swatch, frame_color = (swatch, color) if rng.random() < 0.6 else \
        pick_color(rng, "paint")
    out = Assembly(style={"layout": layout, "leaves": leaves, "wall": wall,
                          "handle": style.handle, "shaker": style.shaker, "color": swatch,
                          "frame_color": frame_swatch, "size": [depth, 2 * outer, height]})
    z0, z1 = threshold + floor_gap, threshold + floor_gap + leaf_h
    if layout == "hinged":
        out.add(make_part("body", body, np.zeros(3), frame_color), "body")
        spans = [(-yo + g, yo - g)] if leaves == 1 else [(-yo + g, -g / 2), (g / 2, yo - g)]
        sides = [choice(rng, ("left", "right"))] if leaves == 1 else ["left", "right"]
        for i, ((ya, yb), side) in enumerate(zip(spans, sides, strict=True)):
            name = f"door_{i}"
            hinged = door(style, ya, yb, z0, z1, x1 - style.thickness, side, hinge_at_front=True)
            joint = revolute(rng, f"{name}_hinge", name, hinged.hinge, hinged.axis,
                             uniform(rng, 1.4, 1.9), **door_dynamics(rng))
            out.add(make_part(name, hinged.primitives, hinged.hinge, color), "door", joint, side)
        return out

    # Sliding: a rail on the wall above the opening, each leaf hanging from it in front.
    rail_h, rail_t = uniform(rng, 0.03, 0.05), uniform(rng, 0.015, 0.025)
    zr = min(z1 + 0.05, height - rail_h - 0.01)
    body.append(Box((x1, -outer, zr), (x1 + rail_t, outer, zr + rail_h), DENSITY["steel"]))
    out.add(make_part("body", body, np.zeros(3), frame_color), "body")
    lx0 = x1 + rail_t + uniform(rng, 0.005, 0.01)  # the leaves' back face
    cover = uniform(rng, 0.03, 0.06)  # how far a leaf laps over the frame
    spans = [(-yo - cover, yo + cover)] if leaves == 1 else [(-yo - cover, -g / 2),
                                                             (g / 2, yo + cover)]
    directions = [choice(rng, ("left", "right"))] if leaves == 1 else ["left", "right"]
    for i, ((ya, yb), towards) in enumerate(zip(spans, directions, strict=True)):
        name = f"door_{i}"
        # The handle on the edge that leads when the leaf closes, where a leaf hinged on
        # the side it slides to has its handle.
        hinged = door(style, ya, yb, z0, min(z1 + 0.05, zr + rail_h), lx0, towards,
                      hinge_at_front=False)
        rest = np.array([lx0, 0.5 * (ya + yb), 0.5 * (z0 + z1)])
        travel = uniform(rng, 0.85, 0.95) * (yb - ya)
        axis = (0.0, 1.0 if towards == "right" else -1.0, 0.0)
        joint = prismatic(rng, f"{name}_slide", name, rest, min(travel, outer - abs(rest[1])),
                          damping=uniform(rng, 1.0, 5.0), friction=uniform(rng, 0.5, 3.0), axis=axis)
        out.add(make_part(name, hinged.primitives, rest, color), "sliding_door", joint)
    return out
