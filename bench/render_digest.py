"""A digest of every frame ``real2code evaluate reconstruction`` renders, per object: RGB,
depth and masks as the evaluation makes them (its cases, seeds, camera path and capture
preset), hashed. Run on two checkouts (``PYTHONPATH=CHECKOUT``) and compare the lines: a
change to how parts are read or coloured that leaves every digest equal leaves the images
the segmentation sees bit-identical.

    PYTHONPATH=$PWD .venv/bin/python bench/render_digest.py --partnet DIR [--splits dev]
        [--objects 6] [--cameras ring] [--capture clean] [--seed 0]
"""

from __future__ import annotations

import argparse
import hashlib
import time
from pathlib import Path

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--partnet", help="PartNet-Mobility folder (with index.json)")
    parser.add_argument("--splits", default="dev")
    parser.add_argument("--objects", type=int, default=6, help="procedural test objects")
    parser.add_argument("--cameras", default="ring")
    parser.add_argument("--distance", default="mid")
    parser.add_argument("--capture", default="clean")
    parser.add_argument("--views", type=int, default=12)
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    import pipeline
    from pipeline.evaluate_articulation import partnet_cases, procedural_cases
    from pipeline.render import render_object
    from pipeline.sensors import degrade, load_sensor

    print(f"# code: {Path(pipeline.__file__).parent.parent}")
    start = time.process_time()
    sets = {"procedural": procedural_cases(args.objects, args.seed)} if args.objects else {}
    for split in [s for s in args.splits.split(",") if s] if args.partnet else []:
        sets[f"partnet {split}"] = partnet_cases(Path(args.partnet), split, args.seed)
    sensor = load_sensor(args.capture)
    for name, cases in sets.items():
        for k, case in enumerate(cases):  # as pipeline.evaluate_reconstruction.evaluate
            capture = render_object(case.obj, base=case.base, views=args.views,
                                    width=args.size, height=args.size, seed=args.seed + k,
                                    cameras=args.cameras, distance=args.distance)
            capture = degrade(capture, sensor, args.seed + k)
            digest = hashlib.sha256()
            for frame in capture.frames:
                for image in (frame.rgb, frame.depth, frame.mask):
                    digest.update(np.ascontiguousarray(image).tobytes())
            print(f"{name}\t{case.label}\t{len(capture.frames)} frames\t{digest.hexdigest()}",
                  flush=True)
    print(f"# {time.process_time() - start:.1f} s CPU")


if __name__ == "__main__":
    main()
