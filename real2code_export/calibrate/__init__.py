"""Calibrate a model's joint dynamics against measured motion: replay it in MuJoCo, show what
the simulation gets wrong, name the cause from a fixed vocabulary of effects, extend the
model with it, fit it, and measure the gain on data it did not fit.

Modules: ``trajectory`` (the CSV contract), ``spec`` / ``simulate`` (the replay),
``experiment`` / ``feedback`` (the experiment file and a declared closed loop),
``windows`` (the window, unmeasured pushes left out), ``features`` (what points at
causes), ``effects`` (the candidate library), ``inverse`` and ``fit`` (fitting), ``select``
(model selection), ``prediction`` (a model predicting runs from their opening),
``validate`` (cross-validation: no false causes), ``inertial`` (base
inertial parameters), ``apply`` / ``extras`` (into the model), ``report``, ``run`` (the
entry points). Real data sets reach it through the general command: their converters to
CSV + experiment file are scripts in ``bench/``.
"""

from .prediction import predict
from .run import (
    CalibrationResult,
    calibrate,
    calibrate_trajectories,
    replay,
    run_calibrate,
)
from .trajectory import Trajectory, read_csv

__all__ = [
    "CalibrationResult",
    "Trajectory",
    "calibrate",
    "calibrate_trajectories",
    "predict",
    "read_csv",
    "replay",
    "run_calibrate",
]
