"""Benchmark: ``real2code --help`` as a user runs it (the console script, a fresh process each
time), beside ``python -c pass`` (the interpreter's own start) in the same run.

    .venv/bin/python bench/cli_startup.py [--repeat 15]

Target (issue 17): ``real2code --help`` under 0.15 s (median).
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import describe, load_average  # noqa: E402

TARGET_S = 0.15


def _seconds(command: list[str], repeat: int) -> list[float]:
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
        out.append(time.perf_counter() - t0)
    return out


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--repeat", type=int, default=15)
    args = p.parse_args()
    script = shutil.which("real2code", path=str(Path(sys.executable).parent)) or "real2code"
    repo = str(Path(__file__).resolve().parents[1])
    os.environ["PYTHONPATH"] = repo + os.pathsep + os.environ.get("PYTHONPATH", "")
    print(f"machine: {describe()}; load average {load_average()}")
    cases = [("python -c pass", [sys.executable, "-c", "pass"]),
             ("real2code --help", [script, "--help"]),
             ("real2code export --help", [script, "export", "--help"])]
    print(f"{'command':26s} {'median s':>9s} {'min s':>7s} {'max s':>7s}  ({args.repeat} runs)")
    medians = {}
    for label, command in cases:
        s = _seconds(command, args.repeat)
        medians[label] = statistics.median(s)
        print(f"{label:26s} {medians[label]:9.3f} {min(s):7.3f} {max(s):7.3f}")
    help_s = medians["real2code --help"]
    verdict = "met" if help_s < TARGET_S else "NOT met"
    print(f"real2code --help: {help_s:.3f} s median, target < {TARGET_S} s: {verdict}")


if __name__ == "__main__":
    main()
