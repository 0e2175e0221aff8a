"""The `limit` experiment at shorter steps than the check's 1 ms: which engine's stop is off
at 1 ms, told against every engine's own run at the finest step (the nearest each comes to
the continuous motion; a stop that looks a step ahead converges with the step, one that
acts only at or past its limit need not: docs/engines.md).

    .venv/bin/python bench/limit_steps.py OBJECT|--flap [--steps 1e-3,2.5e-4,6.25e-5]
        [--engines mujoco,pinocchio,bullet]

OBJECT: any file our readers take (a demo's object.json); `--flap`: a laptop's screen
(`generate("laptop", seed=3)`) given the range -4 to 1.2 rad, observed at 1.2 and without
joint laws: thrown into its open stop, where gravity pulls it out, it falls through its
range onto its other stop at speed, and gravity pulls it out of that one too. `mujoco` is
the check's reference (the MJCF); the others are `real2code simulate`'s engine names, each
run on the file it reads. One row per engine and step; one column per engine at the
finest step (docs/engines.md).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
import time
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))
from _machine import describe  # noqa: E402

from pipeline.procedural import generate  # noqa: E402
from real2code_export.dynamics.experiments import EXPERIMENTS  # noqa: E402
from real2code_export.dynamics.run import ENGINES, compare, write_formats  # noqa: E402
from real2code_export.formats import load  # noqa: E402

SAMPLE_PERIOD = 0.01  # s, as the check's 10 steps of 1 ms


def flap():
    obj = generate("laptop", seed=3)
    (j,) = obj.movable_joints
    j.limits.lower, j.limits.upper, j.state = -4.0, 1.2, 1.2
    j.dynamics.damping = j.dynamics.friction = 0.0
    return obj


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("object", nargs="?")
    p.add_argument("--flap", action="store_true")
    p.add_argument("--steps", default="1e-3,2.5e-4,6.25e-5")
    p.add_argument("--engines", default="mujoco,pinocchio,bullet")
    args = p.parse_args()
    if bool(args.flap) == bool(args.object):
        p.error("give an OBJECT or --flap")
    print(f"machine: {describe()}")
    engines = [ENGINES[e] for e in args.engines.split(",")]
    steps = sorted((float(s) for s in args.steps.split(",")), reverse=True)
    variant, experiment = EXPERIMENTS["limit"](flap() if args.flap else load(args.object))
    runs = {}
    with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        files = write_formats(variant, folder, sorted({e.format for e in engines}))
        for dt in steps:
            run = dataclasses.replace(experiment, dt=dt,
                                      sample_every=max(1, round(SAMPLE_PERIOD / dt)))
            for e in engines:
                start = time.process_time()
                runs[e.label, dt] = (run, e.simulate(files[e.format], run))
                print(f"{e.label} at {dt:g} s: {time.process_time() - start:.1f} s of CPU",
                      flush=True)
    fine = steps[-1]
    labels = [e.label for e in engines]
    print("\n| engine | step (s) | " + " | ".join(f"against {lb} at {fine:g} s" for lb in labels)
          + " |")
    print("|---|---|" + "---|" * len(labels))
    for (label, dt), (run, trajectory) in runs.items():
        cells = []
        for other in labels:
            _, angle, distance = compare(run, runs[other, fine][1], trajectory)
            cells.append(f"{angle:.1e} rad / {distance:.1e} m")
        print(f"| {label} | {dt:g} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
