"""Forward-kinematics reference, run by the main venv's Python (not Blender's).

    .venv/bin/python blender_addon/tests/fk_reference.py < request.json > poses.json

Request: a list of ``{"path": FILE, "configurations": N, "seed": S}``. For each file, the
model the project's own reader makes of it, its joint values (configuration 0 is the
observed state; the others are drawn within the limits, continuous joints in [-pi, pi]) and
the world pose of every part (4x4, row-major) at each, from ``forward_kinematics``.
"""

from __future__ import annotations

import json
import sys
import warnings

import numpy as np

from real2code_export.formats import load
from real2code_export.model import forward_kinematics, sample_configuration


def reference(path: str, configurations: int, seed: int) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # repair notes are not what this compares
        obj = load(path)
    rng = np.random.default_rng(seed)
    values = [obj.observed_configuration()]
    values += [sample_configuration(obj, rng) for _ in range(configurations - 1)]
    return {
        "name": obj.name,
        "parts": [p.name for p in obj.parts],
        "joints": {j.name: j.type.value for j in obj.joints},
        "configurations": values,
        "poses": [{name: pose.tolist() for name, pose in forward_kinematics(obj, q).items()}
                  for q in values],
    }


def main() -> None:
    request = json.load(sys.stdin)
    json.dump({r["path"]: reference(r["path"], r["configurations"], r["seed"]) for r in request},
              sys.stdout)


if __name__ == "__main__":
    main()
