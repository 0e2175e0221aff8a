"""``--engine ray``: one Ray task per object, Ray's own scheduling and fault tolerance.

Without ``--address`` an embedded single-node cluster is started with ``workers`` CPUs and
shut down at the end; with one, the batch joins that cluster and uses all its CPUs. Every
node needs this package installed, and either sees the input and output folders at the same
paths (``--transfer shared``, the default) or gets the files through Ray's object store
(``--transfer object-store``); see docs/batch.md. A worker process that dies is Ray's to
handle: the task is retried ``retries`` times (``max_retries``), then its object is recorded
as failed. Errors a task raises never reach Ray: they are failed records already.
"""

from __future__ import annotations

import logging
import os
import time
from collections import deque
from collections.abc import Iterator, Sequence

from .inputs import BatchInputError
from .tasks import BatchTaskError
from .transfer import pack_inputs, run_shipped, unpack_outputs
from .worker import WorkItem, crashed_record, describe, failed_record, run_one, warm_up

TRANSFERS = ("shared", "object-store")
# The embedded cluster's object store carries records, task arguments and, with
# --transfer object-store, a few objects' files per worker.
_OBJECT_STORE_BYTES = 512 * 2**20
_SHIPPED_PER_WORKER = 4
_WAIT_BATCH = 64


class RayEngine:
    name = "ray"

    def __init__(self, workers: int | None, retries: int, address: str | None = None,
                 warm_modules: Sequence[str] = (), transfer: str = "shared"):
        if transfer not in TRANSFERS:
            raise BatchInputError(f"unknown transfer {transfer!r}; choose from "
                                  f"{', '.join(TRANSFERS)}")
        self.transfer = transfer
        self.workers = workers
        self.retries = retries
        self.address = address or os.environ.get("RAY_ADDRESS")  # as ray.init reads it
        self.warm_modules = tuple(warm_modules)
        self.startup_s = 0.0
        self._started = False

    def __enter__(self) -> RayEngine:
        try:
            import ray
        except ImportError as e:
            raise BatchInputError("--engine ray needs Ray: pip install 'real2code-export[batch]'"
                                  ) from e
        t0 = time.perf_counter()
        if not ray.is_initialized():
            if self.address:
                ray.init(address=self.address, logging_level=logging.WARNING,
                         log_to_driver=False)
            else:
                ray.init(num_cpus=self.workers, include_dashboard=False,
                         object_store_memory=_OBJECT_STORE_BYTES,
                         logging_level=logging.WARNING, log_to_driver=False)
            self._started = True
        cpus = int(ray.cluster_resources().get("CPU", 1))
        self.workers = cpus if self.address or self.workers is None else self.workers
        warm = ray.remote(num_cpus=1)(warm_up)
        ray.get([warm.remote(self.warm_modules) for _ in range(self.workers)])
        self.startup_s = time.perf_counter() - t0
        return self

    def __exit__(self, *exc) -> None:
        if self._started:
            import ray

            ray.shutdown()
            self._started = False

    def run(self, items: Sequence[WorkItem]) -> Iterator[dict]:
        """Records as objects finish (in completion order)."""
        import ray
        from ray.exceptions import RayError

        shipped = self.transfer == "object-store"
        task = ray.remote(num_cpus=1, max_retries=self.retries, retry_exceptions=False)(
            run_shipped if shipped else run_one)
        # Files in flight take object-store memory: a few objects per worker at a time.
        limit = _SHIPPED_PER_WORKER * self.workers if shipped else len(items)
        pending = deque(items)
        refs: dict = {}
        try:
            while pending or refs:
                while pending and len(refs) < limit:
                    item = pending.popleft()
                    try:
                        args = (item, pack_inputs(item)) if shipped else (item,)
                    except (OSError, BatchTaskError) as e:
                        yield failed_record(item, describe(e))
                        continue
                    refs[task.remote(*args)] = item
                if not refs:
                    continue
                done, _ = ray.wait(list(refs), num_returns=min(len(refs), _WAIT_BATCH),
                                   timeout=0.5)
                for ref in done:
                    item = refs.pop(ref)
                    try:
                        result = ray.get(ref)
                    except RayError as e:  # the worker died on every attempt
                        yield crashed_record(item, self.retries + 1, _first_line(e))
                        continue
                    record = result[0] if shipped else result
                    if shipped:
                        unpack_outputs(item, result[1])
                    record["attempts"] = None  # Ray retries on its own and does not say
                    yield record
        finally:
            for ref in refs:  # interrupted: stop what has not finished
                ray.cancel(ref, force=True)


def _first_line(e: BaseException) -> str:
    text = str(e).strip()
    return f"{type(e).__name__}: {text.splitlines()[0] if text else ''}"
