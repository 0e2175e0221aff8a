"""Capture what C libraries print while loading a file.

urdfdom (inside Pinocchio) prints the reason it refuses a URDF on the C stderr and raises
only "does not contain a valid URDF model"; MuJoCo's qhull prints pages of diagnostics on
a degenerate mesh before MuJoCo raises its own one-line error. Python's sys.stdout/stderr
redirection cannot see either, so the file descriptors themselves are redirected.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager


class CapturedOutput:
    text: str = ""

    def lines(self) -> list[str]:
        return [line.strip() for line in self.text.splitlines() if line.strip()]


@contextmanager
def captured_c_output() -> Iterator[CapturedOutput]:
    """Redirect file descriptors 1 and 2 to a temporary file; ``.text`` holds what was
    printed once the block has ended."""
    out = CapturedOutput()
    for stream in (sys.stdout, sys.stderr):
        stream.flush()
    with tempfile.TemporaryFile(mode="w+b") as sink:
        saved = [os.dup(1), os.dup(2)]
        os.dup2(sink.fileno(), 1)
        os.dup2(sink.fileno(), 2)
        try:
            yield out
        finally:
            _flush_c_stdio()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)
            sink.seek(0)
            out.text = sink.read().decode("utf-8", "replace")


def _flush_c_stdio() -> None:
    # No C runtime reachable this way: then nothing buffered there is ours to lose.
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None).fflush(None)
