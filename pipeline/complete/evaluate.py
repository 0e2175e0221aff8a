"""Shape completion against the segment-only baseline, by the paper's part-count buckets.

    real2code evaluate completion [--objects 40] [--partnet DIR] [--out DIR]

Held-out procedural objects (``pipeline.evaluate_articulation.procedural_cases``: ajar,
randomly placed) and, when given, the dev PartNet-Mobility objects are seen from 12 noisy
views on the capture renderer's 120-degree arc in front of the object (``--arc 360``: a full
ring) by :mod:`.views`, with borders labelled correctly: the points of each part are the
ground truth's, so this measures completion alone. Every part with enough points is meshed
twice, by :func:`complete_part` (with the other parts' points as context) and by
:func:`segment_only_mesh`, and scored against its true mesh with the paper's chamfer
distance (:mod:`pipeline.chamfer`); the whole object is scored on all its meshes together.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from real2code_export.markdown import table as markdown_table

from ..chamfer import REPORT_SCALE, chamfer_distance, object_chamfer
from ..predictors.evaluate import BUCKETS, bucket_of
from .baseline import segment_only_mesh
from .data import MIN_POINTS
from .learned import complete_part, load_model
from .views import DEFAULT_VIEWS, partial_clouds

METHODS = ("completion", "segment_only")
# Real2Code's Table 2 (CD x 1000, part columns), by the paper's category columns.
PAPER_PART_CD = {"completion": {"laptop": 3.02, "box": 5.94, "refrigerator": 1.28,
                                "furniture 2-4": 65.79, "furniture 5-15": 118.58},
                 "segment_only": {"laptop": 7.19, "box": 10.52, "refrigerator": 23.44,
                                  "furniture 2-4": 206.49, "furniture 5-15": None}}


@dataclass
class PartResult:
    name: str
    points: int
    cd: dict[str, float]  # method -> chamfer distance (m^2)


@dataclass
class ObjectResult:
    label: str
    category: str
    n_parts: int
    bucket: str
    whole: dict[str, float] = field(default_factory=dict)
    parts: list[PartResult] = field(default_factory=list)
    unseen: list[str] = field(default_factory=list)  # parts with too few points: not scored
    seconds: dict[str, float] = field(default_factory=dict)


def paper_column(category: str, n_parts: int) -> str:
    """The paper's Table 2 column an object falls in (tables count as furniture)."""
    if category in ("storage_furniture", "table"):
        return "furniture 2-4" if n_parts <= 4 else "furniture 5-15"
    return category


def seen_parts(obj, base, rng: np.random.Generator, arc_deg: float = 120.0):
    """The part meshes in the world and each part's points from 12 views (true labels)."""
    from real2code_export.kinematics import world_part_meshes

    from ..render import front_direction

    meshes = world_part_meshes(obj, None, base)
    settings = replace(DEFAULT_VIEWS, border_swap=0.0, arc_deg=arc_deg)
    clouds = partial_clouds(list(meshes.values()), rng, settings,
                            front=front_direction(obj, base))
    return meshes, clouds


def evaluate_object(obj, base, label: str, rng: np.random.Generator, model,
                    arc_deg: float = 120.0) -> ObjectResult:
    """Both methods on every part of ``obj`` (its observed state, placed at ``base``)."""
    meshes, clouds = seen_parts(obj, base, rng, arc_deg)
    names = list(meshes)
    category = obj.metadata.get("category", "partnet")
    result = ObjectResult(label, category, len(obj.parts), bucket_of(len(obj.parts)))
    predicted: dict[str, list] = {m: [] for m in METHODS}
    truth = []
    seconds = dict.fromkeys(METHODS, 0.0)
    for k, name in enumerate(names):
        if len(clouds[k]) < MIN_POINTS:
            result.unseen.append(name)
            continue
        others = np.concatenate([c for j, c in enumerate(clouds) if j != k])
        gt = meshes[name].to_trimesh()
        t0 = time.perf_counter()
        done = complete_part(clouds[k], context=others, model=model)
        t1 = time.perf_counter()
        raw = segment_only_mesh(clouds[k])
        seconds["completion"] += t1 - t0
        seconds["segment_only"] += time.perf_counter() - t1
        cd = {"completion": chamfer_distance(done, gt), "segment_only": chamfer_distance(raw, gt)}
        result.parts.append(PartResult(name, len(clouds[k]), cd))
        predicted["completion"].append(done)
        predicted["segment_only"].append(raw)
        truth.append(gt)
    if truth:
        result.whole = {m: object_chamfer(predicted[m], truth) for m in METHODS}
    result.seconds = seconds
    return result


def procedural_results(n_objects: int, seed: int = 0, model=None, arc_deg: float = 120.0,
                       progress=print) -> list[ObjectResult]:
    from ..evaluate_articulation import procedural_cases

    model = model if model is not None else load_model()
    results = []
    for k, case in enumerate(procedural_cases(n_objects, seed)):
        rng = np.random.default_rng([seed, k, 17])
        results.append(evaluate_object(case.obj, case.base, case.label, rng, model, arc_deg))
        _report(progress, k, n_objects, results[-1])
    return results


def partnet_results(root: Path, split: str = "dev", seed: int = 0, model=None,
                    arc_deg: float = 120.0, progress=print) -> list[ObjectResult]:
    from ..evaluate_articulation import partnet_cases

    model = model if model is not None else load_model()
    cases = partnet_cases(root, split, seed)
    results = []
    for k, case in enumerate(cases):
        rng = np.random.default_rng([seed, k, 23])
        results.append(evaluate_object(case.obj, case.base, case.label, rng, model, arc_deg))
        _report(progress, k, len(cases), results[-1])
    return results


def _report(progress, k: int, n: int, r: ObjectResult) -> None:
    if progress is None:
        return
    parts = {m: np.mean([p.cd[m] for p in r.parts]) * REPORT_SCALE if r.parts else float("nan")
             for m in METHODS}
    progress(f"[{k + 1}/{n}] {r.label}: part CD x1000 completion {parts['completion']:.2f}, "
             f"segment-only {parts['segment_only']:.2f} ({len(r.parts)} parts)")


def summary(results: list[ObjectResult], key=lambda r: r.bucket,
            order: list[str] | None = None) -> dict[str, dict]:
    """Per group: objects, parts, mean part and whole CD (x1000) per method, and the share
    of parts that completion meshes better than segment-only."""
    groups: dict[str, list[ObjectResult]] = {}
    for r in results:
        groups.setdefault(key(r), []).append(r)
    out = {}
    for name in order or sorted(groups):
        rs = groups.get(name, [])
        parts = [p for r in rs for p in r.parts]
        if not parts:
            continue
        row = {"objects": len(rs), "parts": len(parts),
               "unseen_parts": sum(len(r.unseen) for r in rs)}
        for m in METHODS:
            row[f"part_{m}"] = float(np.mean([p.cd[m] for p in parts])) * REPORT_SCALE
            row[f"whole_{m}"] = float(np.mean([r.whole[m] for r in rs if r.whole])) * REPORT_SCALE
            row[f"seconds_{m}"] = float(np.mean([r.seconds[m] for r in rs]))
        row["completion_better"] = float(np.mean([p.cd["completion"] < p.cd["segment_only"]
                                                  for p in parts]))
        out[name] = row
    return out


def markdown(title: str, rows: dict[str, dict], group: str = "parts") -> str:
    header = [group, "objects / parts", "part CD: completion", "part CD: segment-only",
              "whole CD: completion", "whole CD: segment-only", "parts better completed"]
    cells = [[name, f"{r['objects']} / {r['parts']}", f"{r['part_completion']:.2f}",
              f"{r['part_segment_only']:.2f}", f"{r['whole_completion']:.2f}",
              f"{r['whole_segment_only']:.2f}", f"{100 * r['completion_better']:.0f} %"]
             for name, r in rows.items()]
    return "\n".join([f"### {title}", "", *markdown_table(header, cells)])


def paper_markdown(rows: dict[str, dict]) -> str:
    """Our part CD by the paper's Table 2 columns, next to the paper's own."""
    cols = list(PAPER_PART_CD["completion"])

    def cell(v):
        return "N/A" if v is None else f"{v:.2f}"

    cells = [["Real2Code (paper, PartNet-Mobility, predicted masks)",
              *(cell(PAPER_PART_CD["completion"][c]) for c in cols)],
             ["Real2Code-SegOnly (paper)", *(cell(PAPER_PART_CD["segment_only"][c]) for c in cols)]]
    for m, label in (("completion", "ours: completion (gt masks)"),
                     ("segment_only", "ours: segment-only, alpha shape (gt masks)")):
        cells.append([label, *("-" if c not in rows else cell(rows[c][f"part_{m}"])
                               for c in cols)])
    return "\n".join(["### Part chamfer distance (x1000) by the paper's columns", "",
                      *markdown_table(["method", *cols], cells)])


def bar_figure(rows: dict[str, dict], path: Path, title: str) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(rows)
    x = np.arange(len(names))
    fig, ax = plt.subplots(figsize=(6, 3.2), dpi=120)
    for i, (m, label) in enumerate((("completion", "completion"),
                                    ("segment_only", "segment-only (alpha shape)"))):
        ax.bar(x + (i - 0.5) * 0.38, [rows[n][f"part_{m}"] for n in names], 0.38, label=label)
    ax.set_xticks(x, [f"{n} parts" for n in names])
    ax.set_ylabel("part chamfer distance (x1000, m²)")
    ax.set_title(title)
    ax.legend()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path


def example_figure(obj, base, path: Path, seed: int = 0, model=None,
                   arc_deg: float = 120.0) -> Path:
    """One object: the partial points, the segment-only meshes, the completed meshes and the
    truth, each part in its own colour (surface samples, so any mesh draws fast)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..chamfer import surface_points

    model = model if model is not None else load_model()
    rng = np.random.default_rng(seed)
    meshes, clouds = seen_parts(obj, base, rng, arc_deg)
    names = list(meshes)
    panels = {"partial points (12 views)": [], "segment-only": [], "completion": [],
              "ground truth": []}
    for k, name in enumerate(names):
        if len(clouds[k]) < MIN_POINTS:
            continue
        others = np.concatenate([c for j, c in enumerate(clouds) if j != k])
        pick = rng.choice(len(clouds[k]), min(3000, len(clouds[k])), replace=False)
        panels["partial points (12 views)"].append((k, clouds[k][pick]))
        panels["segment-only"].append((k, surface_points(segment_only_mesh(clouds[k]), 3000)))
        panels["completion"].append(
            (k, surface_points(complete_part(clouds[k], context=others, model=model), 3000)))
        panels["ground truth"].append((k, surface_points(meshes[name].to_trimesh(), 3000)))
    fig = plt.figure(figsize=(12, 3.4), dpi=110)
    colours = plt.get_cmap("tab10")
    for i, (title, parts) in enumerate(panels.items()):
        ax = fig.add_subplot(1, 4, i + 1, projection="3d")
        for k, pts in parts:
            ax.scatter(*pts.T, s=0.3, color=colours(k % 10))
        ax.set_title(title, fontsize=9)
        ax.view_init(elev=25, azim=-35)
        ax.set_axis_off()
        ax.set_box_aspect(np.ptp(np.concatenate([p for _, p in parts]), axis=0))
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path


def cmd_evaluate_completion(args) -> int:
    from real2code_export.atomic import write_text

    t0 = time.perf_counter()
    results = procedural_results(args.objects, args.seed, arc_deg=args.arc)
    order = [b for b, *_ in BUCKETS]
    by_bucket = summary(results, order=order)
    by_column = summary(results, key=lambda r: paper_column(r.category, r.n_parts))
    report = {"procedural": {"by_bucket": by_bucket, "by_paper_column": by_column,
                             "objects": [asdict(r) for r in results]}}
    text = [markdown(f"Held-out procedural objects ({len(results)}), CD x1000", by_bucket),
            "", paper_markdown(by_column)]
    bar_figure(by_bucket, args.out / "completion_by_bucket.png",
               "Held-out procedural objects, ground-truth masks")
    if args.partnet is not None:
        pn = partnet_results(args.partnet, "dev", args.seed, arc_deg=args.arc)
        pn_rows = summary(pn, order=order)
        report["partnet_dev"] = {"by_bucket": pn_rows, "objects": [asdict(r) for r in pn]}
        text += ["", markdown(f"PartNet-Mobility dev objects ({len(pn)}), CD x1000", pn_rows)]
    if args.figure is not None:
        from ..evaluate_articulation import procedural_cases

        case = procedural_cases(args.objects, args.seed)[args.figure]
        example_figure(case.obj, case.base, args.out / "completion_example.png", args.seed,
                       arc_deg=args.arc)
    report["arc_deg"] = args.arc
    report["seconds"] = round(time.perf_counter() - t0, 1)
    write_text(args.out / "completion.json", json.dumps(report, indent=1))
    write_text(args.out / "completion.md", "\n".join(text) + "\n")
    print("\n".join(text))
    print(f"-> {args.out / 'completion.md'}, {args.out / 'completion.json'}")
    return 0
