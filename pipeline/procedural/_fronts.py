"""Doors, drawers and their handles, shared by cabinets, tables and refrigerators.

A front sits in an opening of the body (a rectangle in the y-z plane, the front of the
object facing +X). Doors hinge at one edge (left/right: vertical axis; top/bottom: a flap
on a horizontal axis) and open outward for positive angles; drawers are a front panel plus
an open box behind it, sliding out along +X. Handles are merged into their front's part.

"Left" and "right" are as seen by someone standing in front of the object (looking along
-X): their left is -Y.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._build import DENSITY, Box, Cylinder, Primitive, choice, uniform

HANDLE_STYLES = ("bar", "knob", "pull")
HINGE_AXES = {  # unit axis (part frame) that opens the door outward for positive angles
    "left": (0.0, 0.0, -1.0),
    "right": (0.0, 0.0, 1.0),
    "top": (0.0, -1.0, 0.0),
    "bottom": (0.0, 1.0, 0.0),
}
HANDLE_HEIGHT = 1.05  # m above the floor: where a hand reaches for a tall door's handle


@dataclass(frozen=True)
class FrontStyle:
    """Everything about an object's fronts that a designer picks once for all of them."""

    gap: float  # between a front and the edge of its opening
    thickness: float  # of door and drawer-front panels
    density: float
    handle: str  # one of HANDLE_STYLES
    handle_density: float
    bar_length: float
    bar_section: float  # square bar and post cross-section
    standoff: float  # from the front face to the back of a bar
    knob_radius: float
    knob_length: float
    edge_margin: float  # from a door's free edge to its handle's centre line
    shaker: bool  # doors with a raised frame (stiles and rails)
    frame_width: float
    frame_depth: float
    box_wall: float  # drawer box walls
    box_density: float


def front_style(rng: np.random.Generator, *, thickness: tuple[float, float] = (0.016, 0.022),
                density: float = DENSITY["particleboard"], shaker_p: float = 0.35,
                bar_length: tuple[float, float] = (0.08, 0.26)) -> FrontStyle:
    return FrontStyle(
        gap=uniform(rng, 0.002, 0.004),
        thickness=uniform(rng, *thickness),
        density=density,
        handle=choice(rng, HANDLE_STYLES, p=[0.55, 0.3, 0.15]),
        handle_density=DENSITY["aluminium"],
        bar_length=uniform(rng, *bar_length),
        bar_section=uniform(rng, 0.010, 0.016),
        standoff=uniform(rng, 0.022, 0.035),
        knob_radius=uniform(rng, 0.010, 0.018),
        knob_length=uniform(rng, 0.022, 0.032),
        edge_margin=uniform(rng, 0.035, 0.06),
        shaker=bool(rng.random() < shaker_p),
        frame_width=uniform(rng, 0.045, 0.08),
        frame_depth=uniform(rng, 0.004, 0.007),
        box_wall=uniform(rng, 0.008, 0.013),
        box_density=DENSITY["particleboard"],
    )


def handle_half_width(style: FrontStyle) -> float:
    """Half the handle's size across its length (how close it may come to an edge)."""
    return {"bar": style.bar_section / 2, "knob": style.knob_radius, "pull": 0.006}[style.handle]


def handle(style: FrontStyle, face_x: float, y: float, z: float, vertical: bool,
           span: float) -> list[Primitive]:
    """A handle standing on the plane x = ``face_x``, centred at (y, z), its length along z
    (``vertical``) or y, at most 60 % of the front's ``span`` in that direction."""
    along = 2 if vertical else 1
    across = 1 if vertical else 2
    centre = np.array([0.0, y, z])

    def box(x0: float, x1: float, a0: float, a1: float, c_half: float) -> Box:
        lo, hi = centre.copy(), centre.copy()
        lo[0], hi[0] = x0, x1
        lo[along], hi[along] = centre[along] + a0, centre[along] + a1
        lo[across], hi[across] = centre[across] - c_half, centre[across] + c_half
        return Box(tuple(lo), tuple(hi), style.handle_density)

    length = min(style.bar_length, 0.6 * span)
    if style.handle == "knob":
        return [Cylinder((face_x + style.knob_length / 2, y, z), 0, style.knob_radius,
                         style.knob_length, style.handle_density)]
    if style.handle == "pull":  # a flat profile fixed to the face
        return [box(face_x, face_x + 0.02, -length / 2, length / 2, 0.006)]
    s, so = style.bar_section, style.standoff
    post = length / 2 - max(s, 0.12 * length) + s / 2  # post centres, inside the bar's ends
    return [
        box(face_x + so, face_x + so + s, -length / 2, length / 2, s / 2),
        box(face_x, face_x + so, -post - s / 2, -post + s / 2, s / 2),
        box(face_x, face_x + so, post - s / 2, post + s / 2, s / 2),
    ]


@dataclass(frozen=True)
class Hinged:
    primitives: list[Primitive]
    hinge: np.ndarray  # a point on the hinge line (object frame): the joint origin
    axis: tuple[float, float, float]


def door(style: FrontStyle, y0: float, y1: float, z0: float, z1: float, back_x: float,
         side: str, *, hinge_at_front: bool) -> Hinged:
    """A door panel filling [y0, y1] x [z0, z1] (gaps already taken off), from ``back_x``
    forward by the panel thickness, hinged on ``side``.

    The hinge line runs along the panel's front edge for an inset door (the back corner
    then swings into the door's own opening, clear of the carcass) and along its back edge
    for an overlay door (the front corner swings out past the body's side)."""
    td = style.thickness
    face = back_x + td
    prims: list[Primitive] = [Box((back_x, y0, z0), (face, y1, z1), style.density)]
    w, h = y1 - y0, z1 - z0
    reach = handle_half_width(style) + 0.005
    fw = min(style.frame_width, 0.2 * min(w, h))
    shaker = style.shaker and fw >= 2 * reach
    if shaker:
        fx = face + style.frame_depth
        prims += [
            Box((face, y0, z0), (fx, y0 + fw, z1), style.density),
            Box((face, y1 - fw, z0), (fx, y1, z1), style.density),
            Box((face, y0 + fw, z0), (fx, y1 - fw, z0 + fw), style.density),
            Box((face, y0 + fw, z1 - fw), (fx, y1 - fw, z1), style.density),
        ]
        face, margin = fx, fw / 2  # the handle sits on the stile or rail
    else:
        margin = max(style.edge_margin, reach)
    yc, zc = 0.5 * (y0 + y1), 0.5 * (z0 + z1)
    if side in ("left", "right"):
        length = min(style.bar_length, 0.6 * h)
        half = length / 2 + margin
        hz = float(np.clip(HANDLE_HEIGHT, z0 + half, z1 - half)) if h > 2 * half else zc
        hy = y1 - margin if side == "left" else y0 + margin
        prims += handle(style, face, hy, hz, True, h)
    else:
        hz = z0 + margin if side == "top" else z1 - margin
        prims += handle(style, face, yc, hz, False, w)
    hinge_x = back_x + td if hinge_at_front else back_x
    hinge = {
        "left": (hinge_x, y0, zc),
        "right": (hinge_x, y1, zc),
        "top": (hinge_x, yc, z1),
        "bottom": (hinge_x, yc, z0),
    }[side]
    return Hinged(prims, np.array(hinge, dtype=float), HINGE_AXES[side])


@dataclass(frozen=True)
class Sliding:
    primitives: list[Primitive]
    rest: np.ndarray  # the front face's centre when closed: the joint origin
    depth: float  # of the drawer box, front panel excluded


def drawer(rng: np.random.Generator, style: FrontStyle, y0: float, y1: float, z0: float,
           z1: float, front_x: float, room: float) -> Sliding:
    """A drawer in the opening [y0, y1] x [z0, z1] whose front is flush with ``front_x``;
    ``room`` is the free depth behind the front plane. The front panel keeps ``style.gap``
    to the opening; the box (bottom, two sides, back; no top) keeps more, and its sides stop
    below the opening's top so the drawer is an open container."""
    g, tf_, tw = style.gap, style.thickness, style.box_wall
    fy0, fy1, fz0, fz1 = y0 + g, y1 - g, z0 + g, z1 - g
    prims: list[Primitive] = [Box((front_x - tf_, fy0, fz0), (front_x, fy1, fz1), style.density)]
    side_clear = uniform(rng, 0.006, 0.012)
    bottom_clear = uniform(rng, 0.003, 0.006)
    top_clear = min(uniform(rng, 0.012, 0.035), (z1 - z0) - bottom_clear - 0.045)
    depth = room - tf_ - uniform(rng, 0.01, 0.03)
    bx0, bx1 = front_x - tf_ - depth, front_x - tf_
    by0, by1 = y0 + side_clear, y1 - side_clear
    bz0, bz1 = z0 + bottom_clear, z1 - top_clear
    d = style.box_density
    prims += [
        Box((bx0, by0, bz0), (bx1, by1, bz0 + tw), d),  # bottom
        Box((bx0, by0, bz0 + tw), (bx1, by0 + tw, bz1), d),  # sides
        Box((bx0, by1 - tw, bz0 + tw), (bx1, by1, bz1), d),
        Box((bx0, by0 + tw, bz0 + tw), (bx0 + tw, by1 - tw, bz1), d),  # back
    ]
    w, h = fy1 - fy0, fz1 - fz0
    yc = 0.5 * (fy0 + fy1)
    hz = 0.5 * (fz0 + fz1) if h <= 0.25 else fz1 - 0.08
    if style.handle == "knob" and w > 0.6:
        for hy in (fy0 + w / 4, fy1 - w / 4):
            prims += handle(style, front_x, hy, hz, False, w)
    else:
        prims += handle(style, front_x, yc, hz, False, w)
    return Sliding(prims, np.array([front_x, 0.5 * (y0 + y1), 0.5 * (z0 + z1)]), depth)


def door_dynamics(rng: np.random.Generator) -> dict[str, float]:
    return {"damping": uniform(rng, 0.05, 0.3), "friction": uniform(rng, 0.02, 0.2),
            "effort": 20.0}


def drawer_dynamics(rng: np.random.Generator) -> dict[str, float]:
    return {"damping": uniform(rng, 2.0, 8.0), "friction": uniform(rng, 0.5, 3.0)}


# -- appliance parts: knobs and racks ------------------------------------------------------------
KNOB_CLEARANCE = 0.002  # between a knob and the panel it turns on (its shaft is hidden)


def knob(face_x: float, y: float, z: float, radius: float, length: float) -> Hinged:
    """A control knob on the panel x = ``face_x``: a cylinder along +X with a pointer ridge
    across its face (so a turn shows), turning about its own axis."""
    x0 = face_x + KNOB_CLEARANCE
    ridge = 0.25 * radius
    prims: list[Primitive] = [
        Cylinder((x0 + length / 2, y, z), 0, radius, length, DENSITY["plastic"]),
        Box((x0 + length, y - ridge / 2, z - 0.8 * radius), (x0 + length + 0.004, y + ridge / 2,
                                                              z + 0.8 * radius), DENSITY["plastic"]),
    ]
    return Hinged(prims, np.array([x0, y, z]), (1.0, 0.0, 0.0))


def wire_rack(x0: float, x1: float, y0: float, y1: float, z: float, bar: float,
              bars: int) -> list[Primitive]:
    """An oven shelf: a rectangular frame of square steel bars with ``bars`` bars across it
    from front to back, lying on the plane z (its underside)."""
    d = DENSITY["steel"]
    prims: list[Primitive] = [
        Box((x0, y0, z), (x0 + bar, y1, z + bar), d), Box((x1 - bar, y0, z), (x1, y1, z + bar), d),
        Box((x0 + bar, y0, z), (x1 - bar, y0 + bar, z + bar), d),
        Box((x0 + bar, y1 - bar, z), (x1 - bar, y1, z + bar), d),
    ]
    for k in range(bars):
        yc = y0 + (k + 1) * (y1 - y0) / (bars + 1)
        prims.append(Box((x0 + bar, yc - bar / 2, z), (x1 - bar, yc + bar / 2, z + bar), d))
    return prims


def rack_dynamics(rng: np.random.Generator) -> dict[str, float]:
    """Oven shelves and dishwasher baskets run on rails or rollers: lighter than a drawer."""
    return {"damping": uniform(rng, 0.5, 3.0), "friction": uniform(rng, 0.2, 1.5)}


def knob_dynamics(rng: np.random.Generator) -> dict[str, float]:
    return {"damping": uniform(rng, 0.001, 0.01), "friction": uniform(rng, 0.01, 0.05),
            "effort": 1.0}
