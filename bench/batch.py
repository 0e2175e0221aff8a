"""Benchmark: batch throughput over the 29 PartNet-Mobility objects, local process pool and
Ray, at 1, 2 and N (= CPU count) workers; the per-object overhead each engine adds.

    .venv/bin/python bench/batch.py [--workers 1,2] [--to json,mjcf,urdf,usd,gltf]
                                    [--engines local,ray] [--noop 200]

Each run exports every object to the formats and checks them (100 configurations): the
default `real2code batch export` job, into a fresh folder. Objects per second count the
objects only (wall time from the first submission to the last record); engine start-up
(the pool or the embedded Ray cluster, workers warmed with their imports) is reported
apart. The overhead is measured with a task that does nothing (a batch's own bookkeeping
per object: fingerprint, staging folder, move into place, manifest line). Target (issue 8):
scaling efficiency from 1 to 2 workers, rate(2) / (2 rate(1)), at least 80 %.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _data import SHARED_DATA  # noqa: E402
from _machine import describe  # noqa: E402

from real2code_export.batch import TaskOptions, TaskResult, TaskSpec, run_batch  # noqa: E402
from real2code_export.formats import FORMATS  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
PARTNET = SHARED_DATA / "partnet_mobility"


def noop_task(obj, out: Path, options) -> TaskResult:
    """Writes one small file: what is left is the batch's own cost per object."""
    (out / "done.txt").write_text(obj.id)
    return TaskResult(["done.txt"])


NOOP = TaskSpec("noop", noop_task)


def _load() -> str:
    return " ".join(f"{x:.1f}" for x in os.getloadavg())


def _run(task, inputs, engine: str, workers: int, options, tmp: Path, **kw):
    out = Path(tempfile.mkdtemp(dir=tmp))
    s = run_batch(task, inputs, out, options=options, engine=engine, workers=workers,
                  progress=False, force=True, **kw)
    if s.counts["failed"]:
        raise SystemExit(f"{engine} x{workers}: {s.counts['failed']} failed: {s.failed[:3]}")
    return s


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--workers", default=None, help="comma-separated (default: 1,2,CPU count)")
    p.add_argument("--engines", default="local,ray")
    p.add_argument("--to", default="json,mjcf,urdf,usd,gltf")
    p.add_argument("--configurations", type=int, default=100)
    p.add_argument("--noop", type=int, default=200, help="objects for the overhead run")
    args = p.parse_args()
    if not (PARTNET / "index.json").is_file():
        raise SystemExit(f"PartNet-Mobility data not found at {PARTNET}")
    cpus = os.cpu_count() or 1
    counts = sorted({int(w) for w in args.workers.split(",")} if args.workers else {1, 2, cpus})
    engines = args.engines.split(",")
    options = TaskOptions(formats=tuple(args.to.split(",")), configurations=args.configurations)
    print(f"machine: {describe()}; load average at start {_load()}")
    print(f"job: export to {args.to} + check ({args.configurations} configurations), "
          f"29 PartNet-Mobility objects")

    rates: dict[tuple[str, int], float] = {}
    with tempfile.TemporaryDirectory() as tmp:
        # busy: the share of the workers' time spent inside objects (what the engine keeps
        # fed); cpu: the share of that time the workers had a core (1.0 on an idle machine;
        # less when other processes share the cores). Scaling = busy and cpu held at 2.
        print(f"{'engine':7s} {'workers':>7s} {'wall s':>8s} {'obj/s':>7s} {'median s':>9s} "
              f"{'busy %':>7s} {'cpu %':>6s} {'start-up s':>10s} {'load':>14s}")
        for engine in engines:
            for n in counts:
                s = _run("export", [PARTNET], engine, n, options, Path(tmp))
                rates[(engine, n)] = s.rate
                median = s.to_json()["object_s_median"]
                busy = sum(s.object_seconds) / (s.wall_s * s.workers)
                cpu = sum(s.cpu_seconds) / sum(s.object_seconds)
                print(f"{engine:7s} {n:7d} {s.wall_s:8.1f} {s.rate:7.3f} {median:9.2f} "
                      f"{100 * busy:7.0f} {100 * cpu:6.0f} {s.startup_s:10.1f} {_load():>14s}",
                      flush=True)
        for engine in engines:
            if (engine, 1) in rates and (engine, 2) in rates:
                eff = rates[(engine, 2)] / (2 * rates[(engine, 1)])
                print(f"scaling 1 -> 2 workers, {engine}: {100 * eff:.0f} % "
                      f"({'met' if eff >= 0.8 else 'NOT met'}: target 80 %)")
        for n in counts:
            if ("local", n) in rates and ("ray", n) in rates:
                extra = 1 / rates[("ray", n)] - 1 / rates[("local", n)]
                print(f"Ray vs local at {n} worker(s): {1000 * extra:+.0f} ms per object "
                      "(wall time per object, export job)")

        if args.noop:
            folder = Path(tmp) / "noop_inputs"
            folder.mkdir()
            for k in range(args.noop):
                (folder / f"o{k:04d}{FORMATS['urdf'].output_suffix}").write_text(str(k))
            print(f"overhead: a task that does nothing, {args.noop} objects, "
                  f"{min(2, cpus)} workers")
            for engine in engines:
                s = _run(NOOP, [folder], engine, min(2, cpus), TaskOptions(), Path(tmp),
                         inputs_kind="export")
                print(f"{engine:7s} {1000 * s.wall_s / args.noop:6.1f} ms per object "
                      f"(wall), start-up {s.startup_s:.1f} s", flush=True)
    print(f"load average at end {_load()}")


if __name__ == "__main__":
    main()
