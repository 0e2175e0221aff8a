"""What a worker process does with one object, whichever engine sent it: run the task in a
fresh folder, move the outputs into place, and return the object's manifest record.

Every exception a task raises becomes a ``failed`` record, so only a dying process (a crash
inside a native library, ``os._exit``, the out-of-memory killer) reaches the engine, which
retries the object in a new process and records it as failed when the retries run out.
"""

from __future__ import annotations

import contextlib
import importlib
import os
import shutil
import socket
import tempfile
import time
import traceback
import uuid
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from ..errors import Real2CodeError, Real2CodeWarning
from .fingerprint import inputs_hash, task_key
from .inputs import BatchObject
from .tasks import BatchTaskError, TaskOptions, TaskSpec

STAGING = ".staging"  # DIR/.staging: tasks' folders until they are moved into place


@dataclass(frozen=True)
class WorkItem:
    """Everything a worker needs for one object (small: paths, not data)."""

    task: TaskSpec
    obj: BatchObject
    options: TaskOptions
    out_dir: Path  # the batch's DIR
    cache_dir: Path | None  # shared collision-decomposition cache ($REAL2CODE_CACHE);
    # None: the node's own (objects sent through Ray's object store to other machines)
    version: str
    engine: str


def warm_up(modules: Sequence[str]) -> int:
    """Import the task's heavy libraries once per worker; returns the worker's pid."""
    for name in modules:
        # an optional format may be missing: the tasks that need it will say so
        with contextlib.suppress(ImportError):
            importlib.import_module(name)
    return os.getpid()


def run_one(item: WorkItem) -> dict:
    """Run ``item``'s task; its manifest record (``attempts`` is set by the engine)."""
    if item.cache_dir is not None:
        os.environ["REAL2CODE_CACHE"] = str(item.cache_dir)  # every worker shares one cache
    t0, cpu0 = time.perf_counter(), time.process_time()
    obj = item.obj
    record = new_record(item)
    staging: Path | None = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", Real2CodeWarning)
        try:
            if obj.problem:
                raise BatchTaskError(obj.problem)
            t_hash = time.perf_counter()
            record["inputs_hash"] = inputs_hash(obj)
            hash_s = round(time.perf_counter() - t_hash, 4)
            record["key"] = task_key(item.task.name, item.options.to_json(), item.version,
                                     record["inputs_hash"])
            staging = staging_folder(item.out_dir, obj.id)
            result = item.task.run(obj, staging, item.options)
            install(staging, item.out_dir / obj.id)
            staging = None
            record.update(outputs=[f"{obj.id}/{rel}" for rel in result.outputs],
                          check=result.check, result=result.result, error=result.error,
                          timings={"hash_s": hash_s, **result.timings})
        except (Exception, SystemExit) as e:  # recorded; the batch goes on
            record.update(status="failed", error=describe(e))
            if not isinstance(e, Real2CodeError):
                record["traceback"] = traceback.format_exc(limit=-4)
        finally:
            if staging is not None:
                shutil.rmtree(staging, ignore_errors=True)
    repairs = list(dict.fromkeys(str(w.message) for w in caught
                                 if issubclass(w.category, Real2CodeWarning)))
    record["warnings"] = repairs
    if record["status"] is None:
        record["status"] = "failed" if record["error"] else ("repaired" if repairs else "ok")
    record["timings"]["total_s"] = round(time.perf_counter() - t0, 4)
    # CPU seconds of this process (not its children): total_s / cpu_s shows waiting for a core
    record["timings"]["cpu_s"] = round(time.process_time() - cpu0, 4)
    record["finished_at"] = _now()
    return record


def new_record(item: WorkItem) -> dict:
    obj = item.obj
    return {"id": obj.id, "task": item.task.name, "input": str(obj.source), "status": None,
            "error": None, "warnings": [], "outputs": [], "check": None, "result": None,
            "inputs_hash": None, "key": None, "timings": {}, "attempts": 1,
            "engine": item.engine, "worker": {"host": socket.gethostname(), "pid": os.getpid()},
            "version": item.version, "options": item.options.to_json(), "finished_at": None}


def failed_record(item: WorkItem, error: str, attempts: int | None = 1) -> dict:
    """The record of an object that failed outside a worker's hands."""
    record = new_record(item)
    record.update(status="failed", error=error, attempts=attempts, worker=None,
                  finished_at=_now())
    record["timings"]["total_s"] = 0.0
    return record


def crashed_record(item: WorkItem, attempts: int, message: str) -> dict:
    """The record of an object whose worker process died on every attempt."""
    return failed_record(item, f"worker process died while running this object ({attempts} "
                               f"attempt(s)): {message}", attempts)


def describe(e: BaseException) -> str:
    """A one-line error: the project's messages as they are, others with their type."""
    if isinstance(e, Real2CodeError):
        return f"{type(e).__name__}: {e}"
    if isinstance(e, SystemExit):
        return f"the task called sys.exit({e.code!r})"
    return f"{type(e).__name__}: {e}" if str(e) else type(e).__name__


def install(staging: Path, final: Path) -> None:
    """Replace ``final`` by ``staging`` with renames on one file system: readers see the old
    folder or the new one, never a mix; stale files of an earlier run do not survive."""
    final.parent.mkdir(parents=True, exist_ok=True)
    if not final.exists():
        os.replace(staging, final)
        return
    trash = Path(tempfile.mkdtemp(prefix="replaced-", dir=staging.parent))
    os.replace(final, trash / "old")
    os.replace(staging, final)
    shutil.rmtree(trash, ignore_errors=True)


def staging_folder(out_dir: Path, object_id: str) -> Path:
    # mkdir, not mkdtemp: the folder becomes the output and keeps the user's umask.
    path = out_dir / STAGING / f"{object_id.replace('/', '__')}-{uuid.uuid4().hex}"
    path.mkdir(parents=True)
    return path


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")
