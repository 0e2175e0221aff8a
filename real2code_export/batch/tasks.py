"""One function per batch task: ``task(obj, out, options) -> TaskResult``.

Each writes into ``out``, a fresh folder of its own that the batch moves into place only when
the task returns (so a failure leaves nothing behind), and returns what the manifest records.
Problems raise (the batch records them as failed and goes on); a check that finds
disagreement returns its outputs with ``error`` set (recorded as failed, outputs kept to
inspect). Heavy modules are imported inside the tasks.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from .. import atomic
from ..errors import Real2CodeError
from ..jsonsafe import finite_or_null
from .inputs import BatchObject, is_model_file

CHECK_REPORT = "check.json"


class BatchTaskError(Real2CodeError):
    """A batch task cannot run for this object (the message says why)."""


@dataclass(frozen=True)
class TaskOptions:
    """The options a task runs with (part of every object's key: changing one redoes all)."""

    formats: tuple[str, ...] = ()  # export/calibrate; () = json and every available format
    check: bool = True  # check the files a task writes (check: the files it is given)
    configurations: int = 100
    seed: int = 0
    tol_position: float = 1e-6
    tol_rotation: float = 1e-6

    def __post_init__(self):
        from ..formats import FORMATS, export_formats

        if not self.formats:
            object.__setattr__(self, "formats", ("json", *export_formats()))
        unknown = [f for f in self.formats if f not in FORMATS]
        if unknown or not self.formats:
            raise BatchTaskError(f"--to: unknown or no format(s) {unknown or ''}; choose from "
                                 f"{', '.join(FORMATS)}")
        if self.configurations < 1:
            raise BatchTaskError(f"--configurations must be >= 1, got {self.configurations}")
        if not (self.tol_position > 0 and self.tol_rotation > 0):
            raise BatchTaskError("--tol-position and --tol-rotation must be > 0")

    def to_json(self) -> dict[str, Any]:
        d = asdict(self)
        d["formats"] = list(self.formats)
        return d


@dataclass
class TaskResult:
    outputs: list[str]  # files written, relative to the task's folder
    check: dict[str, Any] | None = None  # the check's summary
    result: dict[str, Any] | None = None  # figures particular to the task
    error: str | None = None  # a failure found after the outputs were written
    timings: dict[str, float] = field(default_factory=dict)


TaskFunction = Callable[[BatchObject, Path, TaskOptions], TaskResult]


@dataclass(frozen=True)
class TaskSpec:
    name: str
    run: TaskFunction  # a module-level function: it is sent to worker processes by name
    warm_modules: tuple[str, ...] = ()  # imported when a worker starts, not on its first object


# -- tasks -------------------------------------------------------------------------------------
def export_task(obj: BatchObject, out: Path, options: TaskOptions) -> TaskResult:
    """Load the model, write every requested format, then check them against each other."""
    from ..formats import hulls_collision, load, write_formats

    timings: dict[str, float] = {}
    with _timed(timings, "load_s"):  # (no hulls for formats whose consumers take them)
        model = load(obj.files[0], hull_collision=not hulls_collision(list(options.formats)))
    with _timed(timings, "export_s"):
        written = write_formats(model, out, list(options.formats))
    check, error = _check_outputs(list(written.values()), out, options, timings)
    result = {"parts": len(model.parts), "movable_joints": len(model.movable_joints)}
    return TaskResult(_listing(out), check, result, error, timings)


def check_task(obj: BatchObject, out: Path, options: TaskOptions) -> TaskResult:
    """Load the object's files in their own tools and compare them; ``check.json`` out."""
    from ..check import check_files

    timings: dict[str, float] = {}
    with _timed(timings, "check_s"):
        report = check_files(list(obj.files), **_check_arguments(options))
    summary, error = _summary(report)
    atomic.write_text(out / CHECK_REPORT, json.dumps(report.to_json(), indent=1) + "\n")
    return TaskResult([CHECK_REPORT], summary, None, error, timings)


def calibrate_task(obj: BatchObject, out: Path, options: TaskOptions) -> TaskResult:
    """``real2code calibrate`` on a folder: its model, its CSVs (``*holdout*`` held out)."""
    from ..calibrate import calibrate
    from ..formats import FORMATS, load

    timings: dict[str, float] = {}
    with _timed(timings, "load_s"):
        model = load(obj.files[0])
    with _timed(timings, "calibrate_s"):
        cal = calibrate(model, list(obj.data), list(obj.holdout), out, list(options.formats))
    report = cal.report
    result = {k: report.get(k) for k in ("causes", "rmse_before", "rmse_after",
                                         "holdout_rmse_before", "holdout_rmse_after",
                                         "unexplained")}
    models = [p for name, p in cal.files.items() if name in FORMATS]
    check, error = _check_outputs(models, out, options, timings)
    return TaskResult(_listing(out), check, finite_or_null(result), error, timings)


def reconstruct_task(obj: BatchObject, out: Path, options: TaskOptions) -> TaskResult:
    """``pipeline.reconstruct.reconstruct(capture, out)`` on a capture folder, then the check
    of the model files it wrote (written again with paths relative to the output, so the
    outputs are the same wherever the batch ran)."""
    try:
        from pipeline.reconstruct import reconstruct
    except ModuleNotFoundError as e:
        if e.name not in ("pipeline", "pipeline.reconstruct"):
            raise
        raise BatchTaskError(f"{obj.folder}: reconstruct: this installation has no "
                             "pipeline.reconstruct (the reconstruction pipeline)") from e
    timings: dict[str, float] = {}
    with _timed(timings, "reconstruct_s"):
        result = reconstruct(obj.folder, out, formats=[f for f in options.formats if f != "json"])
    stages = getattr(result, "timings", None)  # seconds per pipeline stage, when it says
    if isinstance(stages, dict):
        timings.update({f"{k}_s": round(float(v), 4) for k, v in stages.items()})
    models = sorted(p for p in out.iterdir() if p.is_file() and is_model_file(p))
    if not models:
        raise BatchTaskError(f"{obj.folder}: reconstruct wrote no model file into its output")
    check, error = _check_outputs(models, out, options, timings)
    return TaskResult(_listing(out), check, None, error, timings)


def _format_imports() -> tuple[str, ...]:
    from ..formats import FORMATS

    names = (n for f in FORMATS.values()
             for n in (*f.requires, *f.read_requires, f.module, *f.probes))
    return tuple(dict.fromkeys(names))


# The heavy libraries every task's export and check use (a missing one is skipped): every
# format's, as the registry names them.
_WARM = ("trimesh", "real2code_export.check", *_format_imports())
TASKS: dict[str, TaskSpec] = {
    "export": TaskSpec("export", export_task, _WARM),
    "check": TaskSpec("check", check_task, _WARM),
    "calibrate": TaskSpec("calibrate", calibrate_task, (*_WARM, "real2code_export.calibrate")),
    "reconstruct": TaskSpec("reconstruct", reconstruct_task, _WARM),
}


# -- shared steps ------------------------------------------------------------------------------
def _check_outputs(paths: list[Path], out: Path, options: TaskOptions,
                   timings: dict[str, float]) -> tuple[dict | None, str | None]:
    """Check written files and keep the full report beside them (paths relative to ``out``,
    so the report is the same wherever the batch ran)."""
    if not options.check or not paths:
        return None, None
    from ..check import check_files

    with _timed(timings, "check_s"):
        report = check_files(paths, **_check_arguments(options))
    summary, error = _summary(report)
    text = json.dumps(_relative(report.to_json(), out), indent=1) + "\n"
    atomic.write_text(out / CHECK_REPORT, text)
    return _relative(summary, out), _relative(error, out)


def _check_arguments(options: TaskOptions) -> dict[str, Any]:
    return {"n_configurations": options.configurations, "seed": options.seed,
            "tol_position": options.tol_position, "tol_rotation": options.tol_rotation}


def _summary(report) -> tuple[dict[str, Any], str | None]:
    """What the manifest keeps of a check report."""
    summary = finite_or_null({
        "ok": report.ok,
        "probes": [p.label for p in report.probes],
        "max_position_error": report.max_position_error,
        "max_rotation_error": report.max_rotation_error,
        "mismatches": len(report.mismatches),
        "first_mismatches": [m.message for m in report.mismatches[:3]],
        "validation_errors": sum(v.errors for v in report.validations),
        "validation_warnings": sum(v.warnings for v in report.validations),
    })
    error = None
    if not report.ok:
        error = (f"check: {len(report.mismatches)} mismatch(es); first: "
                 f"{report.mismatches[0].message}")
    return summary, error


def _listing(folder: Path) -> list[str]:
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file())


def _relative(value, base: Path):
    """``value`` with the task folder's absolute path taken out of every string."""
    return replace_text(value, str(base) + "/", "")


def replace_text(value, old: str, new: str):
    """``value`` (JSON-like) with ``old`` replaced by ``new`` in every string."""
    if isinstance(value, str):
        return value.replace(old, new)
    if isinstance(value, dict):
        return {k: replace_text(v, old, new) for k, v in value.items()}
    if isinstance(value, list):
        return [replace_text(v, old, new) for v in value]
    return value




@contextmanager
def _timed(timings: dict[str, float], name: str) -> Iterator[None]:
    t0 = time.perf_counter()
    try:
        yield
    finally:
        timings[name] = round(time.perf_counter() - t0, 4)
