"""Where we stand on the robot corpora: load each source file (then export, check, check
against the source), report the first error or the warnings count.
Usage: python bench/corpus_survey.py urdf|mjcf [--export [--check [--reference]]]"""
from __future__ import annotations

import json
import sys
import tempfile
import time
import warnings
from pathlib import Path

from real2code_export.check import check_files
from real2code_export.formats import export, load


def erd_files() -> list[Path]:
    import sysconfig

    root = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix/share/example-robot-data/robots"
    return sorted(root.rglob("*.urdf"))


def menagerie_files() -> list[Path]:
    root = Path(__file__).resolve().parents[1] / "../shared/data/mujoco_menagerie"
    return [root / e["model"] for e in json.loads((root / "index.json").read_text())]


def main() -> None:
    which = sys.argv[1]
    files = erd_files() if which == "urdf" else menagerie_files()
    ok = 0
    for f in files:
        t = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                obj = load(f)
                if "--export" in sys.argv:
                    with tempfile.TemporaryDirectory() as d:
                        written = export(obj, Path(d) / "out")
                        if "--check" in sys.argv:
                            checked = list(written.values())
                            if "--reference" in sys.argv:
                                checked.append(f)
                            report = check_files(checked, reference=f if "--reference" in sys.argv
                                                 else None)
                            if not report.ok:
                                raise RuntimeError("check: " + "; ".join(
                                    m.message for m in report.mismatches[:3]))
                status = f"ok ({len(obj.parts)} parts, {len(caught)} warnings)"
                ok += 1
            except Exception as e:  # noqa: BLE001 - a survey lists every failure
                status = f"FAIL {type(e).__name__}: {str(e)[:300]}"
        print(f"{f.name:40s} {time.perf_counter() - t:6.2f}s {status}", flush=True)
    print(f"{ok}/{len(files)} ok")


if __name__ == "__main__":
    main()
