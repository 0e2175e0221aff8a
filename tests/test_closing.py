"""A hinge's observed opening (``pipeline.closing``): the turn that shuts the part flat
against its parent, onto a place no other part holds."""

from __future__ import annotations

import itertools

import numpy as np

from pipeline.closing import _rotate, hinge_opening_from_mesh, place_taken
from pipeline.obb import OBB

Y = np.array([0.0, 1.0, 0.0])


def _slab(lo, hi) -> np.ndarray:
    """The corners of an axis-aligned box: a convex hull is all the estimate reads."""
    return np.array(list(itertools.product(*zip(lo, hi, strict=True))), dtype=float)


def _grid(lo, hi, n=12) -> np.ndarray:
    axes = [np.linspace(a, b, n) if b > a else np.array([a]) for a, b in zip(lo, hi, strict=True)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)


def test_two_flaps_on_one_rail_shut_each_onto_its_own_place():
    """Two flaps hinged on one rail across a carcass's front (the upper one at its bottom
    edge, the lower one at its top edge) lie flush on the front face whichever way each
    shuts. Where the parent's surface misleads (a scan's completed carcass closes the
    upper opening with a membrane, the lower one not), the upper flap shut down onto the
    lower flap's place (the demo's two flaps, 51 mm deep in each other); the other part's
    surface there now rules that place out."""
    carcass = OBB(np.array([0.0, 0.0, 0.47]), np.eye(3), np.array([0.29, 0.39, 0.47]))
    rail = np.array([0.31, 0.0, 0.47])  # along the flaps' front edges
    upper = _slab([0.29, -0.37, 0.48], [0.31, 0.37, 0.69])  # shut
    upper_open = _rotate(upper, Y, rail, np.array([0.36]))[0]  # tipped forward 0.36 rad
    # the membrane over the upper opening, and nothing over the lower one
    membrane = _grid([0.28, -0.38, 0.48], [0.28, 0.38, 0.69])
    lower_seen = _rotate(_grid([0.29, -0.37, 0.25], [0.31, 0.37, 0.46]), -Y, rail,
                         np.array([0.10]))[0]  # the lower flap's surface, lifted a little
    misled = hinge_opening_from_mesh(carcass, upper_open, Y, rail, membrane)
    assert abs(misled - 0.36) > 1.0  # the membrane alone picks the neighbour's place
    state = hinge_opening_from_mesh(carcass, upper_open, Y, rail, membrane, [lower_seen])
    assert abs(state - 0.36) < 0.02, state
    # with nothing in the way the estimate is as before
    free = hinge_opening_from_mesh(carcass, upper_open, Y, rail, None, [np.empty((0, 3))])
    assert abs(free - hinge_opening_from_mesh(carcass, upper_open, Y, rail)) < 1e-9


def test_place_taken_is_the_share_of_another_part_inside():
    box = _slab([0, 0, 0], [1, 1, 1])
    inside, outside = _grid([0.1] * 3, [0.9] * 3, 4), _grid([2.0] * 3, [3.0] * 3, 4)
    assert place_taken(box, [outside]) == 0.0
    assert place_taken(box, [outside, np.concatenate([inside, outside])]) == 0.5
    assert place_taken(_slab([0, 0, 0], [1, 1, 0]), [inside]) == 0.0  # flat: holds nothing
