"""Benchmark and agreement table: `real2code simulate` per object and per engine.

    .venv/bin/python bench/dynamics.py [--engines a,b] [--objects cabinet,generated,partnet]
        [--experiments swing,laws,limit | drop,shut]

Objects: the shipped cabinet (pipeline/samples/cabinet, the demo's ground truth), a demo output if
given (--demo DIR/object.json), one generated object of each of 5 categories, and the first
5 dev PartNet-Mobility objects (../shared/data; skipped when absent). For every object and
engine: the worst joint error against MuJoCo's MJCF over the three experiments (swing, laws,
limit; 2 s at 1 ms), the worst against the converged motion in `limit` (MuJoCo at 1/64
step: `real2code simulate`'s reference where MuJoCo at the step has not converged), the
verdict as `simulate` gives it, and the engine's wall time beside MuJoCo's
(a ratio from one run; an engine's start-up counts once per object: one process a module).
With the contact experiments (drop, shut) each engine is judged alone, MuJoCo included: a
cell says whether every box stayed in its drawer and every door stopped at its frame.
Prints a markdown table (docs/engines.md holds the one measured here).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import warnings
from collections import defaultdict
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))
from _data import SHARED_DATA  # noqa: E402
from _machine import describe  # noqa: E402

from pipeline.procedural import generate  # noqa: E402
from real2code_export.dynamics.contacts import CONTACT_EXPERIMENTS  # noqa: E402
from real2code_export.dynamics.run import ENGINES, REFERENCE, simulate_file  # noqa: E402
from real2code_export.formats import object_json  # noqa: E402

CATEGORIES = [("storage_furniture", 1), ("table", 2), ("refrigerator", 3), ("laptop", 4),
              ("box", 5)]
PARTNET = SHARED_DATA / "partnet_mobility"


def objects(kinds: list[str], demo: str | None, folder: Path) -> list[tuple[str, Path]]:
    out = []
    if "cabinet" in kinds:
        out.append(("pipeline/samples/cabinet", REPO / "pipeline" / "samples" / "cabinet" / "object.json"))
    if demo:
        out.append(("demo output", Path(demo)))
    if "generated" in kinds:
        for category, seed in CATEGORIES:
            d = folder / category
            d.mkdir()
            out.append((f"generated {category}", object_json.save(generate(category, seed=seed),
                                                                   d)))
    if "partnet" in kinds and (PARTNET / "index.json").is_file():
        index = json.loads((PARTNET / "index.json").read_text())
        dev = [e for e in index if e["split"] == "dev"][:5]
        out += [(f"PartNet {e['id']} ({e['category']})", PARTNET / e["id"] / "mobility.urdf")
                for e in dev]
    return out


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--engines", default=",".join(ENGINES))
    p.add_argument("--objects", default="cabinet,generated,partnet")
    p.add_argument("--demo", help="a demo output's object.json, added to the objects")
    p.add_argument("--experiments", default="swing,laws,limit")
    args = p.parse_args()
    engines = [e for e in args.engines.split(",") if e]
    experiments = [e for e in args.experiments.split(",") if e]
    if set(experiments) <= set(CONTACT_EXPERIMENTS):
        contacts(args, engines, experiments)
        return
    print(f"machine: {describe()}")
    labels = [REFERENCE.label] + [ENGINES[e].label for e in engines if e != REFERENCE.name]
    # each object's row as soon as it is measured: a long run cut short keeps what it did
    print("\n| object | joints | verdict | " + " | ".join(labels) + " |")
    print("|---|---|---|" + "---|" * len(labels), flush=True)
    totals: dict[str, float] = defaultdict(float)
    failed = []
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, path in objects(args.objects.split(","), args.demo, Path(tmp)):
            report = simulate_file(path, engines, experiments, faithful_collision=True)
            worst: dict[str, tuple[float, float, float, str]] = {}
            converged: dict[str, float] = {}
            for r in report.runs:
                a, m, s, st = worst.get(r.engine, (0.0, 0.0, 0.0, "ok"))
                st = st if r.status in ("ok", "reference") else r.status
                worst[r.engine] = (max(a, r.max_angle), max(m, r.max_distance), s + r.seconds,
                                   st)
                if r.converged is not None:
                    converged[r.engine] = max(converged.get(r.engine, 0.0), r.converged[0])
                if r.status not in ("ok", "reference", "skipped"):
                    failed.append(f"{name}: {r.experiment} {r.engine}: {r.status} "
                                  f"{r.worst_joint} {r.message}")
            joints = len(report.experiments[0].joints) if report.experiments else 0
            cells = []
            for label in labels:
                if label not in worst:
                    cells.append("-")
                    continue
                a, m, s, st = worst[label]
                totals[label] += s
                against = f" (converged {converged[label]:.1e} rad)" if label in converged \
                    else ""
                if label == REFERENCE.label:
                    cells.append(f"reference{against}, {s:.1f} s")
                elif st == "skipped":
                    cells.append("skipped")
                else:
                    ratio = s / max(worst[REFERENCE.label][2], 1e-9)
                    cells.append(f"{a:.1e} rad / {m:.1e} m{against}, {s:.1f} s (x{ratio:.1f})"
                                 + ("" if st == "ok" else f" **{st}**"))
            verdict = "ok" if report.ok else "**disagree**"
            print("| " + " | ".join((name, str(joints), verdict, *cells)) + " |", flush=True)
    print()
    print("total seconds: " + ", ".join(f"{k} {v:.1f}" for k, v in totals.items()))
    for line in failed:
        print("beyond tolerance:", line)


def contacts(args, engines: list[str], experiments: list[str]) -> None:
    """One row per object: per engine, each contact experiment's verdict and its worst
    figure (a door's travel past its closed value, a box's distance from its floor)."""
    print(f"machine: {describe()}")
    chosen = [REFERENCE] + [ENGINES[e] for e in engines if e != REFERENCE.name]
    labels = [e.label for e in chosen if e.contacts]
    rows, failed = [], []
    totals: dict[str, float] = defaultdict(float)
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, path in objects(args.objects.split(","), args.demo, Path(tmp)):
            report = simulate_file(path, engines, experiments, faithful_collision=True)
            cells = {label: [] for label in labels}
            seconds: dict[str, float] = defaultdict(float)
            for r in report.runs:
                if r.engine not in cells:
                    continue
                what = f"{r.experiment} {r.status}"
                if r.status in ("ok", "disagree"):
                    what += (f" ({r.max_distance * 1000:.0f} mm)" if r.experiment == "drop"
                             else f" ({r.max_angle:.3f} rad)")
                cells[r.engine].append(what)
                seconds[r.engine] += r.seconds
                totals[r.engine] += r.seconds
                if r.status not in ("ok", "skipped"):
                    failed.append(f"{name}: {r.experiment} {r.engine}: {r.status} {r.message}")
            tested = {e.name: e for e in report.experiments}
            what = ", ".join(f"{len(e.boxes)} box(es)" if n == "drop" else
                             f"{sum(1 for v in e.v0 if v)} door(s)" for n, e in tested.items())
            rows.append((name, what or "nothing to test", *(
                "; ".join(cells[label]) + f", {seconds[label]:.1f} s" if cells[label] else "-"
                for label in labels)))
            print(f"{name}: {'ok' if report.ok else 'FAILS'}", flush=True)
    print()
    print("| object | tested | " + " | ".join(labels) + " |")
    print("|---|---|" + "---|" * len(labels))
    for row in rows:
        print("| " + " | ".join(row) + " |")
    print()
    print("total seconds: " + ", ".join(f"{k} {v:.1f}" for k, v in totals.items()))
    for line in failed:
        print("fails:", line)


if __name__ == "__main__":
    main()
