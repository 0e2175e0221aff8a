"""The `limit` experiment at other time steps: how far Pinocchio's and Bullet's stops end from
MuJoCo's (MJCF) when the step is shorter than the check's 1 ms.

    .venv/bin/python bench/limit_steps.py OBJECT [--steps 1e-3,5e-4,2.5e-4,1.25e-4]

OBJECT: any file our readers take (a demo's object.json). `real2code simulate` runs at 1 ms
only; MuJoCo's limit softness (engine_settings.LIMIT_SOLREF) is meant to be as stiff as
the step allows at every step, which this shows (docs/engines.md).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))
from _machine import describe  # noqa: E402

from real2code_export.dynamics.experiments import EXPERIMENTS  # noqa: E402
from real2code_export.dynamics.run import ENGINES, REFERENCE, compare, write_formats  # noqa: E402
from real2code_export.formats import load  # noqa: E402

OTHERS = ["pinocchio", "bullet"]
SAMPLE_PERIOD = 0.01  # s, as the check's 10 steps of 1 ms


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("object")
    p.add_argument("--steps", default="1e-3,5e-4,2.5e-4,1.25e-4")
    args = p.parse_args()
    print(f"machine: {describe()}")
    variant, experiment = EXPERIMENTS["limit"](load(args.object))
    print(f"| step (s) | {' | '.join(ENGINES[e].label for e in OTHERS)} |")
    print("|---|" + "---|" * len(OTHERS))
    with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        files = write_formats(variant, folder, ["mjcf", "urdf"])
        for dt in (float(s) for s in args.steps.split(",")):
            run = dataclasses.replace(experiment, dt=dt,
                                      sample_every=max(1, round(SAMPLE_PERIOD / dt)))
            reference = REFERENCE.simulate(files["mjcf"], run)
            cells = []
            for e in OTHERS:
                _, angle, distance = compare(run, reference, ENGINES[e].simulate(files["urdf"], run))
                cells.append(f"{angle:.1e} rad / {distance:.1e} m")
            print(f"| {dt:g} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
