"""``real2code evaluate reconstruction``: the whole pipeline from rendered RGB-D to an
articulated object, scored the paper's way.

Every test object (the held-out procedural set and the dev PartNet-Mobility objects of
:mod:`pipeline.evaluate_articulation`, each partly open) is rendered from 12 views
(``pipeline.render``, on a camera path that knows nothing of the joints: a full ring unless
asked otherwise) and reconstructed with ground-truth masks and with predicted masks
(``pipeline.segment``), each with shape completion and with the segment-only baseline.
Scores, by the paper's buckets of part count:

- chamfer distance (``pipeline.chamfer``: 10,000 surface points, squared L2, x 1000 in the
  tables) of the whole object and per part, parts matched optimally;
- the joint metrics of ``pipeline.predictors.evaluate`` (type accuracy, axis error, axis
  position) on the reconstructed object, and the stricter precision and recall of its
  movable joints (extra parts and joints count against it);
- for predicted masks, the matched per-part IoU of the segmentation over all views.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field

import numpy as np

from real2code_export.markdown import table as markdown_table

from .camera_paths import DEFAULT_DISTANCE, DEFAULT_PATH
from .evaluate_articulation import Case
from .predictors.evaluate import (
    BUCKETS,
    MATCH_AXIS_DEG,
    MATCH_POSITION_REL,
    PAPER_FULL,
    JointCount,
    JointScore,
    Scores,
    bucket_of,
    score_object,
)

SETTINGS = (("gt", "learned"), ("gt", "segment_only"), ("learned", "learned"),
            ("learned", "segment_only"))
SETTING_NAMES = {("gt", "learned"): "gt masks + completion",
                 ("gt", "segment_only"): "gt masks, segment only",
                 ("learned", "learned"): "predicted masks + completion",
                 ("learned", "segment_only"): "predicted masks, segment only"}
PAPER_SHAPES = {  # Table 2, CD x 1000: (whole, part) for Real2Code and Real2Code-SegOnly
    "Laptop (2)": ((0.44, 3.02), (1.74, 7.19)), "Box (2)": ((1.31, 5.94), (11.46, 10.52)),
    "Fridge (2-3)": ((0.60, 1.28), (0.90, 23.44)),
    "Furniture (2-4)": ((3.47, 65.79), (17.43, 206.49)),
    "Furniture (5-15)": ((19.70, 118.58), (None, None))}


@dataclass
class ShapeScore:
    bucket: str
    whole: float  # CD x 1000
    part: float  # mean over true parts, CD x 1000
    parts_found: int
    parts_true: int


@dataclass
class SettingResult:
    joints: Scores = field(default_factory=Scores)
    shapes: list[ShapeScore] = field(default_factory=list)
    segmentation_iou: list[tuple[str, float]] = field(default_factory=list)
    failures: list[str] = field(default_factory=list)
    seconds: list[float] = field(default_factory=list)
    mask_weights: list[str] = field(default_factory=list)  # per capture: the network used

    def absorb(self, other: SettingResult) -> None:
        """Add ``other``'s cases (one case's, from :func:`evaluate_case`) after these."""
        self.joints.absorb(other.joints)
        self.shapes += other.shapes
        self.segmentation_iou += other.segmentation_iou
        self.failures += other.failures
        self.seconds += other.seconds
        self.mask_weights += other.mask_weights

    def table(self) -> dict[str, dict[str, float]]:
        joints = self.joints.table()
        out = {}
        for name, *_ in BUCKETS:
            shapes = [s for s in self.shapes if s.bucket == name]
            if not shapes and name not in joints:
                continue
            row = dict(joints.get(name, {}))
            if shapes:
                row["whole_cd"] = float(np.mean([s.whole for s in shapes]))
                row["part_cd"] = float(np.mean([s.part for s in shapes]))
                row["part_count_exact"] = float(np.mean([s.parts_found == s.parts_true
                                                         for s in shapes]))
            ious = [v for b, v in self.segmentation_iou if b == name]
            if ious:
                row["segmentation_iou"] = float(np.mean(ious))
            row["failures"] = sum(1 for f in self.failures if f.startswith(name + ":"))
            out[name] = row
        return out


def _truth_meshes(case: Case) -> list:
    from real2code_export.kinematics import world_part_meshes

    return [m.to_trimesh() for m in world_part_meshes(case.obj, None, case.base).values()]


def case_capture(case: Case, seed: int, *, views: int = 12, size: int = 256,
                 cameras: str = DEFAULT_PATH, distance: str = DEFAULT_DISTANCE,
                 sensor=None, room: bool = False):
    """The capture :func:`evaluate` reconstructs ``case`` from: rendered (seeded), degraded
    by ``sensor`` (a :class:`pipeline.sensors.SensorModel`; clean when None), the object
    isolated and the depth cleaned (once, not once per setting)."""
    from .depth_cleanup import clean_capture
    from .isolate import isolate_object
    from .render import render_object
    from .sensors import PRESETS, degrade

    capture = render_object(case.obj, base=case.base, views=views, width=size, height=size,
                            seed=seed, cameras=cameras, distance=distance, room=room)
    capture = degrade(capture, sensor or PRESETS["clean"], seed)
    return clean_capture(isolate_object(capture)[0])[0]


def score_failure(case: Case, scores: Scores) -> None:
    """A failed reconstruction scored as missing, not hidden: no joint predicted, each true
    one wrong at its worst."""
    bucket = bucket_of(len(case.obj.parts))
    scores.objects[bucket] = scores.objects.get(bucket, 0) + 1
    scores.counts.append(JointCount(bucket, len(case.obj.movable_joints), 0, 0))
    for j in case.obj.movable_joints:
        scores.joints.append(JointScore(bucket, j.type.angular, False, 90.0, None, None, None,
                                        None))


def evaluate(cases: list[Case], *, views: int = 12, size: int = 256, seed: int = 0,
             settings=SETTINGS, segmenter=None, completion_model=None,
             mask_weights=None, cameras: str = DEFAULT_PATH, distance: str = DEFAULT_DISTANCE,
             sensor: str = "clean", room: bool = False, workers: int = 1,
             progress=None) -> dict[tuple[str, str], SettingResult]:
    """Reconstruct every case under every (segmentation, completion) setting and score it;
    ``cameras`` and ``distance`` place the views (:mod:`pipeline.camera_paths`), ``sensor``
    (a preset or sensor JSON, :mod:`pipeline.sensors`) degrades them, ``room`` puts the
    object in a room (:mod:`pipeline.room`) that the pipeline must find it in.
    ``mask_weights`` (:mod:`pipeline.segment.choose`; None: its ``DEFAULT``) picks the
    learned masks' network unless a ``segmenter`` is given.

    ``workers`` > 1: the cases in that many processes, each with its own copy of the shipped
    models (so no ``segmenter`` or ``completion_model`` object may be given) and its share
    of the CPUs for torch; every case is rendered and degraded from its own seed as in one
    process, and the results are merged in the cases' order."""
    from .sensors import load_sensor

    sensor_model = load_sensor(sensor)  # a bad preset fails before any work
    mode = _mask_weights_mode(mask_weights)
    needs = _Needs(masks=segmenter is None and any(s == "learned" for s, _ in settings),
                   completion=completion_model is None
                   and any(c == "learned" for _, c in settings))
    case_options = dict(views=views, size=size, settings=tuple(settings), cameras=cameras,
                        distance=distance, sensor=sensor_model, room=room)
    results = {s: SettingResult() for s in settings}

    def merge(k: int, case: Case, outcome: dict[tuple[str, str], SettingResult]) -> None:
        for key, part in outcome.items():
            results[key].absorb(part)
        if progress:
            used = {r.mask_weights[-1] for r in outcome.values() if r.mask_weights}
            masks = f"; mask network {', '.join(sorted(used))}" if used else ""
            progress(f"{k + 1}/{len(cases)} {case.label} ({len(case.obj.parts)} parts{masks})")

    if workers > 1 and len(cases) > 1:
        if segmenter is not None or completion_model is not None:
            raise ValueError("evaluate: workers > 1 loads the shipped models in each worker; "
                             "a segmenter or completion model object cannot be given")
        from multiprocessing import get_context

        workers = min(workers, len(cases))
        threads = max(1, (os.cpu_count() or 1) // workers)
        jobs = [(case, seed + k, case_options) for k, case in enumerate(cases)]
        with get_context("spawn").Pool(workers, initializer=_start_worker,
                                       initargs=(mode, needs, threads)) as pool:
            for k, outcome in enumerate(pool.imap(_worker_case, jobs)):
                merge(k, cases[k], outcome)
        return results
    models = _load_models(mode, needs)
    models.segmenter = segmenter or models.segmenter
    models.completion_model = completion_model or models.completion_model
    for k, case in enumerate(cases):
        merge(k, case, evaluate_case(case, seed + k, models, **case_options))
    return results


@dataclass(frozen=True)
class _Needs:
    masks: bool  # the learned masks' networks
    completion: bool  # the completion model


@dataclass
class _Models:
    mask_weights: object = None  # pipeline.segment.choose.MaskWeights
    segmenter: object = None
    completion_model: object = None


def _mask_weights_mode(mask_weights) -> str:
    from .segment.choose import DEFAULT

    return str(DEFAULT if mask_weights is None else mask_weights)


def _load_models(mode: str, needs: _Needs) -> _Models:
    """The shipped models a run needs, loaded once (a bad weights file fails before any
    work)."""
    models = _Models()
    if needs.masks:
        from .segment.choose import MaskWeights

        models.mask_weights = MaskWeights(mode)
    if needs.completion:
        from .complete import load_model

        models.completion_model = load_model()
    return models


_WORKER_MODELS: _Models | None = None  # a worker process's own, loaded by _start_worker


def _start_worker(mode: str, needs: _Needs, threads: int) -> None:
    global _WORKER_MODELS
    import torch

    torch.set_num_threads(threads)  # the workers share the CPUs, not each all of them
    _WORKER_MODELS = _load_models(mode, needs)


def _worker_case(job) -> dict[tuple[str, str], SettingResult]:
    case, case_seed, options = job
    return evaluate_case(case, case_seed, _WORKER_MODELS, **options)


def evaluate_case(case: Case, case_seed: int, models: _Models, *, views: int, size: int,
                  settings, cameras: str, distance: str, sensor, room: bool
                  ) -> dict[tuple[str, str], SettingResult]:
    """One case under every setting: its capture rendered and degraded from ``case_seed``
    (once, shared by the settings), each reconstruction scored."""
    from .chamfer import REPORT_SCALE, object_chamfer, part_chamfer
    from .reconstruct import reconstruct_capture
    from .segment.evaluate import matched_part_iou

    results = {s: SettingResult() for s in settings}
    bucket = bucket_of(len(case.obj.parts))
    capture = case_capture(case, case_seed, views=views, size=size, cameras=cameras,
                           distance=distance, sensor=sensor, room=room)
    truth = _truth_meshes(case)
    segmentations = {}
    for seg_method, completion in settings:
        result = results[(seg_method, completion)]
        t0 = time.perf_counter()
        try:
            rec = reconstruct_capture(
                capture, segmentation=seg_method, completion=completion,
                segmenter=models.segmenter if seg_method == "learned" else None,
                mask_weights=models.mask_weights, completion_model=models.completion_model,
                name=case.obj.name, collision="hull",
                precomputed_segmentation=segmentations.get(seg_method), texture=False)
        except Exception as e:  # a failed reconstruction is scored as missing, not hidden
            result.failures.append(f"{bucket}: {case.label}: {type(e).__name__}: {e}")
            score_failure(case, result.joints)
            continue
        segmentations[seg_method] = rec.segmentation
        result.seconds.append(time.perf_counter() - t0)
        score_object(case.obj, case.base, rec.articulation.obj, result.joints)
        pred = list(rec.meshes.values())
        result.shapes.append(ShapeScore(
            bucket, REPORT_SCALE * object_chamfer(pred, truth),
            REPORT_SCALE * part_chamfer(pred, truth).mean, len(pred), len(truth)))
        if "mask_weights" in rec.segmentation.details:
            result.mask_weights.append(rec.segmentation.details["mask_weights"]["used"])
        if seg_method != "gt":
            iou, _ = matched_part_iou(rec.segmentation.labels, [f.mask for f in capture.frames])
            result.segmentation_iou.append((bucket, iou))
    return results


def _fmt(row: dict | None, key: str, fmt: str, scale: float = 1.0) -> str:
    value = None if row is None else row.get(key)
    return "-" if value is None or value != value else fmt.format(scale * value)


def _count(row: dict | None) -> str:
    if row is None or "predicted_joints" not in row:
        return "-"
    return f"{int(row['predicted_joints'])} for {int(row['joints'])}"


def mask_weights_note(results: dict[tuple[str, str], SettingResult], mode: str) -> str | None:
    """What network the predicted masks came from, for the tables' notes: the mode asked and
    how many captures each network segmented."""
    from collections import Counter

    used = next((r.mask_weights for (s, _), r in results.items() if s == "learned"), None)
    if used is None:
        return None
    how = {"auto": "auto: chosen by the depth noise each capture's cleanup measured",
           "clean": "clean (the shipped network)", "noisy": "noisy (forced)"}.get(
               mode, f"{mode} (a file)")
    counts = ", ".join(f"{n} on {k}" for n, k in sorted(Counter(used).items()))
    return (f"Predicted masks: mask network {how}; used: {counts or 'none'} of "
            f"{len(used)} segmented captures.")


def markdown(title: str, tables: dict[str, dict[str, dict]], show_paper: bool,
             notes: list[str] | None = None) -> str:
    """Joint and shape tables: a row per setting (and the paper's full-pipeline row), after
    ``notes`` (how the tables were made)."""
    names = [b for b, *_ in BUCKETS]
    header = ["method", *(f"{b} parts" for b in names)]
    joints = []
    if show_paper:
        joints.append(["Real2Code, full pipeline (paper)",
                       *(f"{PAPER_FULL[b][2]:.2f} / {PAPER_FULL[b][0]:.2f} / -" for b in names)])
    for method, table in tables.items():
        joints.append([method, *(" / ".join([_fmt(table.get(b), "type_accuracy", "{:.2f}"),
                                             _fmt(table.get(b), "axis_error_deg", "{:.2f}"),
                                             _fmt(table.get(b), "position_error_rel",
                                                  "{:.1f} %", 100)])
                                 for b in names)])
    strict = [[method, *(" / ".join([_fmt(table.get(b), "joint_precision", "{:.2f}"),
                                     _fmt(table.get(b), "joint_recall", "{:.2f}"),
                                     _count(table.get(b))])
                         for b in names)] for method, table in tables.items()]
    shapes = [[method, *(" / ".join([_fmt(table.get(b), "whole_cd", "{:.2f}"),
                                     _fmt(table.get(b), "part_cd", "{:.2f}"),
                                     _fmt(table.get(b), "part_count_exact", "{:.2f}"),
                                     _fmt(table.get(b), "segmentation_iou", "{:.3f}")])
                         for b in names)] for method, table in tables.items()]
    lines = [f"### {title}", "", *(f"{n}\n" for n in notes or []),
             "Joints: type accuracy / axis error (degrees) / axis position error (% of the "
             "object's diagonal, revolute joints), each true joint on the "
             "predicted part that stands for its part (most of that part's surface its own; "
             "none: scored wrong at 90 degrees):", "",
             *markdown_table(header, joints),
             "", "Movable joints, extras counted: precision / recall / predicted for true "
             f"(a joint is right with the right type, axis within {MATCH_AXIS_DEG:g} degrees "
             f"and, revolute, its line within {100 * MATCH_POSITION_REL:g} % of the diagonal):",
             "", *markdown_table(header, strict),
             "", "Shapes: chamfer distance x 1000 (whole object / mean per part), the share "
             "of objects whose part count came out right, and the segmentation's matched "
             "per-part IoU over all views:", "", *markdown_table(header, shapes)]
    failures = {m: sum(int(r.get("failures", 0)) for r in t.values()) for m, t in tables.items()}
    if any(failures.values()):
        lines += ["", "Failed reconstructions (scored as wrong joints, no shape): " + ", ".join(
            f"{m}: {n}" for m, n in failures.items() if n)]
    return "\n".join(lines)
