"""Batches: one task (export, check, calibrate, reconstruct) per object over a whole dataset,
on a local process pool or on Ray, recorded in ``DIR/manifest.jsonl`` and resumable.

Modules: ``inputs`` (INPUTS to objects), ``fingerprint`` (what an object reads, its content
hash), ``tasks`` (one function per task), ``worker`` (one object in a worker process),
``local`` and ``ray_engine`` (the engines), ``manifest``, ``progress``, ``run`` (a batch
from start to end); its command is ``real2code_export.cli.batch``. Importing this package
imports no engine.
"""

from .inputs import BatchInputError, BatchObject, expand_inputs
from .run import run_batch
from .tasks import TASKS, TaskOptions, TaskResult, TaskSpec

__all__ = [
    "TASKS",
    "BatchInputError",
    "BatchObject",
    "TaskOptions",
    "TaskResult",
    "TaskSpec",
    "expand_inputs",
    "run_batch",
]
