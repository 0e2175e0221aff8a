"""A batch from start to end: expand the inputs, skip what an earlier run finished, run the
rest on an engine, record every object in the manifest as it finishes, summarise."""

from __future__ import annotations

import fcntl
import os
import shutil
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from .. import __version__
from . import manifest
from .fingerprint import input_size, inputs_hash, task_key
from .inputs import BatchInputError, BatchObject, expand_inputs
from .progress import Progress, Summary
from .tasks import TASKS, TaskOptions, TaskSpec
from .worker import STAGING, WorkItem

ENGINES = ("local", "ray")
CACHE = ".cache"  # DIR/.cache: the collision-decomposition cache every worker shares
LOCK = ".lock"


def run_batch(task: str | TaskSpec, inputs: Sequence[str | Path], out_dir: str | Path, *,
              options: TaskOptions | None = None, inputs_kind: str | None = None,
              engine: str = "local", workers: int | None = None, retries: int = 2,
              address: str | None = None, transfer: str = "shared",
              cache_dir: str | Path | None = None, force: bool = False,
              progress: bool = True) -> Summary:
    """Run ``task`` (a name in :data:`TASKS`, or a spec) on every object ``inputs`` name.

    Objects whose manifest line says done, with the same key (inputs' content, options,
    version) and every output present, are skipped unless ``force``. ``inputs_kind`` says how
    to find objects (default: the task's name). ``transfer="object-store"`` (Ray only) sends
    input and output files through Ray's object store, for nodes that share no file system.
    Ctrl-C stops the batch after the objects in
    flight (the summary says ``interrupted``); rerunning the same call continues it.
    """
    spec = TASKS[task] if isinstance(task, str) else task
    options = options or TaskOptions()
    if engine not in ENGINES:
        raise BatchInputError(f"unknown engine {engine!r}; choose from {', '.join(ENGINES)}")
    if transfer != "shared" and engine != "ray":
        raise BatchInputError(f"--transfer {transfer} needs --engine ray")
    if workers is not None and workers < 1:
        raise BatchInputError(f"--workers must be >= 1, got {workers}")
    if retries < 0:
        raise BatchInputError(f"--retries must be >= 0, got {retries}")
    out = Path(out_dir).resolve()  # workers may run elsewhere: absolute paths only
    objects = expand_inputs(inputs, inputs_kind or spec.name, exclude=[out])
    out.mkdir(parents=True, exist_ok=True)
    with _exclusive(out):
        shutil.rmtree(out / STAGING, ignore_errors=True)  # left by workers that died
        path = out / manifest.FILENAME
        records = manifest.read(path)
        manifest.rewrite(path, records.values())  # drops a line a killed run left cut short
        todo = [o for o in objects
                if force or not _still_done(o, records.get(o.id), spec, options, out)]
        cache = Path(cache_dir).resolve() if cache_dir else out / CACHE
        todo.sort(key=lambda o: (-_size(o), o.id))  # biggest first: a shorter tail
        items = [WorkItem(spec, o, options, out, cache, __version__, engine) for o in todo]
        summary = Summary(spec.name, engine, 0, str(out), len(objects),
                          len(objects) - len(todo), {"ok": 0, "repaired": 0, "failed": 0},
                          0.0, 0.0)
        try:
            _run_items(items, summary, path, engine, workers, retries, address, transfer,
                       spec, progress)
        finally:  # from the file: an interrupt may fall between a line and its bookkeeping
            manifest.rewrite(path, manifest.read(path).values())
            shutil.rmtree(out / STAGING, ignore_errors=True)
    return summary


def _run_items(items: list[WorkItem], summary: Summary, path: Path, engine: str,
               workers: int | None, retries: int, address: str | None, transfer: str,
               spec: TaskSpec, progress: bool) -> None:
    if engine == "ray":
        from .ray_engine import RayEngine

        runner = RayEngine(workers or (None if address else os.cpu_count()), retries, address,
                           spec.warm_modules, transfer)
    else:
        from .local import LocalEngine

        runner = LocalEngine(workers or os.cpu_count() or 1, retries, spec.warm_modules)
    if not items:
        summary.workers = runner.workers or 0
        return
    with runner:
        summary.startup_s = runner.startup_s
        summary.workers = runner.workers
        bar = Progress(summary.objects, summary.skipped, f"{spec.name} ({engine})", progress)
        t0 = time.perf_counter()
        try:
            for record in runner.run(items):
                manifest.append(path, record)
                _count(summary, record)
                bar.update(record)
        except KeyboardInterrupt:
            summary.interrupted = True
        finally:
            summary.wall_s = time.perf_counter() - t0
            bar.close()


def _count(summary: Summary, record: dict) -> None:
    summary.counts[record["status"]] += 1
    summary.object_seconds.append(record["timings"].get("total_s", 0.0))
    summary.cpu_seconds.append(record["timings"].get("cpu_s", 0.0))
    if record["status"] == "failed":
        summary.failed.append({"id": record["id"], "error": record["error"]})
    if record.get("check") is not None:
        key = "agree" if record["check"].get("ok") else "disagree"
        summary.check[key] = summary.check.get(key, 0) + 1


def _still_done(obj: BatchObject, record: dict | None, spec: TaskSpec, options: TaskOptions,
                out: Path) -> bool:
    """Whether an earlier run's result for ``obj`` stands (hashing only objects it finished)."""
    if record is None or record.get("status") not in manifest.DONE or obj.problem:
        return False
    try:
        key = task_key(spec.name, options.to_json(), __version__, inputs_hash(obj))
    except OSError:  # an input vanished: the task will say so
        return False
    return manifest.is_done(record, key, out)


def _size(obj: BatchObject) -> int:
    try:
        return input_size(obj)
    except OSError:  # the task will report the missing file
        return 0


@contextmanager
def _exclusive(out: Path) -> Iterator[None]:
    """One batch at a time per output folder (two would interleave the manifest).
    An advisory lock (flock): released by the kernel if this process dies."""
    with (out / LOCK).open("w") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError as e:
            raise BatchInputError(f"{out}: another batch is writing to this folder") from e
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)
