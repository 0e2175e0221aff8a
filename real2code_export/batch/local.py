"""``--engine local``: a process pool on this machine (the standard library's
``ProcessPoolExecutor``), no server.

A worker that dies (a crash in a native library, the out-of-memory killer) breaks the whole
pool and every object in flight with it, and the pool cannot say which one killed it. So the
pool is restarted, and the objects that were in flight are run again one at a time: an
object that crashes alone is the culprit and is blamed each time, until ``retries`` is spent
and it is recorded as failed; the innocent ones simply finish. An object is never blamed for
a break it shared with others, so ``retries=0`` does not fail the bystanders. A record's
``attempts`` counts every start, shared breaks included.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import time
from collections import deque
from collections.abc import Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool

from ..errors import InputError
from .worker import WorkItem, crashed_record, run_one, warm_up

# One thread per worker process in the numeric libraries: the pool already fills the cores
# (Ray does the same for its workers), and it keeps results the same on every engine.
_SINGLE_THREADED = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
                    "MKL_NUM_THREADS": "1"}


class LocalEngine:
    name = "local"

    def __init__(self, workers: int, retries: int, warm_modules: Sequence[str] = ()):
        if workers < 1:
            raise InputError(f"workers must be >= 1, got {workers}")
        self.workers = workers
        self.retries = retries
        self.warm_modules = tuple(warm_modules)
        self.startup_s = 0.0
        self._pool: ProcessPoolExecutor | None = None

    def __enter__(self) -> LocalEngine:
        t0 = time.perf_counter()
        self._pool = self._start_pool()
        self.startup_s = time.perf_counter() - t0
        return self

    def __exit__(self, *exc) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def run(self, items: Sequence[WorkItem]) -> Iterator[dict]:
        """Records as objects finish (in completion order)."""
        pending = deque(items)
        suspects: deque[WorkItem] = deque()  # in flight when the pool broke: run alone
        runs: dict[str, int] = {}  # times each object was started: its record's attempts
        blamed: dict[str, int] = {}  # times it broke the pool while running alone
        in_flight: dict[Future, WorkItem] = {}

        def submit(item: WorkItem) -> None:
            runs[item.obj.id] = runs.get(item.obj.id, 0) + 1
            in_flight[self._pool.submit(run_one, item)] = item

        def finished(item: WorkItem, record: dict) -> dict:
            record["attempts"] = runs[item.obj.id]
            return record

        try:
            while pending or suspects or in_flight:
                if suspects:
                    if not in_flight:
                        submit(suspects.popleft())
                else:
                    while pending and len(in_flight) < self.workers:
                        submit(pending.popleft())
                done, _ = wait(in_flight, return_when=FIRST_COMPLETED)
                lost = []
                for future in done:
                    item = in_flight.pop(future)
                    try:
                        record = future.result()
                    except BrokenProcessPool:
                        lost.append(item)
                        continue
                    yield finished(item, record)
                if not lost:
                    continue
                # The pool takes every object still in flight with it, bar those that
                # finished just before it broke.
                for future, item in in_flight.items():
                    if future.done() and future.exception() is None:
                        yield finished(item, future.result())
                    else:
                        lost.append(item)
                in_flight.clear()
                self._pool.shutdown(wait=True, cancel_futures=True)
                self._pool = self._start_pool()
                if len(lost) > 1:  # no telling which one did it: each runs again alone
                    suspects.extend(lost)
                    continue
                item = lost[0]  # it ran alone, so it is the culprit
                n = blamed[item.obj.id] = blamed.get(item.obj.id, 0) + 1
                if n > self.retries:
                    yield crashed_record(item, runs[item.obj.id],
                                         "a process in the pool was terminated abruptly "
                                         "(crash, os._exit or a kill signal)")
                else:
                    suspects.append(item)
        except KeyboardInterrupt:
            yield from self._drain(in_flight)
            raise

    def _drain(self, in_flight: dict[Future, WorkItem]) -> Iterator[dict]:
        """On Ctrl-C: start nothing new, keep what finishes; a second Ctrl-C stops at once."""
        self._pool.shutdown(wait=False, cancel_futures=True)
        try:
            for future in list(in_flight):
                if future.cancelled():
                    continue
                with contextlib.suppress(Exception):
                    yield future.result()
        except KeyboardInterrupt:
            self._terminate()
            raise

    def _terminate(self) -> None:
        # ProcessPoolExecutor has no public way to stop running workers before Python 3.14
        # (terminate_workers); its process table is the only handle on them.
        for process in list(getattr(self._pool, "_processes", {}).values()):
            with contextlib.suppress(Exception):
                process.terminate()

    def _start_pool(self) -> ProcessPoolExecutor:
        # Fresh interpreters ("spawn"), not fork: the driver may hold threads (progress bar,
        # Ray) and forking a threaded process can deadlock the child.
        pool = ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context("spawn"),
                                   initializer=_ignore_interrupts)
        # Each submit starts one process while none is idle: all of them start here, with
        # the environment they must inherit.
        with _environment(_SINGLE_THREADED):
            ready = [pool.submit(warm_up, self.warm_modules) for _ in range(self.workers)]
        for future in ready:
            future.result()
        return pool


def _ignore_interrupts() -> None:
    """Ctrl-C reaches the whole process group; the driver decides what it stops."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextlib.contextmanager
def _environment(values: dict[str, str]) -> Iterator[None]:
    """Set variables the user has not set, for child processes started inside."""
    added = {k: v for k, v in values.items() if k not in os.environ}
    os.environ.update(added)
    try:
        yield
    finally:
        for k in added:
            os.environ.pop(k, None)
