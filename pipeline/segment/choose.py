"""Which mask network segments a capture: the one trained for exact depth or the one trained
on noisy sensors, chosen by the noise the depth cleanup measured in the capture's own frames
(:mod:`pipeline.depth_cleanup`; never told the sensor).

- ``weights/segmenter.pt`` (``clean``): the shipped network; the clean rings' figures are its.
- ``weights/segmenter_noisy.pt`` (``noisy``): trained on the household world over every camera
  path and sensor preset (docs/evaluation.md, issue 20, sessions 25 and 26). Far better on
  noisy depth, worse on exact depth's many-part objects, so it is used only where the depth
  is noisy.

``auto`` takes ``noisy`` where the cleanup found any frame noisy
(:func:`pipeline.depth_cleanup.measured_noisy`: the cleanup's own threshold, so there is one)
and ``clean`` otherwise; ``clean``, ``noisy`` or a weights file force one. The default is
:data:`DEFAULT`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .learned import WEIGHTS

NOISY_WEIGHTS = WEIGHTS.with_name("segmenter_noisy.pt")
SHIPPED = {"clean": WEIGHTS, "noisy": NOISY_WEIGHTS}
MODES = ("auto", *SHIPPED)  # or a weights file's path
# ``auto`` unless asked (session 29): exact depth gets the shipped network as before, and
# noisy depth the noise-trained one, which on PartNet-Mobility dev's phone-LiDAR views
# (merged main 4d44a4e) is better in 7 of 8 buckets: the ring's 3, 4-5 and 6-15 parts
# (type / axis 0.83 / 15.5 -> 0.94 / 5.4 and 0.83 / 15.5 -> 0.92 / 7.8 in 4-5 and 6-15,
# precision 0.75 / 0.79 / 0.62 -> 1.00 / 0.89 / 0.79) and every hand-held bucket (6-15
# parts 0.83 / 22.7 -> 1.00 / 0.7); it loses the ring's 2-part hinge line (axis 0.09 ->
# 1.07 degrees, one refrigerator door's line 0.21 m off against 0.17); on the room demo's
# capture 6 parts for 6 (the shipped network 7, measured in session 27): docs/evaluation.md,
# sessions 26 to 29.
DEFAULT = "auto"


@dataclass(frozen=True)
class Choice:
    """The weights one capture was segmented with, and why."""

    mode: str  # as asked: auto, clean, noisy, or a path
    used: str  # clean, noisy, or the file's name
    weights: Path
    why: str
    noise_rel: float  # the capture's largest frame noise, relative to depth

    def record(self) -> dict:
        """For report.json, the segmentation's summary and the model's metadata."""
        return {"mode": self.mode, "used": self.used, "weights": self.weights.name,
                "why": self.why, "noise_rel": self.noise_rel}


def choose(mask_weights: str | Path, cleanup: dict) -> Choice:
    """The weights for a capture whose depth cleanup summary is ``cleanup``."""
    from ..depth_cleanup import CleanupOptions, measured_noisy

    noise = max(cleanup.get("noise_rel") or [0.0])
    mode = str(mask_weights)
    if mode == "auto":
        noisy = measured_noisy(cleanup)
        used = "noisy" if noisy else "clean"
        threshold = cleanup.get("min_noise_rel", CleanupOptions().min_noise_rel)
        why = (f"{'auto, the default' if mode == DEFAULT else 'auto'}: depth noise "
               f"{noise:.5f} of range measured, "
               f"{'at or above' if noisy else 'below'} the cleanup's {threshold:g}")
        return Choice(mode, used, SHIPPED[used], why, noise)
    if mode in SHIPPED:
        said = "the default" if mode == DEFAULT else f"forced ({mode})"
        return Choice(mode, mode, SHIPPED[mode], f"{said}; depth noise {noise:.5f} "
                      "of range measured", noise)
    path = Path(mask_weights)
    return Choice(mode, path.name, path, f"forced (a file); depth noise {noise:.5f} of range "
                  "measured", noise)


class MaskWeights:
    """The networks a ``mask_weights`` choice may use, loaded at once (a missing or foreign
    file is a :class:`pipeline.weights.WeightsError` naming it, before any work), and the one
    for each capture."""

    def __init__(self, mask_weights: str | Path = DEFAULT):
        from .learned import LearnedSegmenter

        self.mode = str(mask_weights)
        paths = list(SHIPPED.values()) if self.mode == "auto" else \
            [SHIPPED.get(self.mode, Path(mask_weights))]
        self._loaded = {p: LearnedSegmenter.load(p) for p in paths}
        if self.mode == "auto":
            clean, noisy = (self._loaded[p].config["network"] for p in SHIPPED.values())
            if clean != noisy:  # a guard on the package: the two are one architecture
                from ..weights import WeightsError

                raise WeightsError(NOISY_WEIGHTS, None, "not the architecture of "
                                   f"{WEIGHTS.name}: {noisy} vs {clean}")

    def for_capture(self, cleanup: dict):
        """(the loaded segmenter, its :class:`Choice`) for a capture's cleanup summary."""
        choice = choose(self.mode, cleanup)
        return self._loaded[choice.weights], choice
