"""Kinematics-aware part segmentation of a capture: one label per rigid part, the same in
every view.

- ``learned`` (default): the point-prompted mask network trained in this repository
  (``network.py``, ``train.py``, shipped weights), prompted the paper's way
  (``prompting.py``);
- ``sam``: a Segment Anything checkpoint (fine-tuned the paper's way) by path, prompted
  the same way (``sam.py``);
- ``gt``: the capture's own ground-truth masks (evaluation).
"""

from __future__ import annotations

from pathlib import Path

from real2code_export.errors import InputError

from ..capture import Capture
from .prompting import PromptingOptions, Segmentation, ground_truth_segmentation, segment_capture

METHODS = ("learned", "gt", "sam")

__all__ = ["METHODS", "PromptingOptions", "Segmentation", "get_segmenter", "segment"]


def get_segmenter(method: str, *, weights: str | Path | None = None,
                  sam_checkpoint: str | Path | None = None, sam_model_type: str = "vit_b"):
    if method == "learned":
        from .learned import LearnedSegmenter

        return LearnedSegmenter.load(weights)
    if method == "sam":
        from real2code_export.errors import Real2CodeError

        from .sam import SamSegmenter

        if sam_checkpoint is None:
            raise Real2CodeError("segmentation 'sam' needs a checkpoint (--sam-checkpoint PATH)")
        return SamSegmenter.load(sam_checkpoint, sam_model_type)
    raise InputError(f"unknown segmentation {method!r}; choose from {list(METHODS)}")


def segment(capture: Capture, method: str = "learned", *, segmenter=None,
            options: PromptingOptions | None = None, weights: str | Path | None = None,
            sam_checkpoint: str | Path | None = None, sam_model_type: str = "vit_b",
            ) -> Segmentation:
    """Part labels for every view of ``capture``. ``segmenter`` (any
    :class:`~pipeline.segment.prompting.PromptSegmenter`, already loaded) overrides
    ``method``'s."""
    if method == "gt" and segmenter is None:
        return ground_truth_segmentation(capture)
    if segmenter is None:
        segmenter = get_segmenter(method, weights=weights, sam_checkpoint=sam_checkpoint,
                                  sam_model_type=sam_model_type)
    return segment_capture(capture, segmenter, options or PromptingOptions())
