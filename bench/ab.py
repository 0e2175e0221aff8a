"""Benchmark: one command as a user runs it, with another checkout's code (``--before``)
against this one's, alternating run by run so a busy machine slows both alike; the CPU time
(user + system, child processes included) of each, median and minimum.

    git archive REV | tar -x -C /tmp/before     # the code to compare with, as a folder (link
                                                # its gltf_validator/node_modules for check)
    .venv/bin/python bench/ab.py --before /tmp/before [--repeat 5] check DIR [DIR ...]
    .venv/bin/python bench/ab.py --before /tmp/before [--repeat 5] [--to mjcf,urdf] export FILE [FILE ...]
    .venv/bin/python bench/ab.py --before /tmp/before [--repeat 5] export-check FILE [FILE ...]

``--server``: each side's commands run through a ``real2code server`` of its own code
(started first, in a runtime folder of its own, stopped at the end), as a user's commands run
once one is started: a command's CPU is the caller's and the server's fork's.

``check DIR``: ``real2code check`` of every file in DIR (an export's folder); ``export
FILE``: ``real2code export FILE --to usd`` (or ``--to`` the formats given) into a temporary
folder; ``export-check FILE``:
each side exports FILE (every default format) with its own code once, then ``real2code
check`` of its own export is timed (a change to what the export writes). Both checkouts run in the
same console script and interpreter, each chosen by ``PYTHONPATH``; both are byte-compiled
first, as ``pip install`` does (a stale ``__pycache__`` would make one of them compile its
modules from source on every run).
"""

from __future__ import annotations

import argparse
import atexit
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import byte_compile, describe, load_average  # noqa: E402

REPO = Path(__file__).resolve().parents[1]


class Side:
    """One checkout's code: the environment its commands run in and, with ``--server``, its
    own ``real2code server`` (whose ended forks' CPU is counted with each command's)."""

    def __init__(self, tree: Path, ours: str, server: bool) -> None:
        self.tree = tree
        self.env = {**os.environ, "PYTHONPATH": str(tree)}
        self.pid = None
        if server:
            self.folder = tempfile.TemporaryDirectory()
            self.env.update(XDG_RUNTIME_DIR=self.folder.name)
            # (started outside both checkouts: ``server run`` is ``python -m``, whose first
            # import path is its folder, which would otherwise pick this checkout's code)
            done = subprocess.run([ours, "server", "start", "--idle-timeout", "0"],
                                  env=self.env, cwd=self.folder.name, capture_output=True,
                                  text=True)
            said = done.stdout + done.stderr
            if done.returncode != 0 or "pid " not in said:
                sys.exit(f"{tree}: real2code server start failed: {said.strip()[-500:]}")
            self.pid = int(said.split("pid ")[1].split(",")[0])
        else:
            self.env["REAL2CODE_SERVER"] = "off"

    def forks_cpu(self) -> float:
        if self.pid is None:
            return 0.0
        fields = Path(f"/proc/{self.pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[13]) + int(fields[14])) / os.sysconf("SC_CLK_TCK")

    def cpu(self, command: list[str]) -> float:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        forks = self.forks_cpu()
        done = subprocess.run(command, env=self.env,
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        if done.returncode not in (0, 1):  # (1: the check found a disagreement, a result too)
            sys.exit(f"{self.tree}: {' '.join(command)} failed: {done.stderr.strip()[-500:]}")
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        return (after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
                + self.forks_cpu() - forks)

    def stop(self, ours: str) -> None:
        if self.pid is not None:
            subprocess.run([ours, "server", "stop"], env=self.env, capture_output=True)
            self.folder.cleanup()


def _files(folder: Path) -> list[str]:
    return sorted(str(f) for f in folder.iterdir() if f.is_file())


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--before", required=True, type=Path, help="the other checkout")
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--to", default="usd", help="export: the formats (as real2code export's --to)")
    p.add_argument("--server", action="store_true",
                   help="each side's commands through a real2code server of its own code")
    p.add_argument("command", choices=["check", "export", "export-check"])
    p.add_argument("inputs", nargs="+", type=Path)
    args = p.parse_args()
    ours = shutil.which("real2code", path=str(Path(sys.executable).parent)) or "real2code"
    trees = {"before": args.before.resolve(), "after": REPO}
    for tree in trees.values():
        byte_compile(tree / "real2code_export")
    sides = {name: Side(tree, ours, args.server) for name, tree in trees.items()}
    for side in sides.values():  # (stopped on every exit, sys.exit's too)
        atexit.register(side.stop, ours)
    print(f"machine: {describe()}; load average at start {load_average()}"
          + ("; each side through its own real2code server" if args.server else ""))
    print(f"| {args.command} | before ({trees['before']}) | after ({REPO}) |")
    print("|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for k, item in enumerate(args.inputs):
            if args.command == "check":
                commands = dict.fromkeys(trees, [ours, "check", *_files(item)])
            elif args.command == "export":
                commands = dict.fromkeys(trees, [ours, "export", str(item), "--to", args.to,
                                                 "--out", f"{tmp}/out"])
            else:
                commands = {}
                for name in trees:
                    out = Path(tmp) / name / str(k)
                    sides[name].cpu([ours, "export", str(item), "--out", str(out)])
                    commands[name] = [ours, "check", *_files(out)]
            cpu: dict[str, list[float]] = {name: [] for name in trees}
            for _ in range(args.repeat):
                for name in trees:
                    shutil.rmtree(f"{tmp}/out", ignore_errors=True)
                    cpu[name].append(sides[name].cpu(commands[name]))
            print(f"| `{item.name}` | " + " | ".join(
                f"{statistics.median(v):.3f} ({min(v):.3f})" for v in cpu.values()) + " |",
                flush=True)
    print(f"CPU s, median (min) of {args.repeat} runs each; load average at end "
          f"{load_average()}")


if __name__ == "__main__":
    main()
