"""Trace `evaluate reconstruction` object by object, stage by stage: the same render
(camera path, room), degradation (sensor preset), isolation, cleanup, segmentation and
reconstruction as `pipeline.evaluate_reconstruction.evaluate` (its functions, its seeds),
with what each stage did written out: the object's pixels kept and the room's left by
isolation, the raw labels and those after the compartments stage
(`compartments.return_to_carcass`) against the true masks pixel by pixel, then fusion,
boxes and the joint predictor (`reconstruct_capture` on that segmentation), each joint
scored and each predicted joint set against the true part its label mostly holds.

    PYTHONPATH=$PWD nice -n 5 .venv/bin/python bench/trace_capture.py \
        --partnet ../shared/data/partnet_mobility --splits dev \
        [--cameras ring|handheld|...] [--room] [--capture phone-lidar] \
        [--only 0,3] [--seg-cache DIR] [--gt] [--set lateral_px=0,holes=0] \
        [--mask-weights auto|clean|noisy|PATH]

``--only`` picks cases by their index in the split (the evaluation's order, so each case's
seed is the evaluation's); ``--seg-cache`` keeps each capture's raw segmentation so the
later stages can be traced again without the mask network; ``--gt`` also runs the
capture's own masks through the same later stages (is a loss the masks' or the fusion's,
boxes' or joint predictor's?); ``--set`` changes a preset's fields (one fault at a time
taken out); ``--mask-weights`` picks the mask network as the command does (auto: by the
noise the cleanup measured; a segmentation cached by another network than the clean one is
kept under its own name).
"""

from __future__ import annotations

import argparse
import pickle
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import load_average  # noqa: E402

from pipeline.compartments import return_to_carcass  # noqa: E402
from pipeline.depth_cleanup import clean_capture  # noqa: E402
from pipeline.evaluate_articulation import partnet_cases, procedural_cases  # noqa: E402
from pipeline.isolate import isolate_object  # noqa: E402
from pipeline.predictors.evaluate import Scores, score_object  # noqa: E402
from pipeline.reconstruct import reconstruct_capture  # noqa: E402
from pipeline.render import render_object  # noqa: E402
from pipeline.segment import segment  # noqa: E402
from pipeline.segment.choose import DEFAULT as DEFAULT_MASK_WEIGHTS  # noqa: E402
from pipeline.segment.choose import MaskWeights, choose  # noqa: E402
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


def label_purity(labels, frames) -> dict[int, tuple[int, int, float, float]]:
    """Each predicted label: (pixels, the true part it mostly is, that share of the label,
    the share of that true part it holds)."""
    p = np.concatenate([a.ravel() for a in labels]).astype(np.int64)
    t = np.concatenate([f.mask.ravel() for f in frames]).astype(np.int64)
    out = {}
    for k in np.unique(p[p > 0]):
        truth = t[p == k]
        counts = np.bincount(truth)
        top = int(np.argmax(counts))
        out[int(k)] = (len(truth), top, counts[top] / len(truth),
                       counts[top] / max(1, int((t == top).sum())))
    return out


def print_labels(title, labels, frames) -> dict:
    purity = label_purity(labels, frames)
    print(f"  {title}: {len(purity)} labels")
    for k, (n, top, share, of_truth) in purity.items():
        print(f"    label {k}: {n} px, {share:.2f} part {top} ({of_truth:.2f} of it)")
    return purity


def run_stages(case, capture, seg, scores, purity=None) -> None:
    rec = reconstruct_capture(capture, segmentation=seg.method if seg.method == "gt"
                              else "learned", completion="segment_only", name=case.obj.name,
                              collision="hull", precomputed_segmentation=seg, texture=False)
    one = Scores()
    score_object(case.obj, case.base, rec.articulation.obj, one)
    score_object(case.obj, case.base, rec.articulation.obj, scores)
    for j in one.joints:
        print(f"    true {'revolute' if j.revolute else 'prismatic'}: type "
              f"{'ok' if j.type_ok else 'WRONG'}, axis {j.axis_deg:.2f} deg")
    for j in rec.articulation.obj.movable_joints:
        k = int(j.child.rsplit("_", 1)[-1]) if j.child.startswith("part_") else None
        what = ""
        if purity and k in purity:
            n, top, share, of_truth = purity[k]
            what = f" on label {k}: {share:.2f} part {top} ({of_truth:.2f} of it, {n} px)"
        print(f"    predicted {j.type.value} {j.child}{what}, "
              f"{len(rec.clouds.get(j.child, []))} points")
    c = one.counts[0]
    print(f"    {c.predicted} movable predicted for {c.true}, {c.correct} right", flush=True)


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
    p.add_argument("--gt", action="store_true", help="also the capture's own masks")
    p.add_argument("--set", default="", help="sensor fields changed, e.g. lateral_px=0,holes=0 "
                   "(one fault at a time taken out of a preset)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--mask-weights", default=DEFAULT_MASK_WEIGHTS,
                   help="auto|clean|noisy|PATH, as real2code reconstruct's (default "
                   f"{DEFAULT_MASK_WEIGHTS}; auto: by the noise the cleanup measured)")
    args = p.parse_args()
    cases = procedural_cases(args.objects, args.seed) if args.objects else \
        partnet_cases(args.partnet, args.splits, args.seed)
    only = {int(x) for x in args.only.split(",") if x.strip()}
    sensor = load_sensor(args.capture)
    changes = {k: float(v) for k, v in (x.split("=") for x in args.set.split(",") if x)}
    sensor = replace(sensor, **changes)
    segmenter = None
    predicted, truth = Scores(), Scores()
    print(f"load average {load_average()}", flush=True)
    for k, case in enumerate(cases):
        if only and k not in only:
            continue
        t0 = time.perf_counter()
        raw = render_object(case.obj, base=case.base, views=12, width=256, height=256,
                            seed=args.seed + k, cameras=args.cameras, distance=args.distance,
                            room=args.room)
        raw = degrade(raw, sensor, args.seed + k)
        capture, cleanup = clean_capture(isolate_object(raw)[0])
        print(f"[{k}] {case.label} ({len(case.obj.parts)} parts, "
              f"{len(case.obj.movable_joints)} movable): {isolation_trace(raw, capture)}; "
              f"cleanup dropped {cleanup['dropped']} filled {cleanup['filled']}", flush=True)
        choice = choose(args.mask_weights, cleanup)
        print(f"  mask network: {choice.used} ({choice.why})", flush=True)
        used = "" if choice.used == "clean" else f"_{choice.used}"  # earlier caches: clean
        tag = (f"{args.cameras}_{args.distance}_{args.capture}{args.set}_{int(args.room)}_"
               f"{args.seed}_{k}{used}.pkl")
        cached = args.seg_cache / tag if args.seg_cache else None
        if cached and cached.is_file():
            seg = pickle.loads(cached.read_bytes())
        else:
            segmenter = segmenter or MaskWeights(args.mask_weights)
            seg = segment(capture, "learned", segmenter=segmenter.for_capture(cleanup)[0])
            if cached:
                cached.parent.mkdir(parents=True, exist_ok=True)
                cached.write_bytes(pickle.dumps(seg))
        print_labels("raw segmentation", seg.labels, capture.frames)
        after = return_to_carcass(capture, seg)
        for move in after.details.get("returned_to_carcass", []):
            print(f"    moved: {move}")
        purity = print_labels("after compartments", after.labels, capture.frames)
        iou, per_part = matched_part_iou(after.labels, [f.mask for f in capture.frames])
        print(f"  matched IoU {iou:.3f} ({', '.join(f'{v:.2f}' for v in per_part.values())})")
        print("  predicted masks:")
        run_stages(case, capture, after, predicted, purity)
        if args.gt:
            print("  true masks:")
            run_stages(case, capture, segment(capture, "gt"), truth)
        print(f"  {time.perf_counter() - t0:.0f} s", flush=True)
    for name, scores in (("predicted", predicted), ("true masks", truth)):
        for bucket, row in scores.table().items():
            print(name, bucket, {key: round(v, 3) for key, v in row.items()
                                 if isinstance(v, float)})
    print(f"load average {load_average()}")


if __name__ == "__main__":
    main()
