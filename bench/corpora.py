"""Benchmark: whole commands on the public robot corpora, ours side by side with the converter
a user would pick instead, one run, same machine, same load.

    bench/setup_converters.sh            # urdf-usd-converter, mujoco-usd-converter (own venv)
    .venv/bin/python bench/corpora.py [--corpus urdf|mjcf|both] [--limit N] [--markdown F]
                                      [--usd-only] [--server]

Per file: ``real2code export FILE --out D`` (all four formats, one process, as a user runs
it), then ``real2code check D/*`` (four exports, 100 configurations), ``real2code export
FILE --to usd`` (what the converter writes) and the converter (``urdf_usd_converter FILE D``
/ ``mujoco_usd_converter FILE D``, USD only). Prints the per-file seconds (wall, and the
CPU the command used), the medians and totals per corpus and the ratios converter / ours.
``--usd-only``: the USD export and the converter alone (a quarter of the run's CPU), for the
one ratio the converter can be compared on; with ``--floor`` also, per file, each tool's floor
(:data:`FLOOR`: its interpreter importing what it writes USD with and MuJoCo compiling the
file, nothing written), the CPU no export of that file by either tool can go below.
``--server``: our commands also run through ``real2code server`` (started once, in a folder
of its own, its start timed: the cold first command), each file's command beside the one on
its own: the USD export with ``--usd-only``, else the export to four formats and the check of
its four exports; a command's CPU there is the caller's and the server's fork's.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import sysconfig
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _data import SHARED_DATA  # noqa: E402
from _machine import byte_compile, converters_bin, describe, load_average  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
CONVERTERS = converters_bin()
REAL2CODE = [sys.executable, "-m", "real2code_export.cli"]
ALONE = {**os.environ, "REAL2CODE_SERVER": "off"}  # ours on its own, whatever server runs


def urdf_files() -> list[Path]:
    root = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix/share/example-robot-data/robots"
    return sorted(root.rglob("*.urdf"))


def mjcf_files() -> list[Path]:
    root = SHARED_DATA / "mujoco_menagerie"
    return [root / e["model"] for e in json.loads((root / "index.json").read_text())]


class Server:
    """``real2code server`` in a runtime folder of its own (not the user's), for the run."""

    def __init__(self) -> None:
        self.folder = tempfile.TemporaryDirectory()
        self.env = {**os.environ, "XDG_RUNTIME_DIR": self.folder.name}
        self.start_s, _, rc, said = timed([*REAL2CODE, "server", "start", "--idle-timeout", "0"],
                                          self.env)
        if rc != 0:
            sys.exit(f"real2code server start failed: {said}")
        self.pid = int(said.split("pid ")[1].split(",")[0])

    def forks_cpu(self) -> float:
        """CPU seconds of the server's ended forks (its children's, as the kernel counts)."""
        fields = Path(f"/proc/{self.pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[13]) + int(fields[14])) / os.sysconf("SC_CLK_TCK")

    def timed(self, cmd: list[str]) -> tuple[float, float, int, str]:
        before = self.forks_cpu()
        wall, cpu, rc, said = timed(cmd, self.env)
        return wall, cpu + self.forks_cpu() - before, rc, said

    def stop(self) -> None:
        timed([*REAL2CODE, "server", "stop"], self.env)
        self.folder.cleanup()


def timed(cmd: list[str], env: dict | None = None) -> tuple[float, float, int, str]:
    """Wall seconds, CPU seconds (user + system: what the command itself used, which a busy
    machine inflates less than the wall time), exit status and last line said."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    # (the environment as the user's shell has it: no MUJOCO_GL forced on either tool)
    done = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    last = (done.stderr.strip() or done.stdout.strip()).splitlines()[-1:] or [""]
    return wall, cpu, done.returncode, last[0][:160]


# What each tool cannot do without before it writes a prim of an MJCF file: start its
# interpreter, import numpy, MuJoCo and the USD modules it writes with (ours: Sdf, Gf, Vt,
# formats/usd/layer.py; the converter: the schema modules too) and compile the file (MuJoCo
# reading its meshes itself). Ours runs in the environment our command sets
# (cli.process_defaults), the converter's as the shell has it, as each tool runs.
FLOOR = {"ours": "from pxr import Sdf, Gf, Vt",
         "converter": "from pxr import Usd, UsdGeom, UsdPhysics, UsdShade, Sdf, Gf, Vt"}
_FLOOR_CODE = "import sys, numpy, mujoco; {}; mujoco.MjSpec.from_file(sys.argv[1]).compile()"


def floors(path: Path) -> dict:
    """CPU seconds of :data:`FLOOR` for ``path`` in each tool's venv."""
    import os

    ours = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "disable"),
            "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS", "1")}
    out = {}
    for tool, python, env in (("ours", sys.executable, ours),
                              ("converter", str(CONVERTERS / "python"), None)):
        _, cpu, rc, _ = timed([python, "-c", _FLOOR_CODE.format(FLOOR[tool]), str(path)],
                                 env)
        out[f"floor_{tool}_cpu"] = cpu if rc == 0 else float("nan")
    return out


def _floor_cells(r: dict) -> str:
    """The two ``--floor`` cells of a row (or of the medians): the floors, and each tool's
    CPU above its own."""
    return (f"{r['floor_ours_cpu']:.2f} / {r['floor_converter_cpu']:.2f} | "
            f"{r['above_ours_cpu']:.2f} / {r['above_converter_cpu']:.2f} |")


def run_file(path: Path, converter: str, usd_only: bool = False,
             server: Server | None = None) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        row: dict = {"file": path.name}
        if not usd_only:
            ours, ours_cpu, rc, said = timed([*REAL2CODE, "export", str(path), "--out",
                                              f"{tmp}/ours"], ALONE)
            row.update(export_s=ours, export_cpu=ours_cpu, export_rc=rc, said=said)
        if not usd_only and rc == 0:
            files = sorted(str(p) for p in Path(tmp, "ours").iterdir() if p.is_file())
            check, check_cpu, rc_check, _ = timed([*REAL2CODE, "check", *files], ALONE)
            row.update(check_s=check, check_cpu=check_cpu, check_rc=rc_check)
            if server is not None:
                warm, warm_cpu, rc_warm, _ = server.timed([*REAL2CODE, "export", str(path),
                                                           "--out", f"{tmp}/warm4"])
                check, check_cpu, rc_check, _ = server.timed([*REAL2CODE, "check", *files])
                row.update(warm4_s=warm, warm4_cpu=warm_cpu, warm4_rc=rc_warm,
                           warm_check_s=check, warm_check_cpu=check_cpu,
                           warm_check_rc=rc_check)
        # the converter's output alone (USD), as a user after a USD file runs it
        usd, usd_cpu, rc_usd, _ = timed([*REAL2CODE, "export", str(path), "--to", "usd",
                                         "--out", f"{tmp}/usd"], ALONE)
        row.update(usd_s=usd, usd_cpu=usd_cpu, usd_rc=rc_usd)
        if server is not None and usd_only:
            warm, warm_cpu, rc_warm, _ = server.timed([*REAL2CODE, "export", str(path), "--to",
                                                       "usd", "--out", f"{tmp}/warm"])
            row.update(warm_s=warm, warm_cpu=warm_cpu, warm_rc=rc_warm)
        if usd_only:
            row.update(export_rc=rc_usd)
        conv, conv_cpu, rc_conv, said_conv = timed([str(CONVERTERS / converter), str(path),
                                                    f"{tmp}/conv"])
        row.update(converter_s=conv, converter_cpu=conv_cpu, converter_rc=rc_conv,
                   converter_said=said_conv)
    return row


def _median(rows: list[dict], key: str) -> float:
    values = [r[key] for r in rows if key in r]
    return statistics.median(values) if values else float("nan")


def _both(rows: list[dict], ours: str) -> list[dict]:
    """The files both tools convert: a file one of them refuses is quick to refuse, and
    timing it would credit the refusal as speed."""
    return [r for r in rows if r[ours] == 0 and r["converter_rc"] == 0]


def usd_summary(name: str, rows: list[dict], ours: str = "usd") -> str:
    """The ``--usd-only`` line: how many files each tool converts, then medians, totals
    and ratios of the USD export (``ours``: ``usd`` on its own, ``warm`` in the server) and
    the converter over the files both convert."""
    ok = [r for r in rows if r[f"{ours}_rc"] == 0]
    conv_ok = [r for r in rows if r["converter_rc"] == 0]
    both = _both(rows, f"{ours}_rc")
    usd, usd_cpu = _median(both, f"{ours}_s"), _median(both, f"{ours}_cpu")
    conv, conv_cpu = _median(both, "converter_s"), _median(both, "converter_cpu")
    ratios = [r["converter_cpu"] / r[f"{ours}_cpu"] for r in both]
    walls = [r["converter_s"] / r[f"{ours}_s"] for r in both]
    return (f"| {name}{' (server)' if ours == 'warm' else ''} | {len(rows)} | {len(ok)} | "
            f"{len(conv_ok)} | {len(both)} | "
            f"{usd:.2f} ({usd_cpu:.2f}) | {conv:.2f} ({conv_cpu:.2f}) | {conv / usd:.2f} "
            f"({conv_cpu / usd_cpu:.2f}) | {sum(r[f'{ours}_s'] for r in both):.1f} / "
            f"{sum(r['converter_s'] for r in both):.1f} | "
            f"{sum(x > 1 for x in ratios)} / {sum(x >= 2 for x in ratios)} | "
            f"{sum(x > 1 for x in walls)} / {sum(x >= 2 for x in walls)} |")


def summary(name: str, rows: list[dict], server: bool = False) -> str:
    ok = [r for r in rows if r["export_rc"] == 0]
    conv_ok = [r for r in rows if r["converter_rc"] == 0]
    both = _both(rows, "export_rc")
    conv, conv_cpu = _median(both, "converter_s"), _median(both, "converter_cpu")
    ours, ours_cpu = _median(both, "export_s"), _median(both, "export_cpu")
    usd, usd_cpu = _median(both, "usd_s"), _median(both, "usd_cpu")
    return (f"| {name} | {len(rows)} | {len(ok)} | {len(conv_ok)} | {len(both)} | "
            f"{ours:.2f} ({ours_cpu:.2f})"
            f" | {usd:.2f} ({usd_cpu:.2f}) | {conv:.2f} ({conv_cpu:.2f}) | "
            f"{conv / ours:.2f} ({conv_cpu / ours_cpu:.2f}) | "
            f"{conv / usd:.2f} ({conv_cpu / usd_cpu:.2f}) | "
            f"{sum(r['export_s'] for r in both):.0f} / {sum(r['converter_s'] for r in both):.0f}"
            f" | {_median(ok, 'check_s'):.2f} ({_median(ok, 'check_cpu'):.2f}) |"
            + (_server_cells({k: _median(ok, k) for k in ("warm4_s", "warm4_cpu",
                                                          "warm_check_s", "warm_check_cpu")})
               + f" {sum(r['warm_check_s'] < 1 for r in ok)} of {len(ok)} |"
               if server else ""))


def _server_cells(r: dict) -> str:
    """The two ``--server`` cells of a full run's row: the export to four formats and the
    check in the server."""
    return (f" {r['warm4_s']:.2f} ({r['warm4_cpu']:.2f}) | "
            f"{r['warm_check_s']:.2f} ({r['warm_check_cpu']:.2f}) |")


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--corpus", choices=["urdf", "mjcf", "both"], default="both")
    p.add_argument("--limit", type=int, default=None, help="first N files of each corpus")
    p.add_argument("--markdown", help="also write the tables to this file")
    p.add_argument("--floor", action="store_true",
                   help="with --usd-only: each tool's floor per file (FLOOR)")
    p.add_argument("--usd-only", action="store_true",
                   help="only `real2code export --to usd` and the converter")
    p.add_argument("--server", action="store_true",
                   help="our commands through `real2code server` too")
    args = p.parse_args()
    if not (CONVERTERS / "urdf_usd_converter").exists():
        sys.exit("run bench/setup_converters.sh first")
    byte_compile(REPO / "real2code_export")
    corpora = {"urdf": ("example-robot-data (URDF)", urdf_files, "urdf_usd_converter"),
               "mjcf": ("MuJoCo Menagerie (MJCF)", mjcf_files, "mujoco_usd_converter")}
    lines = [f"machine: {describe()}; load average at start {load_average()}", "",
             "seconds: wall (CPU, user + system)", ""]
    if args.usd_only:
        floor = (" floor, ours / converter's (CPU) | above it, ours / converter (CPU) |"
                 if args.floor else "")
        warm = (" ours in the server | converter / ours in the server (wall, CPU) |"
                if args.server else "")
        lines += ["| file | ours: export --to usd | converter (USD) | converter / ours "
                  "(wall, CPU) | exit ours / converter |" + floor + warm,
                  "|---|---|---|---|---|" + "---|---|" * (args.floor + args.server)]
        totals = ["| corpus | files | we export | converter exits clean | both convert "
                  "(the rest over these) | median export --to usd | median converter | "
                  "converter / ours (medians) | total ours / converter (wall s) | files "
                  "faster / 2x faster (CPU) | files faster / 2x faster (wall) |"
                  + floor.replace(" floor", " median floor").replace(" above", " median above"),
                  "|---|---|---|---|---|---|---|---|---|---|---|" + "---|---|" * args.floor]
    else:
        warm = (" ours in the server: export, 4 formats | check |" if args.server else "")
        lines += ["| file | ours: export, 4 formats | ours: check | ours: export --to usd | "
                  "converter (USD) | converter / ours (4 formats) | converter / ours (USD) | "
                  "exit ours / converter |" + warm,
                  "|---|---|---|---|---|---|---|---|" + "---|---|" * args.server]
        totals = ["| corpus | files | we export | converter exits clean | both convert "
                  "(the rest over these) | median export, 4 formats | median export --to usd | "
                  "median converter | converter / ours (4 formats, medians) | converter / ours "
                  "(USD, medians) | total ours / converter (s) | median check |"
                  + (" median in the server: export, 4 formats | check | checks under 1 s "
                     "in the server |" if args.server else ""),
                  "|---|---|---|---|---|---|---|---|---|---|---|---|" + "---|" * 3 * args.server]
    server = Server() if args.server else None
    if server is not None:
        lines.insert(1, f"\nreal2code server start (the cold first command): "
                        f"{server.start_s:.2f} s wall")
    print(lines[0], flush=True)
    for key in (["urdf", "mjcf"] if args.corpus == "both" else [args.corpus]):
        name, files, converter = corpora[key]
        rows = []
        for path in files()[: args.limit]:
            r = run_file(path, converter, args.usd_only, server)
            if args.usd_only and args.floor:
                r.update(floors(path))
                r["above_ours_cpu"] = r["usd_cpu"] - r["floor_ours_cpu"]
                r["above_converter_cpu"] = r["converter_cpu"] - r["floor_converter_cpu"]
            rows.append(r)
            line = (f"| {r['file']} | {r['usd_s']:.2f} ({r['usd_cpu']:.2f}) | "
                    f"{r['converter_s']:.2f} ({r['converter_cpu']:.2f}) | "
                    f"{r['converter_s'] / r['usd_s']:.2f}, "
                    f"{r['converter_cpu'] / r['usd_cpu']:.2f} | {r['usd_rc']} / "
                    f"{r['converter_rc']} |") if args.usd_only else (f"| {r['file']} | {r['export_s']:.2f} ({r['export_cpu']:.2f}) | "
                    f"{r.get('check_s', float('nan')):.2f} ({r.get('check_cpu', float('nan')):.2f})"
                    f" | {r['usd_s']:.2f} ({r['usd_cpu']:.2f}) | {r['converter_s']:.2f} "
                    f"({r['converter_cpu']:.2f}) | {r['converter_s'] / r['export_s']:.2f} | "
                    f"{r['converter_s'] / r['usd_s']:.2f} | {r['export_rc']} / "
                    f"{r['converter_rc']} |")
            if args.usd_only and args.floor:
                line += " " + _floor_cells(r)
            if server is not None and not args.usd_only:
                line += _server_cells(r) if "warm_check_s" in r else " - | - |"
            elif server is not None:
                line += (f" {r['warm_s']:.2f} ({r['warm_cpu']:.2f}) | "
                         f"{r['converter_s'] / r['warm_s']:.2f}, "
                         f"{r['converter_cpu'] / r['warm_cpu']:.2f} |")
            print(line, flush=True)
            lines.append(line)
        totals.append(usd_summary(name, rows) if args.usd_only
                      else summary(name, rows, server is not None))
        if args.usd_only and args.floor:
            totals[-1] += " " + _floor_cells({k: _median(_both(rows, "usd_rc"), k) for k in (
                "floor_ours_cpu", "floor_converter_cpu", "above_ours_cpu",
                "above_converter_cpu")})
        if server is not None and args.usd_only:
            totals.append(usd_summary(name, rows, "warm"))
    if server is not None:
        server.stop()
    lines[0] += f"; at end {load_average()}"
    text = "\n".join(lines + [""] + totals) + "\n"
    print("\n".join(totals))
    if args.markdown:
        Path(args.markdown).write_text(text)


if __name__ == "__main__":
    main()
