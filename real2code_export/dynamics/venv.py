"""Engines whose pins clash with the main venv run in a venv of their own as a subprocess:
the experiments as JSON on stdin, the trajectories as JSON on stdout, several experiments in
one process (an engine's start-up is most of a run's cost: importing Genesis alone takes
~18 s of CPU). ``.venv-engines``
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
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from . import EngineUnavailable, Experiment, Trajectory

REPO = Path(__file__).resolve().parents[2]
TIMEOUT = 900  # s a run: Newton and Genesis compile their kernels on first use (~30 s to ~2 min)
# An engine refusing a file or an experiment (a missing joint, a value out of its range): that
# run fails, the others go on.
REFUSALS = (KeyError, ValueError, RuntimeError)
# A run's outcome: its trajectory, or why it failed; the seconds it took (the first run in
# a process also its start-up)
Outcome = tuple[Trajectory | Exception, float]


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
    """``module``'s ``simulate_here`` here when ``package`` imports here, else in ``venv``."""
    ((outcome, _),) = run_many_in_venv(module, package, [(path, experiment)], venv)
    if isinstance(outcome, Exception):
        raise outcome
    return outcome


def run_many_in_venv(module: str, package: str, cases: list[tuple[Path, Experiment]],
                     venv: Venv = ENGINES_VENV) -> list[Outcome]:
    """Every case in one process: here when ``package`` imports here, else in ``venv``.
    Raises EngineUnavailable without the venv, RuntimeError when the process fails."""
    if importlib.util.find_spec(package) is not None:
        return simulate_each(importlib.import_module(module).simulate_here, cases)
    python = venv.python()
    if python is None:
        raise EngineUnavailable(f"{package} is not installed here and there is no venv at "
                                f"{venv.default_python.parents[1]} (run {venv.setup})")
    request = json.dumps([{"path": str(path), "experiment": experiment.to_json()}
                          for path, experiment in cases])
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    start = time.perf_counter()
    done = subprocess.run([str(python), "-m", module], input=request, capture_output=True,
                          text=True, env=env, timeout=TIMEOUT * len(cases), check=False)
    if done.returncode != 0:
        lines = [line for line in done.stderr.strip().splitlines() if line.strip()]
        raise RuntimeError(lines[-1] if lines else f"exit status {done.returncode}")
    answers = json.loads(done.stdout.strip().splitlines()[-1])
    outcomes: list[Outcome] = [
        (Trajectory.from_json(a["trajectory"]) if "trajectory" in a else
         RuntimeError(a["error"]), a["seconds"]) for a in answers]
    if outcomes:  # the process's start-up, to its first run
        startup = time.perf_counter() - start - sum(seconds for _, seconds in outcomes)
        outcomes[0] = (outcomes[0][0], outcomes[0][1] + max(startup, 0.0))
    return outcomes


def simulate_each(simulate: Callable[[Path, Experiment], Trajectory],
                  cases: list[tuple[Path, Experiment]]) -> list[Outcome]:
    """Every case in turn; a refusal fails its own run only."""
    outcomes: list[Outcome] = []
    for path, experiment in cases:
        start = time.perf_counter()
        try:
            result: Trajectory | Exception = simulate(path, experiment)
        except REFUSALS as e:
            result = e
        outcomes.append((result, time.perf_counter() - start))
    return outcomes


def serve(simulate_here) -> None:
    """The subprocess side: read the cases from stdin, print their outcomes as one line."""
    cases = [(Path(c["path"]), Experiment.from_json(c["experiment"]))
             for c in json.loads(sys.stdin.read())]
    answers = [{"trajectory": r.to_json(), "seconds": s} if isinstance(r, Trajectory) else
               {"error": f"{type(r).__name__}: {r}", "seconds": s}
               for r, s in simulate_each(simulate_here, cases)]
    sys.stdout.write(json.dumps(answers) + "\n")
