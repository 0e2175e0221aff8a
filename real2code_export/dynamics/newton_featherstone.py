"""Newton 1.8's Featherstone solver (its own reduced-coordinate articulated-body solver,
symplectic Euler) on our USD, loaded as for its MuJoCo solver (newton.py). Runs in the
engines venv (venv.py).

What it leaves out, by its own documentation: joint dry friction (``joint_friction`` is not
applied); a limit is a spring and damper (``joint_limit_ke``, ``joint_limit_kd``: 1e4 and 10
unless the file says otherwise), not a constraint: the check sets them per joint from its
effective inertia and the step (newton.py, ``_featherstone_limits``); damping is applied
explicitly (MuJoCo's implicitly). Its angular body damping (0.05 by default) is set to 0, as
PhysX's is in our USD. No contacts are simulated here.
"""

from __future__ import annotations

from pathlib import Path

from . import Experiment, Trajectory
from .venv import Outcome, run_in_venv, run_many_in_venv, serve


def simulate(path: Path, experiment: Experiment) -> Trajectory:
    return run_in_venv(__name__, "newton", path, experiment)


def simulate_many(cases: list[tuple[Path, Experiment]]) -> list[Outcome]:
    """Every case in one process (venv.py)."""
    return run_many_in_venv(__name__, "newton", cases)


def simulate_here(path: Path, experiment: Experiment) -> Trajectory:
    from .newton import simulate_here as newton_here

    return newton_here(path, experiment, featherstone=True)


if __name__ == "__main__":
    serve(simulate_here)
