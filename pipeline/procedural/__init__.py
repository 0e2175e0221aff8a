"""Procedural articulated objects: the five Real2Code categories (:data:`CATEGORIES`) and
household objects users scan besides them (:data:`HOUSEHOLD_CATEGORIES`: ovens,
dishwashers, microwaves, trash cans, doors in their frames).

``generate(category, n_parts, seed)`` builds a random object of ``category`` with
``n_parts`` rigid parts (the root body included; ``None`` picks a count), the same object
for the same arguments. Dimensions are in metres and drawn from realistic ranges; styles
(layout, base, handles, colours, materials) vary with the seed.

Conventions (besides the model's):
- Z up; the object's front faces +X (:data:`FRONT`); it stands on z = 0, centred on the
  z axis. "Left"/"right" are as seen from the front (looking along -X): left is -Y.
- The root part is always ``body``; movable parts are ``door_<i>`` / ``drawer_<i>``
  (numbered top to bottom, then left to right), ``lid`` (box, trash can) and ``screen``
  (laptop), and in household objects ``rack_<i>`` (oven shelves, dishwasher baskets, top to
  bottom), ``knob_<i>``, ``turntable``, ``lid_<i>`` (a trash can's butterfly lid) and
  ``pedal``; their joints ``<part>_hinge`` (revolute) or ``<part>_slide`` (prismatic).
- q = 0 is closed. Revolute joints open outward for positive angles (doors swing to the
  front, lids lift, a pedal goes down; knobs and turntables turn about their own axis),
  prismatic joints slide along +X (a sliding door along the wall, +Y or -Y); limits start
  at 0. The observed ``state`` is a random, mostly partly open value within the limits
  (sometimes closed).
- A part's frame is its joint frame: on the hinge line for doors and lids (on the axis for
  knobs and turntables), at the centre of the closed front face for drawers (of the front
  bar for racks, of the back face for sliding doors). No joint origin is rotated.
- Geometry is a union of boxes (and 12-sided cylinders): the visual mesh concatenates them,
  each is one convex collision piece, the inertial combines their exact solid inertials.
- Closed, no two parts overlap: fronts keep a gap of a few millimetres to their opening.
  The observed configuration is collision-free too (a front that would hit another open
  one is observed closed).

``metadata`` holds ``category``, ``seed``, ``generator``, ``n_parts``, ``front``/``up``,
``part_labels`` / ``joint_labels`` (``body``, ``door``, ``drawer``, ``lid``, and in household
objects ``rack``, ``knob``, ``turntable``, ``pedal``, ``sliding_door``), ``hinge_sides`` (of
doors, lids and pedals: ``left``, ``right``, ``top``, ``bottom``, ``back``) and ``style``
(the choices made).
"""

from __future__ import annotations

from types import ModuleType

import numpy as np

from real2code_export.errors import Real2CodeError
from real2code_export.model import ArticulatedObject, validate

from . import (
    box,
    dishwasher,
    door,
    laptop,
    microwave,
    oven,
    refrigerator,
    storage_furniture,
    table,
    trash_can,
)
from ._build import FRONT, UP, close_clashing_fronts

__all__ = ["ALL_CATEGORIES", "CATEGORIES", "FRONT", "GENERATOR", "HOUSEHOLD_CATEGORIES", "UP",
           "GenerationError", "generate", "part_count_range"]

# The paper's categories: the procedural test set (``procedural_cases``) draws from these only.
CATEGORIES = ("storage_furniture", "table", "refrigerator", "laptop", "box")
HOUSEHOLD_CATEGORIES = ("oven", "dishwasher", "microwave", "trash_can", "door")
ALL_CATEGORIES = CATEGORIES + HOUSEHOLD_CATEGORIES
GENERATOR = "real2code_export.procedural"
_MODULES: dict[str, ModuleType] = {
    "storage_furniture": storage_furniture,
    "table": table,
    "refrigerator": refrigerator,
    "laptop": laptop,
    "box": box,
    "oven": oven,
    "dishwasher": dishwasher,
    "microwave": microwave,
    "trash_can": trash_can,
    "door": door,
}


class GenerationError(Real2CodeError, ValueError):
    """The arguments ask for an object that cannot be made (unknown category, a part count
    outside the category's range, a bad seed)."""


def _module(category: str) -> ModuleType:
    if category not in _MODULES:
        raise GenerationError(
            f"unknown category {category!r}; choose from {list(ALL_CATEGORIES)}")
    return _MODULES[category]


def part_count_range(category: str) -> tuple[int, int]:
    """The smallest and largest number of rigid parts (root included) ``category`` allows."""
    return _module(category).PART_RANGE


def _part_count(rng: np.random.Generator, lo: int, hi: int) -> int:
    """A count when none is asked for: small objects are the common ones (as in
    PartNet-Mobility), so weights fall off with the number of movable parts."""
    counts = np.arange(lo, hi + 1)
    weights = 1.0 / counts.astype(float)
    return int(rng.choice(counts, p=weights / weights.sum()))


def generate(category: str, n_parts: int | None = None, seed: int = 0) -> ArticulatedObject:
    """A random articulated object of ``category`` with ``n_parts`` rigid parts (``None``:
    drawn from the seed), the same for the same arguments. Raises :class:`GenerationError`."""
    module = _module(category)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise GenerationError(f"seed must be a non-negative integer, got {seed!r}")
    lo, hi = module.PART_RANGE
    rng = np.random.default_rng(int(seed))
    if n_parts is None:
        n_parts = _part_count(rng, lo, hi)
    elif isinstance(n_parts, bool) or not isinstance(n_parts, (int, np.integer)):
        raise GenerationError(f"n_parts must be an integer, got {n_parts!r}")
    if not lo <= n_parts <= hi:
        raise GenerationError(
            f"a {category} has {lo} to {hi} parts (the body included), {n_parts} asked for")
    n_parts = int(n_parts)
    built = module.build(rng, n_parts)
    close_clashing_fronts(built.parts, built.joints)
    obj = ArticulatedObject(
        name=f"{category}_{int(seed)}",
        parts=built.parts,
        joints=built.joints,
        metadata={
            "category": category,
            "seed": int(seed),
            "generator": GENERATOR,
            "n_parts": n_parts,
            "front": "+x",
            "up": "+z",
            "part_labels": built.part_labels,
            "joint_labels": built.joint_labels,
            "hinge_sides": built.hinge_sides,
            "style": built.style,
        },
    )
    return validate(obj)
