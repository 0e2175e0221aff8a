"""A function run in a forked copy of this process while this one goes on: the second core
put to work where a command has two independent halves, e.g. ``export`` reading its input
while it imports the writers' libraries (USD's ``pxr``: 0.2 s of CPU, a third of an export
of a PartNet-Mobility object to USD; docs/benchmarks.md).

The copy starts with everything this process has imported, so what both halves need is
imported once, before :func:`start`. Its result comes back pickled through a pipe. Where
forking is not safe or not possible (not Linux: macOS's system libraries and Windows do not
survive a fork; another thread alive, native ones included, whose locks the copy would
inherit held; a profiler or tracer watching, which would not see the copy) or where the copy fails in any way (an
error, a result that does not pickle, a crash), the function runs here instead when its
result is asked for: its errors are raised here as if nothing had been forked, and its
result is the same either way.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import sys
from collections.abc import Callable
from typing import Any


def can_fork() -> bool:
    """Whether :func:`start` forks here (see the module's docstring)."""
    return (sys.platform.startswith("linux") and hasattr(os, "fork") and _threads() == 1
            and not sys.getprofile() and not sys.gettrace())


def _threads() -> int:
    """This process's threads, native ones included (a library's pool: OpenBLAS's unless
    ``OPENBLAS_NUM_THREADS=1``, as the console script sets it; USD's TBB workers once it has
    worked), which the threading module does not see and whose locks a copy would inherit
    held; 0 when that cannot be told."""
    try:
        return len(os.listdir("/proc/self/task"))
    except OSError:
        return 0


class Pending:
    """``function(*args)`` under way in a forked copy (or to be run here); :meth:`result`
    waits for it. Use as a context manager: leaving it without the result stops the copy."""

    def __init__(self, function: Callable[..., Any], args: tuple) -> None:
        self.function, self.args = function, args
        self.pid: int | None = None
        self.fd: int | None = None
        self.forked = False  # whether the result came from the copy
        if not can_fork():
            return
        read_end, write_end = os.pipe()
        try:
            pid = os.fork()
        except OSError:  # no memory or process left for a copy: run it here when asked
            os.close(read_end)
            os.close(write_end)
            return
        if pid == 0:  # the copy: run, send, end without this process's exit handlers
            os.close(read_end)
            _run_and_send(function, args, write_end)
        os.close(write_end)
        self.pid, self.fd = pid, read_end

    def result(self) -> Any:
        """The function's result: the copy's, or (no copy, or the copy failed) its own run
        here, raising what it raises."""
        if self.pid is not None:
            with os.fdopen(self.fd, "rb") as pipe:
                self.fd = None
                data = pipe.read()
            _, status = os.waitpid(self.pid, 0)
            self.pid = None
            if status == 0 and data:
                with contextlib.suppress(Exception):  # anything amiss: run it here
                    done, value = pickle.loads(data)
                    if done:
                        self.forked = True
                        return value
        return self.function(*self.args)

    def stop(self) -> None:
        """End the copy, if it is still running, unasked."""
        import signal

        if self.fd is not None:
            os.close(self.fd)
            self.fd = None
        if self.pid is not None:
            with contextlib.suppress(OSError):
                os.kill(self.pid, signal.SIGKILL)
                os.waitpid(self.pid, 0)
            self.pid = None

    def __enter__(self) -> Pending:
        return self

    def __exit__(self, *exc) -> None:
        self.stop()


def start(function: Callable[..., Any], *args) -> Pending:
    """Start ``function(*args)`` in a forked copy of this process (where :func:`can_fork`);
    ``Pending.result()`` waits for what it returns."""
    return Pending(function, args)


def _run_and_send(function, args, fd: int) -> None:
    """In the copy: the pickled (True, result), or (False, None) when it failed; then end."""
    try:
        try:
            data = pickle.dumps((True, function(*args)), protocol=pickle.HIGHEST_PROTOCOL)
        except BaseException:  # noqa: BLE001 - the process that asks runs it again and raises
            data = pickle.dumps((False, None))
        with os.fdopen(fd, "wb") as pipe:
            pipe.write(data)
    finally:
        os._exit(0)
