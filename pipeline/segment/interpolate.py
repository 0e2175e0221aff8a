"""Weights between two mask networks of one architecture: the initial ones and their fine-tuning.

    python -m pipeline.segment.interpolate OLD.pt NEW.pt --alpha 0.5 --out MIXED.pt

Each parameter (and batch-norm statistic) is ``(1 - alpha) * old + alpha * new``, as WiSE-FT
(Wortsman et al. 2022, "Robust fine-tuning of zero-shot models") interpolates a network and its
fine-tuning: fine-tuning on other camera paths and sensors gains on them and gives up a
little where the old weights were trained; the weights between keep more of the old skill for
much of the new. ``pipeline.segment.compare`` says which ``alpha`` to keep. The record keeps
both networks' training records and the ``alpha``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..weights import save_weights
from .learned import LearnedSegmenter


def interpolate(old: Path, new: Path, alpha: float, out: Path) -> dict:
    import torch

    if not 0.0 <= alpha <= 1.0:
        raise ValueError(f"alpha must lie in [0, 1], got {alpha}")
    a, b = LearnedSegmenter.load(old), LearnedSegmenter.load(new)
    if a.config["network"] != b.config["network"]:
        raise ValueError(f"{old} and {new} are different networks: "
                         f"{a.config['network']} vs {b.config['network']}")
    first, second = a.network.state_dict(), b.network.state_dict()
    mixed = {k: (torch.lerp(first[k], v, alpha) if v.is_floating_point() else v)
             for k, v in second.items()}  # integer counters (batches seen) are the new one's
    net = b.network
    net.load_state_dict(mixed)
    config = {**b.config, "training": {"interpolated": {
        "alpha": alpha, "old": a.config.get("training"), "new": b.config.get("training")}}}
    save_weights(net, config, out)
    return config["training"]


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("old", type=Path)
    p.add_argument("new", type=Path)
    p.add_argument("--alpha", type=float, default=0.5, help="0 = old, 1 = new")
    p.add_argument("--out", type=Path, required=True)
    args = p.parse_args(argv)
    try:
        interpolate(args.old, args.new, args.alpha, args.out)
    except ValueError as e:
        p.error(str(e))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
