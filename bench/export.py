"""Benchmark: export of a 15-part object (collision pieces already in the model, as after the
first export when coacd results are cached).

    .venv/bin/python bench/export.py [--repeat 20]

Targets (issue 2 and 3, on the 2-core machines): MJCF + URDF under 200 ms; USD and glTF
under 300 ms each.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import describe, timeit  # noqa: E402

from pipeline.procedural import generate  # noqa: E402
from real2code_export.formats import export, unavailable_reason  # noqa: E402


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--repeat", type=int, default=20)
    args = p.parse_args()
    obj = generate("storage_furniture", 15, 0)
    n_tri = sum(len(pt.visual.faces) for pt in obj.parts if pt.visual is not None)
    n_col = sum(len(pt.collision) for pt in obj.parts)
    print(f"machine: {describe()}")
    print(f"object: {obj.name}, {len(obj.parts)} parts, {n_tri} visual triangles, "
          f"{n_col} collision pieces")
    cases = [("mjcf+urdf", ["mjcf", "urdf"]), ("mjcf", ["mjcf"]), ("urdf", ["urdf"]),
             ("usd", ["usd"]), ("gltf", ["gltf"]), ("all four", ["mjcf", "urdf", "usd", "gltf"])]
    print(f"{'formats':12s} {'median ms':>10s} {'min ms':>8s} {'max ms':>8s}")
    with tempfile.TemporaryDirectory() as tmp:
        for label, formats in cases:
            if any(unavailable_reason(f, writing=True) for f in formats):
                print(f"{label:12s} (format not available)")
                continue
            export(obj, Path(tmp) / "warm", formats)  # imports and first-call costs
            times = timeit(lambda f=formats: export(obj, Path(tmp) / "out", f), args.repeat)
            ms = [t * 1000 for t in times]
            print(f"{label:12s} {statistics.median(ms):10.1f} {min(ms):8.1f} {max(ms):8.1f}")


if __name__ == "__main__":
    main()
