"""Benchmark: whole commands on the public robot corpora, ours side by side with the converter
a user would pick instead, one run, same machine, same load.

    bench/setup_converters.sh            # urdf-usd-converter, mujoco-usd-converter (own venv)
    .venv/bin/python bench/corpora.py [--corpus urdf|mjcf|both] [--limit N] [--markdown F]

Per file: ``real2code export FILE --to mjcf,urdf,usd,gltf --out D`` (one process, as a user
runs it), then ``real2code check D/*`` (four exports, 100 configurations), and the converter
(``urdf_usd_converter FILE D`` / ``mujoco_usd_converter FILE D``, USD only). Prints the
per-file seconds, the medians and totals per corpus and the ratio converter / ours.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import sysconfig
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import byte_compile, describe, load_average  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
CONVERTERS = REPO / ".venv-converters" / "bin"
REAL2CODE = [sys.executable, "-m", "real2code_export.cli"]


def urdf_files() -> list[Path]:
    root = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix/share/example-robot-data/robots"
    return sorted(root.rglob("*.urdf"))


def mjcf_files() -> list[Path]:
    root = Path(os.environ.get("REAL2CODE_SHARED_DATA", REPO.parent / "shared" / "data"))
    root = root / "mujoco_menagerie"
    return [root / e["model"] for e in json.loads((root / "index.json").read_text())]


def timed(cmd: list[str]) -> tuple[float, int, str]:
    start = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ,
                          "MUJOCO_GL": os.environ.get("MUJOCO_GL", "osmesa")})
    last = (done.stderr.strip() or done.stdout.strip()).splitlines()[-1:] or [""]
    return time.perf_counter() - start, done.returncode, last[0][:160]


def run_file(path: Path, converter: str) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        ours, rc, said = timed([*REAL2CODE, "export", str(path), "--out", f"{tmp}/ours"])
        row = {"file": path.name, "export_s": ours, "export_rc": rc, "said": said}
        if rc == 0:
            files = sorted(str(p) for p in Path(tmp, "ours").iterdir() if p.is_file())
            check, rc_check, _ = timed([*REAL2CODE, "check", *files])
            row.update(check_s=check, check_rc=rc_check)
        conv, rc_conv, said_conv = timed([str(CONVERTERS / converter), str(path), f"{tmp}/conv"])
        row.update(converter_s=conv, converter_rc=rc_conv, converter_said=said_conv)
    return row


def summary(name: str, rows: list[dict]) -> str:
    ok = [r for r in rows if r["export_rc"] == 0]
    conv_ok = [r for r in rows if r["converter_rc"] == 0]
    med_ours = statistics.median(r["export_s"] for r in rows)
    med_conv = statistics.median(r["converter_s"] for r in rows)
    checks = [r["check_s"] for r in ok if "check_s" in r]
    return (f"| {name} | {len(rows)} | {len(ok)} | {len(conv_ok)} | {med_ours:.2f} | "
            f"{med_conv:.2f} | {med_conv / med_ours:.2f} | "
            f"{sum(r['export_s'] for r in rows):.0f} / {sum(r['converter_s'] for r in rows):.0f}"
            f" | {statistics.median(checks) if checks else float('nan'):.2f} |")


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--corpus", choices=["urdf", "mjcf", "both"], default="both")
    p.add_argument("--limit", type=int, default=None, help="first N files of each corpus")
    p.add_argument("--markdown", help="also write the tables to this file")
    args = p.parse_args()
    if not (CONVERTERS / "urdf_usd_converter").exists():
        sys.exit("run bench/setup_converters.sh first")
    byte_compile(REPO / "real2code_export")
    corpora = {"urdf": ("example-robot-data (URDF)", urdf_files, "urdf_usd_converter"),
               "mjcf": ("MuJoCo Menagerie (MJCF)", mjcf_files, "mujoco_usd_converter")}
    lines = [f"machine: {describe()}; load average at start {load_average()}", "",
             "| file | ours: export (s) | ours: check (s) | converter (s) | converter / ours |"
             " exit ours / converter |", "|---|---|---|---|---|---|"]
    totals = ["| corpus | files | we export | converter exits clean | median export (s) | "
              "median converter (s) | converter / ours (medians) | total ours / converter (s) "
              "| median check (s) |", "|---|---|---|---|---|---|---|---|---|"]
    for key in (["urdf", "mjcf"] if args.corpus == "both" else [args.corpus]):
        name, files, converter = corpora[key]
        rows = []
        for path in files()[: args.limit]:
            r = run_file(path, converter)
            rows.append(r)
            line = (f"| {r['file']} | {r['export_s']:.2f} | {r.get('check_s', float('nan')):.2f}"
                    f" | {r['converter_s']:.2f} | {r['converter_s'] / r['export_s']:.2f} | "
                    f"{r['export_rc']} / {r['converter_rc']} |")
            print(line, flush=True)
            lines.append(line)
        totals.append(summary(name, rows))
    lines[0] += f"; at end {load_average()}"
    text = "\n".join(lines + [""] + totals) + "\n"
    print("\n".join(totals))
    if args.markdown:
        Path(args.markdown).write_text(text)


if __name__ == "__main__":
    main()
