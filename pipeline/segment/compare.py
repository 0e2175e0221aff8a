"""Mask networks side by side on held-out rendered views, one camera path and sensor at a time.

    python -m pipeline.segment.compare OLD.pt NEW.pt [--objects 30] [--cameras ring,front-arc]
        [--sensors clean,phone-lidar] [--world household]

For every (camera path, sensor) pair: views of procedural objects of a world (default the
paper's categories) that the training never drew (another seed), each network prompted
inside the true parts as in training, and the mean IoU of its masks
(:func:`pipeline.segment.train.validate`). The shipped weights are replaced only by weights
that do better on the paths people take and no worse on the front arc.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from .data import SHIPPED_WORLD

HELD_OUT_SEED = 424242  # far from the training seeds (1 to a few) and their validation's


def compare(weights: list[Path], cameras: list[str], sensors: list[str], objects: int,
            views_per_object: int = 2, workers: int = 1, cache_dir: Path | None = None,
            report=None, world: str = SHIPPED_WORLD) -> dict[tuple[str, str], list[dict]]:
    """Per (camera path, sensor): each network's :func:`validate` figures; ``report(key,
    rows)`` is called as each pair is done (a long comparison shows its rows as it goes)."""
    from .data import make_views
    from .learned import LearnedSegmenter
    from .train import _cached, validate

    nets = [LearnedSegmenter.load(w).network for w in weights]
    tag = "" if world == SHIPPED_WORLD else f"_{world}"
    out = {}
    for path in cameras:
        for sensor in sensors:
            views = _cached(cache_dir, f"compare_{objects}_{views_per_object}_{path}_"
                            f"{Path(sensor).stem}{tag}", lambda p=path, s=sensor: make_views(
                                objects, HELD_OUT_SEED, views_per_object, workers, (p,), (s,),
                                world))
            out[(path, sensor)] = [validate(net, views) for net in nets]
            if report is not None:
                report((path, sensor), out[(path, sensor)])
    return out


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("weights", nargs="+", type=Path)
    p.add_argument("--objects", type=int, default=30)
    p.add_argument("--cameras", default="ring,handheld,front-arc")
    p.add_argument("--sensors", default="clean,phone-lidar")
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--world", default=SHIPPED_WORLD,
                   help="the categories of the held-out objects (pipeline.predictors.data.WORLDS)")
    p.add_argument("--cache-dir", type=Path, default=None,
                   help="keep the rendered views here between runs")
    args = p.parse_args(argv)
    names = [w.name if w.name != "segmenter.pt" else str(w) for w in args.weights]
    print(f"World: {args.world}.")
    print("| cameras | sensor | " + " | ".join(names) + " |")
    print("|---|---|" + "---|" * len(names), flush=True)

    def row(key, rows):
        cells = " | ".join(f"{r['mean_iou']:.3f} ({r['iou_over_0.9']:.2f})" for r in rows)
        print(f"| {key[0]} | {key[1]} | {cells} |", flush=True)

    compare(args.weights, args.cameras.split(","), args.sensors.split(","), args.objects,
            workers=args.workers, cache_dir=args.cache_dir, report=row, world=args.world)


if __name__ == "__main__":
    main()
