"""Part-level shape completion (Real2Code's second stage): partial point cloud of one rigid
part in, watertight mesh out.

- :func:`complete_part` — the learned occupancy network (:mod:`.network`, weights shipped in
  ``weights/occupancy.pt``, trained by ``python -m pipeline.complete.train``) and marching
  cubes (:mod:`.learned`).
- :func:`pipeline.complete.baseline.segment_only_mesh` — the "segment only" baseline:
  surface reconstruction of the raw points, no learning.
- Training data: :mod:`.views` (partial views by ray casting), :mod:`.frame` (the partial
  box the part is normalised by), :mod:`.occupancy` (exact labels), :mod:`.data`.

Torch, open3d and scikit-image are imported only when a function needs them.
"""

from .learned import CompletionError, OccupancyModel, complete_part, load_model

__all__ = ["CompletionError", "OccupancyModel", "complete_part", "load_model"]
