"""Benchmark: ``real2code --help`` as a user runs it (the console script, a fresh process each
time), beside ``python -c pass`` (the interpreter's own start) in the same run.

    .venv/bin/python bench/cli_startup.py [--repeat 15] [--baseline OTHER_CHECKOUT]

``--baseline`` also times the same console script running another checkout's code (say,
the commit before issue 17), in the same run.

Target (issue 17): ``real2code --help`` under 0.15 s (median).
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import byte_compile, describe, load_average  # noqa: E402

TARGET_S = 0.15


def _seconds(command: list[str], repeat: int, path: str) -> tuple[list[float], list[float]]:
    """Wall seconds and CPU seconds (user + system) of each run of ``command`` with ``path``
    first on PYTHONPATH: on a shared machine the CPU time is what the command itself costs,
    the wall time what a user waits."""
    env = {**os.environ, "PYTHONPATH": path + os.pathsep + os.environ.get("PYTHONPATH", "")}
    wall, cpu = [], []
    for _ in range(repeat):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL, env=env)
        wall.append(time.perf_counter() - t0)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return wall, cpu


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--repeat", type=int, default=15)
    p.add_argument("--baseline", help="another checkout whose CLI to time beside this one")
    args = p.parse_args()
    script = shutil.which("real2code", path=str(Path(sys.executable).parent)) or "real2code"
    repo = str(Path(__file__).resolve().parents[1])
    byte_compile(Path(repo) / "real2code_export", *([Path(args.baseline) / "real2code_export"]
                                                   if args.baseline else []))
    print(f"machine: {describe()}; load average {load_average()}")
    cases = [("python -c pass", [sys.executable, "-c", "pass"], repo),
             ("real2code --help", [script, "--help"], repo),
             ("real2code export --help", [script, "export", "--help"], repo)]
    if args.baseline:
        cases.append(("baseline: real2code --help", [script, "--help"], args.baseline))
    print(f"{'command':28s} {'median s':>9s} {'min s':>7s} {'max s':>7s} {'cpu s':>7s}"
          f"  ({args.repeat} runs; cpu: median of user + system)")
    medians, cpus = {}, {}
    for label, command, path in cases:
        s, cpu = _seconds(command, args.repeat, path)
        medians[label], cpus[label] = statistics.median(s), statistics.median(cpu)
        print(f"{label:28s} {medians[label]:9.3f} {min(s):7.3f} {max(s):7.3f} "
              f"{cpus[label]:7.3f}")
    help_s = medians["real2code --help"]
    verdict = "met" if help_s < TARGET_S else "NOT met"
    print(f"real2code --help: {help_s:.3f} s median wall ({cpus['real2code --help']:.3f} s "
          f"CPU), target < {TARGET_S} s: {verdict}")
    if args.baseline:
        base = medians["baseline: real2code --help"]
        print(f"baseline / this checkout: {base / help_s:.1f}x")


if __name__ == "__main__":
    main()
