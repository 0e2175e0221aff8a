"""Benchmark: ``real2code export URDF --to usd`` against urdf-usd-converter (NVIDIA's URDF ->
USD converter) on PartNet-Mobility objects, each as the whole command a user runs (a fresh
process: imports, reading the URDF and its meshes, writing the USD), side by side in one run,
the two alternating so a busy machine slows both alike.

    bench/setup_converters.sh   # .venv-converters with the converters (they cannot share .venv)
    .venv/bin/python bench/export_vs_converter.py [--objects 3] [--repeat 3]

Target (issue 17): ``real2code export`` at least 2x faster than the converter (ratio >= 2).
Both write one object's USD with its physics; the converter also writes its layered asset
structure (an interface layer with payloaded contents), ours one .usda with convex collision
pieces and mass properties (computed from the meshes where the URDF has none).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import describe, load_average  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("REAL2CODE_SHARED_DATA", REPO.parent / "shared" / "data"))
CONVERTER = REPO / ".venv-converters" / "bin" / "urdf_usd_converter"


def _run(command: list[str]) -> tuple[float, float]:
    """Wall seconds and CPU seconds (user + system) of one run of ``command``: on a shared
    machine the CPU time is what the command itself costs, the wall time what a user waits."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--objects", type=int, default=3, help="the first N dev objects (index.json)")
    p.add_argument("--repeat", type=int, default=3, help="runs of each command per object")
    args = p.parse_args()
    root = DATA / "partnet_mobility"
    if not (root / "index.json").is_file():
        sys.exit(f"PartNet-Mobility data not found at {root} (set REAL2CODE_SHARED_DATA)")
    if not CONVERTER.is_file():
        sys.exit(f"{CONVERTER} not found: run bench/setup_converters.sh first")
    ours = shutil.which("real2code", path=str(Path(sys.executable).parent)) or "real2code"
    os.environ["PYTHONPATH"] = str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")
    index = json.loads((root / "index.json").read_text())
    ids = [e["id"] for e in index if e["split"] == "dev"][:args.objects]
    print(f"machine: {describe()}; load average at start {load_average()}")
    print(f"{'object':8s} {'wall s: ours':>12s} {'converter':>10s} {'ratio':>6s}   "
          f"{'cpu s: ours':>11s} {'converter':>10s} {'ratio':>6s}  (medians of {args.repeat} runs)")
    totals = {"wall": [0.0, 0.0], "cpu": [0.0, 0.0]}
    with tempfile.TemporaryDirectory() as tmp:
        for oid in ids:
            urdf = str(root / oid / "mobility.urdf")
            runs: dict[str, list[tuple[float, float]]] = {"ours": [], "theirs": []}
            for k in range(args.repeat):
                out = Path(tmp) / f"{oid}_{k}"
                runs["ours"].append(_run([ours, "export", urdf, "--to", "usd", "--out",
                                          str(out / "a")]))
                runs["theirs"].append(_run([str(CONVERTER), urdf, str(out / "b")]))
            row = []
            for i, kind in enumerate(("wall", "cpu")):
                a = statistics.median(r[i] for r in runs["ours"])
                b = statistics.median(r[i] for r in runs["theirs"])
                totals[kind][0] += a
                totals[kind][1] += b
                row.append(f"{a:12.3f} {b:10.3f} {b / a:6.2f}")
            print(f"{oid:8s} " + "   ".join(row))
    for kind, (a, b) in totals.items():
        verdict = "met" if b / a >= 2 else "NOT met"
        print(f"all {len(ids)}, {kind}: real2code {a:.2f} s, converter {b:.2f} s, "
              f"converter/real2code = {b / a:.2f} (target >= 2: {verdict})")
    print(f"load average at end {load_average()}")

if __name__ == "__main__":
    main()
