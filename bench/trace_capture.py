"""Trace `evaluate reconstruction` object by object, stage by stage: the same render,
degradation, isolation, cleanup, segmentation and reconstruction as
`pipeline.evaluate_reconstruction.evaluate` (its functions, its seeds), with what each stage
did to the object written out: pixels of the object kept and of the room left by isolation,
the predicted labels against the true masks, the joints scored one by one.

    PYTHONPATH=$PWD .venv/bin/python bench/trace_capture.py --partnet PATH --splits dev \
        --cameras handheld [--room] [--capture clean] [--only 0,3] [--seg-cache DIR]

``--only`` picks cases by their index in the split (the evaluation's order, so the seed of
each is the evaluation's); ``--seg-cache`` keeps each capture's segmentation so later stages
can be traced again without it.
"""

from __future__ import annotations

import argparse
import pickle
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import load_average  # noqa: E402

from pipeline.depth_cleanup import clean_capture  # noqa: E402
from pipeline.evaluate_articulation import partnet_cases, procedural_cases  # noqa: E402
from pipeline.isolate import isolate_object  # noqa: E402
from pipeline.predictors.evaluate import Scores, bucket_of, score_object  # noqa: E402
from pipeline.reconstruct import reconstruct_capture  # noqa: E402
from pipeline.render import render_object  # noqa: E402
from pipeline.segment import get_segmenter  # noqa: E402
from pipeline.segment.evaluate import matched_part_iou  # noqa: E402
from pipeline.sensors import degrade, load_sensor  # noqa: E402


def isolation_trace(raw, isolated) -> str:
    """Of the object's pixels with depth, the share isolation kept; of the room's, left."""
    obj_total = obj_kept = room_left = 0
    for a, b in zip(raw.frames, isolated.frames, strict=True):
        on = a.mask > 0
        obj_total += int((on & (a.depth > 0)).sum())
        obj_kept += int((on & (b.depth > 0)).sum())
        room_left += int((~on & (b.depth > 0)).sum())
    return f"object kept {obj_kept / max(obj_total, 1):.4f}, room pixels left {room_left}"


def label_trace(labels, frames) -> list[str]:
    """Each predicted label: its pixels, and its share of the true part it is mostly."""
    p = np.concatenate([a.ravel() for a in labels]).astype(np.int64)
    t = np.concatenate([f.mask.ravel() for f in frames]).astype(np.int64)
    lines = []
    for k in np.unique(p[p > 0]):
        truth = t[p == k]
        counts = np.bincount(truth)
        top = int(np.argmax(counts))
        share_of_truth = counts[top] / max(1, int((t == top).sum()))
        lines.append(f"  label {k}: {len(truth)} px, {counts[top] / len(truth):.2f} part {top} "
                     f"({share_of_truth:.2f} of it)")
    return lines


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--partnet", type=Path)
    p.add_argument("--splits", default="dev")
    p.add_argument("--objects", type=int, default=0, help="procedural test objects")
    p.add_argument("--cameras", default="ring")
    p.add_argument("--distance", default="mid")
    p.add_argument("--capture", default="clean")
    p.add_argument("--room", action="store_true")
    p.add_argument("--only", default="", help="comma-separated case indices")
    p.add_argument("--seg-cache", type=Path)
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args()
    cases = procedural_cases(args.objects, args.seed) if args.objects else \
        partnet_cases(args.partnet, args.splits, args.seed)
    only = {int(x) for x in args.only.split(",") if x.strip()}
    sensor = load_sensor(args.capture)
    segmenter = get_segmenter("learned")
    total = Scores()
    print(f"load average {load_average()}", flush=True)
    for k, case in enumerate(cases):
        if only and k not in only:
            continue
        t0 = time.perf_counter()
        raw = render_object(case.obj, base=case.base, views=12, width=256, height=256,
                            seed=args.seed + k, cameras=args.cameras, distance=args.distance,
                            room=args.room)
        raw = degrade(raw, sensor, args.seed + k)
        isolated, summary = isolate_object(raw)
        capture, _ = clean_capture(isolated)
        print(f"[{k}] {case.label} ({len(case.obj.parts)} parts, "
              f"{len(case.obj.movable_joints)} movable): {isolation_trace(raw, capture)}",
              flush=True)
        tag = f"{args.cameras}_{args.capture}_{int(args.room)}_{args.seed}_{k}.pkl"
        cached = None
        if args.seg_cache and (args.seg_cache / tag).is_file():
            cached = pickle.loads((args.seg_cache / tag).read_bytes())
        rec = reconstruct_capture(capture, segmentation="learned", completion="segment_only",
                                  segmenter=segmenter, name=case.obj.name, collision="hull",
                                  precomputed_segmentation=cached, texture=False)
        if args.seg_cache and cached is None:
            args.seg_cache.mkdir(parents=True, exist_ok=True)
            (args.seg_cache / tag).write_bytes(pickle.dumps(rec.segmentation))
        iou, per_part = matched_part_iou(rec.segmentation.labels, [f.mask for f in capture.frames])
        print(f"  segmentation: {rec.segmentation.n_parts} labels, matched IoU {iou:.3f} "
              f"({', '.join(f'{v:.2f}' for v in per_part.values())})")
        print("\n".join(label_trace(rec.segmentation.labels, capture.frames)))
        one = Scores()
        score_object(case.obj, case.base, rec.articulation.obj, one)
        score_object(case.obj, case.base, rec.articulation.obj, total)
        for j in one.joints:
            print(f"  joint: {'revolute' if j.revolute else 'prismatic'} type "
                  f"{'ok' if j.type_ok else 'WRONG'}, axis {j.axis_deg:.2f} deg")
        c = one.counts[0]
        print(f"  {c.predicted} movable predicted for {c.true}, {c.correct} right; "
              f"{time.perf_counter() - t0:.0f} s", flush=True)
    for bucket, row in total.table().items():
        print(bucket, {key: round(v, 3) for key, v in row.items()
                       if isinstance(v, float)})
    print(f"load average {load_average()}; buckets by {bucket_of.__name__}")


if __name__ == "__main__":
    main()
