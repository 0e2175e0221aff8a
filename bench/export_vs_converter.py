"""Benchmark: ``real2code export URDF --to usd`` against urdf-usd-converter (NVIDIA's URDF ->
USD converter) on PartNet-Mobility objects, each as the whole command a user runs (a fresh
process: imports, reading the URDF and its meshes, writing the USD), side by side in one run,
the two alternating so a busy machine slows both alike.

    bench/setup_converters.sh   # .venv-converters with the converters (they cannot share .venv;
                                # REAL2CODE_CONVERTERS=DIR: that venv instead)
    .venv/bin/python bench/export_vs_converter.py [--objects 3] [--repeat 3]

Target (issue 17): ``real2code export`` at least 2x faster than the converter (ratio >= 2).
Both write one object's USD with its physics; the converter also writes its layered asset
structure (an interface layer with payloaded contents), ours one .usda with convex collision
pieces and mass properties (computed from the meshes where the URDF has none).

Ours keeps those hulls and mass properties in a disk cache keyed by the meshes' content
(``real2code_export/meshcache.py``), so each object is measured twice: the first export with
an empty cache (``first``), then the median of ``--repeat`` exports with the cache filled
(``again``: a user re-exporting, a batch rerun), each beside the converter run just after it.
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
from _data import SHARED_DATA  # noqa: E402
from _machine import byte_compile, converters_bin, describe, load_average  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
DATA = SHARED_DATA
CONVERTER = converters_bin() / "urdf_usd_converter"


def _run(command: list[str]) -> tuple[float, float]:
    """Wall seconds and CPU seconds (user + system) of one run of ``command``: on a shared
    machine the CPU time is what the command itself costs, the wall time what a user waits.
    (The CPU includes every process the command waited for: our export's forked reader, as
    the converter's worker threads are in its own.)"""
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
    byte_compile(REPO / "real2code_export")
    index = json.loads((root / "index.json").read_text())
    ids = [e["id"] for e in index if e["split"] == "dev"][:args.objects]
    print(f"machine: {describe()}; load average at start {load_average()}")
    print(f"{'object':8s} {'run':6s} {'wall s: ours':>12s} {'converter':>10s} {'ratio':>6s}   "
          f"{'cpu s: ours':>11s} {'converter':>10s} {'ratio':>6s}  (again: medians of "
          f"{args.repeat} runs)")
    totals = {(kind, run): [0.0, 0.0] for kind in ("wall", "cpu") for run in ("first", "again")}
    with tempfile.TemporaryDirectory() as tmp:
        for oid in ids:
            urdf = str(root / oid / "mobility.urdf")
            runs: dict[str, list[tuple[float, float]]] = {"ours": [], "theirs": []}
            os.environ["REAL2CODE_CACHE"] = str(Path(tmp) / f"cache_{oid}")  # empty: "first"
            for k in range(args.repeat + 1):
                out = Path(tmp) / f"{oid}_{k}"
                runs["ours"].append(_run([ours, "export", urdf, "--to", "usd", "--out",
                                          str(out / "a")]))
                runs["theirs"].append(_run([str(CONVERTER), urdf, str(out / "b")]))
            for run, pick in (("first", lambda r: r[0]),
                              ("again", lambda r: statistics.median(r[1:]))):
                row = []
                for i, kind in enumerate(("wall", "cpu")):
                    a = pick([r[i] for r in runs["ours"]])
                    b = pick([r[i] for r in runs["theirs"]])
                    totals[kind, run][0] += a
                    totals[kind, run][1] += b
                    row.append(f"{a:12.3f} {b:10.3f} {b / a:6.2f}")
                print(f"{oid:8s} {run:6s} " + "   ".join(row))
    for (kind, run), (a, b) in totals.items():
        verdict = "met" if b / a >= 2 else "NOT met"
        print(f"all {len(ids)}, {kind}, {run}: real2code {a:.2f} s, converter {b:.2f} s, "
              f"converter/real2code = {b / a:.2f} (target >= 2: {verdict})")
    _floor(ours, args.repeat)
    print(f"load average at end {load_average()}")


# what each command imports before any work: numpy and USD's modules (each venv its own; ours
# writes through Sdf alone, formats/usd/layer.py; the converter uses the schema modules)
_IMPORTS = {"real2code": "import numpy; from pxr import Sdf, Gf, Vt",
            "converter": "import numpy; from pxr import Usd, UsdGeom, UsdPhysics, UsdShade, Sdf, Gf, Vt"}


def _floor(ours: str, repeat: int) -> None:
    """The imports alone, in each tool's interpreter, alternating as above: the CPU no export
    of either tool can go below, beside what their exports cost."""
    pythons = {"real2code": Path(ours).parent / "python", "converter": CONVERTER.parent / "python"}
    cpu: dict[str, list[float]] = {name: [] for name in pythons}
    for _ in range(max(repeat, 3)):
        for name, python in pythons.items():
            cpu[name].append(_run([str(python), "-c", _IMPORTS[name]])[1])
    print("imports alone, cpu s, median: " + ", ".join(
        f"{name} ({_IMPORTS[name]}) {statistics.median(v):.3f}" for name, v in cpu.items()))


if __name__ == "__main__":
    main()
