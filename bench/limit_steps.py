"""An experiment (`limit` unless told) at shorter steps than the check's 1 ms: which
engine is off at 1 ms, told against every engine's own run at the finest step (the nearest
each comes to the continuous motion; a stop that looks a step ahead converges with the
step, one that acts only at or past its limit as its square root: docs/engines.md, "Which
motion is right").

    .venv/bin/python bench/limit_steps.py OBJECT|--flap|--objects KINDS
        [--experiment limit] [--steps 1e-3,2.5e-4,6.25e-5] [--engines mujoco,pinocchio,bullet]

OBJECT: any file our readers take (a demo's object.json); `--objects`: bench/dynamics.py's
objects (cabinet,generated,partnet); `--flap`: a laptop's screen
(`generate("laptop", seed=3)`) given the range -4 to 1.2 rad, observed at 1.2 and without
joint laws: thrown into its open stop, where gravity pulls it out, it falls through its
range onto its other stop at speed, and gravity pulls it out of that one too. `mujoco` is
the check's reference (the MJCF), run below 1 ms as `simulate` makes its converged motion
(its limits at two of the step); the others are `real2code simulate`'s engine names, each
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
from dynamics import objects  # noqa: E402

from pipeline.procedural import generate  # noqa: E402
from real2code_export.dynamics.experiments import EXPERIMENTS  # noqa: E402
from real2code_export.dynamics.mujoco import simulate_converged  # noqa: E402
from real2code_export.dynamics.run import ENGINES, REFERENCE, compare, write_formats  # noqa: E402
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
    p.add_argument("--objects", help="bench/dynamics.py's kinds: cabinet,generated,partnet")
    p.add_argument("--experiment", default="limit", choices=list(EXPERIMENTS))
    p.add_argument("--steps", default="1e-3,2.5e-4,6.25e-5")
    p.add_argument("--engines", default="mujoco,pinocchio,bullet")
    args = p.parse_args()
    if sum(map(bool, (args.flap, args.object, args.objects))) != 1:
        p.error("give an OBJECT, --flap or --objects")
    print(f"machine: {describe()}")
    engines = [ENGINES[e] for e in args.engines.split(",")]
    steps = sorted((float(s) for s in args.steps.split(",")), reverse=True)
    with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if args.objects:
            named = [(name, load(path)) for name, path in
                     objects(args.objects.split(","), None, Path(folder))]
        else:
            named = [("flap", flap()) if args.flap else (args.object, load(args.object))]
        for name, obj in named:
            variant, experiment = EXPERIMENTS[args.experiment](obj)
            if experiment.joints:
                print(f"\n{name}, {args.experiment}:")
                table(engines, steps, variant, experiment, Path(folder) / "files")


def table(engines, steps, variant, experiment, folder: Path) -> None:
    runs = {}
    files = write_formats(variant, folder, sorted({e.format for e in engines}))
    for dt in steps:
        run = dataclasses.replace(experiment, dt=dt,
                                  sample_every=max(1, round(SAMPLE_PERIOD / dt)))
        for e in engines:
            start = time.process_time()
            refine = round(experiment.dt / dt)
            runs[e.label, dt] = (run, simulate_converged(files[e.format], experiment, refine)
                                 if e is REFERENCE and refine > 1 else
                                 e.simulate(files[e.format], run))
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
