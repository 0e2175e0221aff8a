"""Benchmark: `check` of a 15-part object across three loaders (MJCF in MuJoCo, URDF in
MuJoCo, URDF in Pinocchio) at 100 configurations, loading included.

    .venv/bin/python bench/check.py [--repeat 5]

Target (issue 2, on the 2-core machines): under 2 s.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import describe, timeit  # noqa: E402

from pipeline.procedural import generate  # noqa: E402
from real2code_export.check import check_files  # noqa: E402
from real2code_export.formats import export  # noqa: E402


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--configurations", type=int, default=100)
    args = p.parse_args()
    obj = generate("storage_furniture", 15, 0)
    print(f"machine: {describe()}")
    with tempfile.TemporaryDirectory() as tmp:
        written = export(obj, tmp, ["mjcf", "urdf"])
        files = [written["mjcf"], written["urdf"]]
        report = check_files(files, n_configurations=args.configurations)  # warm imports
        labels = ", ".join(p.label for p in report.probes)
        times = timeit(lambda: check_files(files, n_configurations=args.configurations),
                       args.repeat)
        # the command as a user runs it: a new process, imports and loading included
        cli = [sys.executable, "-m", "real2code_export.cli", "check", *map(str, files),
               "--configurations", str(args.configurations)]
        cold = timeit(lambda: subprocess.run(cli, check=True, capture_output=True), args.repeat)
    print(f"object: {obj.name}, {len(obj.parts)} parts; loaders: {labels}; "
          f"{args.configurations} configurations; ok={report.ok}")
    print(f"check_files (warm process): median {statistics.median(times) * 1000:.0f} ms, "
          f"min {min(times) * 1000:.0f} ms, max {max(times) * 1000:.0f} ms")
    print(f"`real2code check` (new process): median {statistics.median(cold) * 1000:.0f} ms, "
          f"min {min(cold) * 1000:.0f} ms, max {max(cold) * 1000:.0f} ms")


if __name__ == "__main__":
    main()
