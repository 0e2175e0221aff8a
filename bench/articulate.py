"""Benchmark: `articulate` of a 15-part object from its part meshes (boxes, prediction,
closed state, range sweep, collision pieces, inertials), without writing files.

    .venv/bin/python bench/articulate.py [--repeat 5] [--predictor learned]

Target (issue 5, on the 2-core machines): under 2 s, range sweep included.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import describe  # noqa: E402

from pipeline.articulate import articulate  # noqa: E402
from pipeline.predictors import get_predictor  # noqa: E402
from pipeline.procedural import generate  # noqa: E402
from real2code_export.kinematics import world_part_meshes  # noqa: E402


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--predictor", default="learned")
    args = p.parse_args()
    obj = generate("storage_furniture", 15, 0)
    meshes = world_part_meshes(obj)
    predictor = get_predictor(args.predictor)
    articulate(meshes, predictor)  # warm: imports, torch start-up
    times = []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        articulate(meshes, predictor)
        times.append(time.perf_counter() - t0)
    print(f"machine: {describe()}")
    print(f"object: {obj.name}, {len(meshes)} parts, predictor {args.predictor}")
    print(f"articulate: median {statistics.median(times) * 1000:.0f} ms, "
          f"min {min(times) * 1000:.0f} ms, max {max(times) * 1000:.0f} ms")


if __name__ == "__main__":
    main()
