"""Benchmark: `reconstruct` of a 5-part object from 12 views at 256 x 256, end to end as the
command runs it (read the capture, segment, fuse, complete, articulate, export to every
format, check), each stage's time listed.

    .venv/bin/python bench/reconstruct.py [--repeat 3] [--parts 5] [--segmentation learned]
        [--cameras ring] [--capture phone-lidar] [--room]

Target (issue 6, on the 2-core machines): under 60 s.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import describe, load_average  # noqa: E402

from pipeline.procedural import generate  # noqa: E402
from pipeline.reconstruct import reconstruct  # noqa: E402
from pipeline.render import render_model  # noqa: E402
from real2code_export.formats import object_json  # noqa: E402


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--parts", type=int, default=5)
    p.add_argument("--segmentation", default="learned", choices=["learned", "gt"])
    p.add_argument("--cameras", default="ring", help="camera path (pipeline.camera_paths)")
    p.add_argument("--capture", default="clean", help="sensor preset (pipeline.sensors)")
    p.add_argument("--room", action="store_true", help="the object in a room (pipeline.room)")
    args = p.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        object_json.save(generate("storage_furniture", args.parts, 0), tmp / "model")
        render_model(tmp / "model" / "object.json", tmp / "capture", views=12, width=256,
                     height=256, state="random", seed=0, cameras=args.cameras,
                     sensor=args.capture, room=args.room)
        runs = []
        for k in range(args.repeat):
            t0, c0 = time.perf_counter(), time.process_time()
            result = reconstruct(tmp / "capture", tmp / f"out{k}",
                                 segmentation=args.segmentation)
            runs.append((time.perf_counter() - t0, time.process_time() - c0, result.timings,
                         result.check.ok))
    # CPU time beside wall time: on the shared machine the wall time grows with the load
    print(f"machine: {describe()}; load average {load_average()}")
    print(f"object: storage_furniture, {args.parts} parts, 12 views at 256 x 256 on a "
          f"{args.cameras} path{', in a room' if args.room else ''}, capture {args.capture}, segmentation {args.segmentation}, completion learned, predictor learned")
    stages = list(runs[0][2])
    print("run  total s    CPU s  " + "  ".join(f"{s:>12s}" for s in stages) + "  check")
    for k, (total, cpu, timings, ok) in enumerate(runs):
        cells = "  ".join(f"{timings.get(s, float('nan')):12.2f}" for s in stages)
        print(f"{k:3d}  {total:7.2f}  {cpu:7.2f}  {cells}  {'ok' if ok else 'DISAGREE'}")
    median = statistics.median(r[0] for r in runs)
    print(f"median total {median:.2f} s (target < 60 s): "
          f"{'met' if median < 60 else 'NOT met'}")


if __name__ == "__main__":
    main()
