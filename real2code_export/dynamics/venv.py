"""Engines whose pins clash with the main venv (ovphysx, Newton: usd-core < 26.9, their own
warp) run in ``.venv-engines`` (scripts/setup_engines.sh) as a subprocess: the experiment as
JSON on stdin, the trajectory as JSON on stdout. That venv needs numpy and lxml only of ours:
``real2code_export.dynamics`` imports nothing heavier."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

from . import EngineUnavailable, Experiment, Trajectory

REPO = Path(__file__).resolve().parents[2]
VENV_PYTHON = REPO / ".venv-engines" / "bin" / "python"
TIMEOUT = 600  # s: Newton compiles its kernels on first use (~30 s)


def engines_python() -> Path | None:
    """The engines venv's Python (REAL2CODE_ENGINES_PYTHON overrides), None when absent."""
    given = os.environ.get("REAL2CODE_ENGINES_PYTHON")
    path = Path(given) if given else VENV_PYTHON
    return path if path.is_file() else None


def run_in_venv(module: str, package: str, path: Path, experiment: Experiment) -> Trajectory:
    """``module``'s ``simulate`` here when ``package`` imports here, else in the engines venv."""
    if importlib.util.find_spec(package) is not None:
        return importlib.import_module(module).simulate_here(path, experiment)
    python = engines_python()
    if python is None:
        raise EngineUnavailable(f"{package} is not installed here and there is no engines venv "
                                f"at {VENV_PYTHON} (run scripts/setup_engines.sh)")
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
