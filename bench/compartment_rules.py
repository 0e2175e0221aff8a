"""Benchmark: what each rule of the compartments stage (``pipeline/compartments.py``) does to
the true parts and the movable joints of PartNet-Mobility dev and holdout, side by side.

Each object is captured and segmented once, as ``real2code evaluate reconstruction`` does it
(same seeds, camera path, sensor; predicted masks), and the raw segmentation cached; then the
compartments stage runs with every rule switched off in turn (and as an earlier commit had
it, ``--commits``), and fusion, boxes and the joint predictor (segment-only completion) run
on each result, scored as the evaluation scores it. Per variant and split: the true moving
parts that keep a label of their own (a label most of whose points are that part's),
movable-joint precision / recall / predicted for true, how many of the joints scored right
are on stand-ins (a label mostly of other parts' points, a piece of the carcass, matched
to a true part the masks never found, its joint counted right when its type and axis agree:
the score's matching by centres did that until session 21; matching by surfaces it should
count none, which this column checks), type accuracy and axis error. With
``--trace`` each step of today's stage is followed on every object: the points of true
moving parts it moved, and the true moving parts that lost their last label to it;
``--trace-only`` does only that (seconds an object, once cached).

    PYTHONPATH=$PWD .venv/bin/python bench/compartment_rules.py \\
        --partnet ../shared/data/partnet_mobility --splits dev,holdout \\
        --cache /tmp/compartment_cache [--commits 9473fb3] [--trace] [--only 0,3]

The holdout is a benchmark: report it, do not tune a rule to it.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import importlib.util
import pickle
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import describe, load_average  # noqa: E402

import pipeline.compartments as compartments  # noqa: E402
from pipeline.evaluate_articulation import Case, partnet_cases  # noqa: E402
from pipeline.evaluate_reconstruction import case_capture, score_failure  # noqa: E402
from pipeline.predictors.evaluate import (  # noqa: E402
    BUCKETS,
    MATCH_AXIS_DEG,
    MATCH_POSITION_REL,
    Scores,
    bucket_of,
    score_object,
)

STEPS = ("return_stray_pieces", "find_level_fronts", "split_panels", "claim_panels",
         "return_compartments", "give_protrusions", "give_past_walls", "return_enclosed",
         "merge_nested", "merge_faces", "merge_behind", "return_past_square_panels",
         "return_frontless", "return_face_fronts", "split_fronts",
         "merge_shell")  # return_to_carcass's order
ENCLOSED_KINDS = ("small", "thick", "deep_m", "through")


# -- the cache: each object's capture and raw segmentation, once ------------------------------
def cached(cache: Path, split: str, k: int, case: Case, seed: int, segmenter) -> dict:
    """The capture and raw (pre-compartments) segmentation of the ``k``-th object of
    ``split``, made as the evaluation makes them, from ``cache`` when there."""
    from pipeline.depth_cleanup import clean_capture
    from pipeline.isolate import isolate_object
    from pipeline.segment import segment

    path = cache / split / f"{k:02d}_{case.label.split()[0]}.pkl"
    if path.is_file():
        return pickle.loads(path.read_bytes())
    t0 = time.perf_counter()
    capture = case_capture(case, seed + k)
    # reconstruct_capture isolates and cleans again before segmenting: its capture is this one
    inner = clean_capture(isolate_object(capture)[0])[0]
    raw = segment(inner, "learned", segmenter=segmenter)
    item = {"capture": capture, "inner": inner, "raw": raw,
            "seconds": time.perf_counter() - t0}
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_bytes(pickle.dumps(item))
    tmp.replace(path)
    return item


# -- variants of the stage ------------------------------------------------------------------
def _off(cloud, labels, *args, **kwargs):
    return labels.copy(), []


@contextlib.contextmanager
def patched(**attrs):
    old = {name: getattr(compartments, name) for name in attrs}
    try:
        for name, value in attrs.items():
            setattr(compartments, name, value)
        yield
    finally:
        for name, value in old.items():
            setattr(compartments, name, value)


def _without_kinds(*names: str):
    original = compartments.enclosed_kinds

    def kinds(*args, **kwargs):
        return {k: v for k, v in original(*args, **kwargs).items() if k not in names}
    return kinds


def _strays_to_carcass(cloud, labels, points, exclude):
    return np.ones(len(points), dtype=labels.dtype)


def module_at(commit: str):
    """``pipeline/compartments.py`` as ``commit`` had it, loaded beside today's."""
    text = subprocess.run(["git", "show", f"{commit}:pipeline/compartments.py"], check=True,
                          capture_output=True, text=True).stdout
    folder = Path(tempfile.mkdtemp(prefix="compartments_"))
    path = folder / f"compartments_{commit}.py"
    path.write_text(text)
    spec = importlib.util.spec_from_file_location(f"pipeline._compartments_{commit}", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # (its dataclasses look themselves up there)
    spec.loader.exec_module(module)
    return module


def variants(commits: list[str]) -> dict[str, tuple]:
    """name -> (the stage's function, the patches it runs under)."""
    out = {"today": (None, {})}
    for step in STEPS:
        out[f"no {step}"] = (None, {step: _off})
    for kind in ENCLOSED_KINDS:
        out[f"no return_enclosed:{kind}"] = (None, {"enclosed_kinds": _without_kinds(kind)})
    # a part may be returned for several reasons: session 18's two together
    out["no return_enclosed:deep_m+through"] = (
        None, {"enclosed_kinds": _without_kinds("deep_m", "through")})
    out["no return_enclosed:strays to nearest"] = (None, {"_nearest_label": _strays_to_carcass})
    out["no stage"] = (lambda capture, seg: seg, {})
    for commit in commits:
        out[f"at {commit}"] = (module_at(commit).return_to_carcass, {})
    return out


def run_stage(variant: tuple, capture, raw):
    function, patches = variant
    with patched(**patches):
        return (function or compartments.return_to_carcass)(capture, raw)


# -- truth ------------------------------------------------------------------------------------
def point_truth(capture, points: np.ndarray) -> np.ndarray:
    """Each fused point's true part (mask value, 0 none): the nearest masked pixel's."""
    from scipy.spatial import cKDTree

    from pipeline.fuse import point_map

    clouds, values = [], []
    for frame in capture.frames:
        pts, valid = point_map(frame)
        keep = valid & (frame.mask > 0)
        clouds.append(pts[keep])
        values.append(frame.mask[keep])
    return np.concatenate(values)[cKDTree(np.concatenate(clouds)).query(points)[1]]


def moving_parts(case: Case, capture) -> dict[int, str]:
    """Mask value -> name of each part a movable joint moves."""
    children = {j.child for j in case.obj.movable_joints}
    return {k + 1: name for k, name in enumerate(capture.parts) if name in children}


def kept(labels: np.ndarray, truth: np.ndarray, moving: dict[int, str]) -> set[int]:
    """The true moving parts that own a label (most of its points theirs)."""
    owners = set()
    for label in np.unique(labels):
        values, counts = np.unique(truth[labels == label], return_counts=True)
        owners.add(int(values[np.argmax(counts)]))
    return owners & set(moving)


# -- the downstream stages, scored ------------------------------------------------------------
def reconstruct_scored(case: Case, capture, seg) -> tuple[Scores, dict[str, int]]:
    """The evaluation's score of ``seg`` run on through fusion, boxes and the joint
    predictor, and the label each true part was matched to."""
    from pipeline.reconstruct import reconstruct_capture

    scores = Scores()
    try:
        rec = reconstruct_capture(capture, segmentation="learned", completion="segment_only",
                                  name=case.obj.name, collision="hull",
                                  precomputed_segmentation=seg, texture=False)
    except Exception:  # scored as the evaluation scores it
        score_failure(case, scores)
        return scores, {}
    match = score_object(case.obj, case.base, rec.articulation.obj, scores)
    # predicted parts are named by their label (pipeline.reconstruct: part_<label>)
    return scores, {t: int(p.rsplit("_", 1)[1]) for t, p in match.items()}


def stand_ins(case: Case, scores: Scores, match: dict[str, int], labels: np.ndarray,
              truth: np.ndarray, capture) -> int:
    """How many of the joints scored right are on a stand-in: a label matched to the true
    part (as the score matches) most of whose points are not that part's (a piece of the
    carcass read as a slide along a button's axis, counted right by the centre matching
    before session 21)."""
    index = {name: k + 1 for k, name in enumerate(capture.parts)}
    count = 0
    for joint, score in zip(case.obj.movable_joints, scores.joints, strict=True):
        label = match.get(joint.child)
        if right(score) and label is not None and np.mean(
                truth[labels == label] == index[joint.child]) < 0.5:
            count += 1
    return count


def right(j) -> bool:
    return j.type_ok and j.axis_deg <= MATCH_AXIS_DEG and (
        j.position_rel is None or j.position_rel <= MATCH_POSITION_REL)


def summary(per_object: list[tuple[Scores, int, int, int]]) -> str:
    """By bucket: kept / true moving parts; precision / recall / predicted for true, joints
    right on stand-ins; type / axis degrees."""
    cells = []
    for name, *_ in BUCKETS:
        rows = [row for row in per_object if name in row[0].objects]
        if not rows:
            cells.append("-")
            continue
        merged = Scores()
        for s, *_ in rows:
            merged.joints += s.joints
            merged.counts += s.counts
            merged.objects[name] = merged.objects.get(name, 0) + 1
        t = merged.table()[name]
        cells.append(f"{sum(r[1] for r in rows)}/{sum(r[2] for r in rows)}; "
                     f"{t['joint_precision']:.2f} / {t['joint_recall']:.2f} / "
                     f"{int(t['predicted_joints'])} for {int(t['joints'])}, "
                     f"{sum(r[3] for r in rows)} on stand-ins; "
                     f"{t['type_accuracy']:.2f} / {t['axis_error_deg']:.2f}")
    return " | ".join(cells)


def trace(item: dict, case: Case) -> list[str]:
    """Each step of today's stage on one object: the true moving parts whose last label it
    took, and those it gave one."""
    inner, raw = item["inner"], item["raw"]
    truth = point_truth(inner, raw.points)
    moving = moving_parts(case, inner)
    steps: list[tuple[str, np.ndarray, np.ndarray, list]] = []

    def recording(name, function):
        def wrapper(cloud, labels, *args, **kwargs):
            out, moved = function(cloud, labels, *args, **kwargs)
            steps.append((name, labels, out, moved))
            return out, moved
        return wrapper

    with patched(**{s: recording(s, getattr(compartments, s)) for s in STEPS}):
        compartments.return_to_carcass(inner, raw)
    lines = []
    names = {k + 1: name for k, name in enumerate(inner.parts)}
    for name, before, after, moved in steps:
        lost = kept(before, truth, moving) - kept(after, truth, moving)
        found = kept(after, truth, moving) - kept(before, truth, moving)
        if lost or found:
            lines.append(f"  {name}: lost {sorted(moving[t] for t in lost)}, gave a label to "
                         f"{sorted(moving[t] for t in found)}; moves {moved}")
        texts = moves(before, after, truth, names, set(moving))
        lines += [f"  {name}: {text}" for text in texts]
        if texts and not (lost or found):
            lines.append(f"  {name}: its moves {moved}")
    return lines


def _mode(values: np.ndarray) -> int:
    found, counts = np.unique(values, return_counts=True)
    return int(found[np.argmax(counts)])


def _share(truth: np.ndarray, names: dict[int, str]) -> str:
    found, counts = np.unique(truth, return_counts=True)
    order = np.argsort(-counts)[:3]
    return ", ".join(f"{names.get(int(found[i]), 'none')} {counts[i] / len(truth):.0%}"
                     for i in order)


def moves(before: np.ndarray, after: np.ndarray, truth: np.ndarray, names: dict[int, str],
          moving: set[int]) -> list[str]:
    """What a step moved, whatever the renumbering: each label's points that left the label
    it went on as (the after-label holding most of them, when most of that one's points were
    its own; else it was merged whole), when most of them are a true moving part's."""
    owner = {int(a): _mode(before[after == a]) for a in np.unique(after)}
    out = []
    for label in np.unique(before):
        mine = before == label
        goes_on = _mode(after[mine])
        moved = mine if owner[goes_on] != label else mine & (after != goes_on)
        for to in np.unique(after[moved]):
            which = moved & (after == to)
            if _mode(truth[which]) not in moving:
                continue
            where = "the carcass" if to == 1 else f"label {to} ({_share(truth[after == to], names)})"
            out.append(f"{which.sum()} of label {label}'s {mine.sum()} points ({_share(truth[which], names)}) "
                       f"-> {where}")
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--partnet", type=Path, required=True)
    p.add_argument("--splits", default="dev,holdout")
    p.add_argument("--cache", type=Path, required=True)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--commits", default="", help="also run the stage as these commits had it")
    p.add_argument("--variants", default="", help="only these variants (comma-separated)")
    p.add_argument("--only", default="", help="only these object indices (comma-separated)")
    p.add_argument("--trace", action="store_true")
    p.add_argument("--trace-only", action="store_true",
                   help="only the trace (cached objects: seconds an object)")
    args = p.parse_args()
    print(f"machine: {describe()}; load average {load_average()}", flush=True)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    print(f"code: {commit}", flush=True)
    chosen = variants([c for c in args.commits.split(",") if c])
    if args.variants:
        names = [n.strip() for n in args.variants.split(",")]
        chosen = {n: chosen[n] for n in ["today", *names] if n in chosen}
    only = {int(x) for x in args.only.split(",") if x}
    segmenter = None
    results: dict[str, dict[str, list]] = {}
    downstream: dict[str, Scores] = {}  # by the stage's labels: most variants move nothing
    t0, c0 = time.perf_counter(), time.process_time()
    for split in [s for s in args.splits.split(",") if s]:
        cases = partnet_cases(args.partnet, split, args.seed)
        for k, case in enumerate(cases):
            if only and k not in only:
                continue
            if segmenter is None:
                from pipeline.segment import get_segmenter

                segmenter = get_segmenter("learned")
            item = cached(args.cache, split, k, case, args.seed, segmenter)
            if args.trace_only:
                print(f"{split} {k} {case.label} [{bucket_of(len(case.obj.parts))}]")
                print("\n".join(trace(item, case)), flush=True)
                continue
            truth = point_truth(item["inner"], item["raw"].points)
            moving = moving_parts(case, item["inner"])
            line = []
            for name, variant in chosen.items():
                seg = run_stage(variant, item["inner"], item["raw"])
                key = (f"{split}{k}:" + hashlib.sha1(seg.point_labels.tobytes()).hexdigest())
                if key not in downstream:
                    downstream[key] = reconstruct_scored(case, item["capture"], seg)
                scores, match = downstream[key]
                have = kept(seg.point_labels, truth, moving)
                standing_in = stand_ins(case, scores, match, seg.point_labels, truth,
                                        item["inner"])
                results.setdefault(name, {}).setdefault(split, []).append(
                    (scores, len(have), len(moving), standing_in))
                c = scores.counts[0]
                line.append(f"{name}: {len(have)}/{len(moving)} kept, {c.correct} right "
                            f"({standing_in} on stand-ins), {c.predicted} for {c.true}")
            print(f"{split} {k} {case.label} [{bucket_of(len(case.obj.parts))}]", flush=True)
            base = line[0]
            print(f"    {base}", flush=True)
            for text in line[1:]:
                if text.split(": ", 1)[1] != base.split(": ", 1)[1]:
                    print(f"    {text}", flush=True)
            if args.trace:
                for text in trace(item, case):
                    print(text, flush=True)
    print(f"\nwall {time.perf_counter() - t0:.0f} s, CPU {time.process_time() - c0:.0f} s, "
          f"load average {load_average()}")
    names = [b for b, *_ in BUCKETS]
    print("\nper variant and split, by bucket (" + ", ".join(names) + " parts): true moving "
          "parts with a label of their own; precision / recall / predicted for true, right "
          "joints on stand-ins (labels mostly not the part they were matched to); "
          "type / axis degrees")
    for split in [s for s in args.splits.split(",") if s]:
        print(f"\n| {split} | " + " | ".join(f"{b} parts" for b in names) + " |")
        print("|---|" + "---|" * len(names))
        for name, by_split in results.items():
            if split in by_split:
                print(f"| {name} | {summary(by_split[split])} |")


if __name__ == "__main__":
    main()
