"""A robot file's dynamics as its own tools build it against our exports', file by file: each
URDF exported to URDF and MJCF, its masses, inertias, centres of mass, damping, friction,
armature and limits compared in Pinocchio (source URDF against URDF export) and in MuJoCo
(source URDF as MuJoCo imports it, where it loads it as it is, against the MJCF export); each
MJCF source against its MJCF export in MuJoCo (``real2code_export.probes.dynamics``). A
difference is warned when one of the reader's warnings names its element and says what of it
changed (``dynamics.explaining``), unexplained otherwise; the kinds of warning that explain differences are
counted at the end. The tables in docs/corpora.md come from it.

    .venv/bin/python bench/corpus_dynamics.py urdf|mjcf|pybullet|PATH... [--markdown FILE]
"""

from __future__ import annotations

import os
import re
import sys
import tempfile
import time
import warnings
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from corpus_survey import erd_files, files_under, menagerie_files, pybullet_files  # noqa: E402

from real2code_export.errors import Real2CodeError  # noqa: E402
from real2code_export.formats import export, hulls_collision, is_format, load  # noqa: E402
from real2code_export.probes import dynamics  # noqa: E402

FORMATS = ["urdf", "mjcf"]
KINDS: Counter = Counter()  # kind of explaining warning -> differences it explains


def _kind(warning: str) -> str:
    """A repair warning without its file, element and names: what kind of repair it is."""
    text = re.sub(r"^\S+?(:\d+)?: ", "", warning)  # the file (and line)
    text = re.sub(r"^<\w+ name='[^']*'>: ", "", text)  # the element
    text = re.sub(r"'[^']*'(, '[^']*')*", "...", text)
    return re.split(r"[:(]", text, maxsplit=1)[0].strip()


def _explained(found: list, said: list[str]) -> None:
    for d in found:
        by = dynamics.explaining(d, said)
        if by:
            KINDS[_kind(by[0])] += 1


def compared(path: Path) -> list[str]:
    """Table cells: Pinocchio's and MuJoCo's comparisons, then the first unexplained."""
    with warnings.catch_warnings(record=True) as caught, tempfile.TemporaryDirectory() as tmp:
        warnings.simplefilter("always")
        try:
            obj = load(path, hull_collision=hulls_collision(FORMATS))
            written = export(obj, Path(tmp) / "out", FORMATS)
        except Real2CodeError as e:
            return ["refused", "", str(e).replace(str(path), path.name)]
        said = [str(w.message) for w in caught]
        cells, first = [], ""
        by_tool = {c.tool: c.differences
                   for c in dynamics.against_source(path, [written["urdf"], written["mjcf"]])}
        tools = (by_tool.get("Pinocchio"), by_tool["MuJoCo"])
        for found in tools:
            if found is None:
                cells.append("does not load it" if is_format(path, "urdf") else "")
                continue
            left = dynamics.unexplained(found, said)
            _explained(found, said)
            cells.append(f"{len(found)} ({len(found) - len(left)} warned, "
                         f"{len(left)} unexplained)" if found else "equal")
            first = first or (str(left[0]) if left else "")
        return [*cells, first]


def main() -> None:
    args = sys.argv[1:]
    if "--markdown" in args:
        del args[args.index("--markdown"):args.index("--markdown") + 2]
    named = {"urdf": erd_files, "mjcf": menagerie_files, "pybullet": pybullet_files}
    files = named[args[0]]() if len(args) == 1 and args[0] in named else files_under(args)
    root = Path(os.path.commonpath([f.parent for f in files])) if files else Path()
    rows, unexplained = [], 0
    for f in files:
        start = time.perf_counter()
        cells = compared(f)
        unexplained += any("unexplained" in c and " 0 unexplained" not in c for c in cells[:2])
        row = (f"| {f.relative_to(root)} | {cells[0]} | {cells[1]} | "
               f"{time.perf_counter() - start:.1f} | {cells[2].replace('|', '/')} |")
        print(row, flush=True)
        rows.append(row)
    total = f"{unexplained} of {len(files)} files with an unexplained difference"
    kinds = "\n".join(f"- {kind}: {n}" for kind, n in KINDS.most_common())
    total += f"\n\nDifferences explained, by the kind of warning naming their element:\n\n{kinds}"
    print(total)
    if "--markdown" in sys.argv:
        out = Path(sys.argv[sys.argv.index("--markdown") + 1])
        head = ["| file | Pinocchio (URDF export) | MuJoCo (MJCF export) | seconds | first "
                "unexplained / reason |", "|---|---|---|---|---|"]
        out.write_text("\n".join(head + rows) + f"\n\n{total}\n")


if __name__ == "__main__":
    main()
