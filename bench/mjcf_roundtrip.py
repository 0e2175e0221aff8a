"""MJCF -> model -> MJCF on the Menagerie snapshot: is the body tree the same (bodies, their
parents and how many joints each holds), are the sites there, and how many actuators,
tendons, sensors and equality constraints the export holds against the source. The table in
docs/corpora.md comes from it.

    .venv/bin/python bench/mjcf_roundtrip.py [--markdown FILE]
"""

from __future__ import annotations

import sys
import tempfile
import warnings
from pathlib import Path

import mujoco

from real2code_export.formats import export, load
from real2code_export.model import sanitize_name

sys.path.insert(0, str(Path(__file__).resolve().parent))
from corpus_survey import menagerie_files  # noqa: E402


def tree(model) -> list[tuple[str, str, int]]:
    """(body, parent, joint count) per body, named as the MJCF reader names them."""
    def name(b: int) -> str:
        return sanitize_name(model.body(b).name or f"body_{b}")

    return [(name(b), name(int(model.body_parentid[b])), int(model.body_jntnum[b]))
            for b in range(1, model.nbody)]


def counts(model) -> list[int]:
    return [model.nsite, model.nu, model.ntendon, model.nsensor, model.neq]


def main() -> None:
    rows = []
    for path in menagerie_files():
        with warnings.catch_warnings(), tempfile.TemporaryDirectory() as tmp:
            warnings.simplefilter("ignore")
            written = export(load(path), Path(tmp) / "out", ["mjcf"])["mjcf"]
            source, ours = mujoco.MjModel.from_xml_path(str(path)), \
                mujoco.MjModel.from_xml_path(str(written))
        same = "same" if tree(source) == tree(ours) else "differs"
        pairs = " | ".join(f"{a} / {b}" for a, b in zip(counts(source), counts(ours),
                                                        strict=True))
        rows.append(f"| {path.name} | {same} | {pairs} |")
        print(rows[-1], flush=True)
    table = "\n".join(["| file | body tree | sites | actuators | tendons | sensors | "
                       "equalities |", "|---|---|---|---|---|---|---|", *rows])
    if "--markdown" in sys.argv:
        Path(sys.argv[sys.argv.index("--markdown") + 1]).write_text(table + "\n")


if __name__ == "__main__":
    main()
