"""The unit frame a part is completed in: its *partial* box, as the paper normalises it.

The box is fitted to the observed points only (``pipeline.obb.part_obb``: gravity-aware when
tight), widened by a margin so hidden geometry just past the seen points fits, and scaled
per axis to the cube [-1/2, 1/2]^3, so a 2 cm door and a 1 m cabinet fill the grid alike
(the paper: "to avoid under-fitting the smaller-sized meshes"). A floor on each half-size
keeps a door seen only from the front from collapsing to a plane. The metric half-sizes
go to the network beside the points, since the per-axis scaling hides them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MARGIN = 1.5  # the paper's factor on the partial box
MIN_HALF = 0.015  # m: at least a 3 cm slab before the margin
MIN_HALF_RATIO = 0.05  # ...and at least 5 % of the longest side


@dataclass(frozen=True, eq=False)
class PartFrame:
    center: np.ndarray  # (3,) world
    R: np.ndarray  # (3, 3) columns: box axes in the world
    half: np.ndarray  # (3,) half-sizes of the region, margin included

    def to_unit(self, points: np.ndarray) -> np.ndarray:
        return ((np.asarray(points, float) - self.center) @ self.R) / (2.0 * self.half)

    def from_unit(self, unit: np.ndarray) -> np.ndarray:
        return (np.asarray(unit, float) * (2.0 * self.half)) @ self.R.T + self.center

    def features(self) -> np.ndarray:
        """What the network is told about the metric size: log half-sizes (m)."""
        return np.log(self.half).astype(np.float32)


def part_frame(points: np.ndarray) -> PartFrame:
    """The frame of a part seen as ``points`` (world, at least 4)."""
    from ..obb import part_obb

    box = part_obb(points)
    floor = max(MIN_HALF, MIN_HALF_RATIO * float(box.extent.max()))
    half = MARGIN * np.maximum(box.extent, floor)
    return PartFrame(box.center.copy(), box.R.copy(), half)
