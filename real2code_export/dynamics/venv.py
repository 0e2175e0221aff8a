"""Engines whose pins clash with the main venv run in a venv of their own as a subprocess:
the experiment as JSON on stdin, the trajectory as JSON on stdout. ``.venv-engines``
(scripts/setup_engines.sh): ovphysx, Newton (usd-core < 26.9, their own warp, mujoco 3.17)
and SAPIEN; ``.venv-genesis`` (scripts/setup_genesis.sh): Genesis (torch, mujoco 4.0).
Those venvs need numpy and lxml only of ours: ``real2code_export.dynamics`` imports nothing
heavier."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from . import EngineUnavailable, Experiment, Trajectory

REPO = Path(__file__).resolve().parents[2]
TIMEOUT = 900  # s: Newton and Genesis compile their kernels on first use (~30 s to ~2 min)


@dataclass(frozen=True)
class Venv:
    folder: str  # beside the repository's root
    setup: str  # the script that makes it
    override: str  # an environment variable naming another Python instead

    @property
    def default_python(self) -> Path:
        return REPO / self.folder / "bin" / "python"

    def python(self) -> Path | None:
        """Its Python (the environment variable overrides), None when absent."""
        given = os.environ.get(self.override)
        path = Path(given) if given else self.default_python
        return path if path.is_file() else None


ENGINES_VENV = Venv(".venv-engines", "scripts/setup_engines.sh", "REAL2CODE_ENGINES_PYTHON")
GENESIS_VENV = Venv(".venv-genesis", "scripts/setup_genesis.sh", "REAL2CODE_GENESIS_PYTHON")


def run_in_venv(module: str, package: str, path: Path, experiment: Experiment,
                venv: Venv = ENGINES_VENV) -> Trajectory:
    """``module``'s ``simulate`` here when ``package`` imports here, else in ``venv``."""
    if importlib.util.find_spec(package) is not None:
        return importlib.import_module(module).simulate_here(path, experiment)
    python = venv.python()
    if python is None:
        raise EngineUnavailable(f"{package} is not installed here and there is no venv at "
                                f"{venv.default_python.parents[1]} (run {venv.setup})")
    request = json.dumps({"path": str(path), "experiment": experiment.to_json()})
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    done = subprocess.run([str(python), "-m", module], input=request, capture_output=True,
                          text=True, env=env, timeout=TIMEOUT, check=False)
    if done.returncode != 0:
        lines = [line for line in done.stderr.strip().splitlines() if line.strip()]
        raise RuntimeError(lines[-1] if lines else f"exit status {done.returncode}")
    return Trajectory.from_json(json.loads(done.stdout.strip().splitlines()[-1]))


def serve(simulate_here) -> None:
    """The subprocess side: read one request from stdin, print the trajectory as one line."""
    request = json.loads(sys.stdin.read())
    trajectory = simulate_here(Path(request["path"]), Experiment.from_json(request["experiment"]))
    sys.stdout.write(json.dumps(trajectory.to_json()) + "\n")
