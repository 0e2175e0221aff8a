"""A function run in a forked copy of the process (``export`` reads its input there while it
imports the writers' libraries): the same result, the same errors, nothing left running.

The test process has other threads (OpenBLAS's pool, USD's once a test has used it), where
nothing forks; so forking is tried in a fresh interpreter with the console script's
environment (``OPENBLAS_NUM_THREADS=1``), and compared with what this process does unforked.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from real2code_export import forked
from real2code_export.cli import EXIT_OK, run
from real2code_export.formats import urdf

from helpers import small_cabinet

REPO = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="forks on Linux")

_UNITS = r"""
import json, os, sys, time
import numpy as np
from real2code_export import forked
from real2code_export.errors import FormatError

def pid_and_array(n):
    return os.getpid(), np.arange(n, dtype=np.float64) / 3.0

def fail(path):
    raise FormatError(path, "<robot>", "what is wrong")

def unpicklable():
    return lambda: None

out = {"can_fork": forked.can_fork()}
with forked.start(pid_and_array, 100_000) as p:  # 800 kB: more than a pipe holds
    pid, array = p.result()
out["copy"] = [p.forked, pid != os.getpid(),
               bool(np.array_equal(array, np.arange(100_000, dtype=np.float64) / 3.0))]
try:
    with forked.start(fail, "x.urdf") as p:
        p.result()
except FormatError as e:
    out["error"] = [p.forked, str(e)]
with forked.start(unpicklable) as p:
    out["unpicklable"] = [p.forked, callable(p.result())]
with forked.start(time.sleep, 60) as p:
    child = p.pid
try:
    os.waitpid(child, os.WNOHANG)
    out["stopped"] = False
except ChildProcessError:  # reaped: not left running, nor a zombie
    out["stopped"] = True
def no_fork():
    raise BlockingIOError(11, "Resource temporarily unavailable")
os.fork = no_fork
with forked.start(pid_and_array, 3) as p:
    out["fork_failed"] = [p.forked, p.result()[0] == os.getpid()]
print(json.dumps(out))
"""


def _python(code: str, *args: str) -> str:
    """``code`` run by a fresh interpreter as the console script sets it up; its stdout."""
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "MUJOCO_GL": "disable"}
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True,
                          check=True, cwd=REPO, env=env).stdout


@pytest.fixture(scope="module")
def units() -> dict:
    return json.loads(_python(_UNITS).splitlines()[-1])


def test_the_result_comes_from_the_copy(units):
    assert units["can_fork"] and units["copy"] == [True, True, True]


def test_an_error_in_the_copy_is_raised_here(units):
    forked_, message = units["error"]
    assert not forked_ and "x.urdf" in message and "what is wrong" in message


def test_a_result_that_does_not_pickle_is_made_here(units):
    assert units["unpicklable"] == [False, True]


def test_leaving_without_the_result_ends_the_copy(units):
    assert units["stopped"]


def test_a_fork_that_fails_leaves_the_function_to_run_here(units):
    assert units["fork_failed"] == [False, True]


def test_no_fork_beside_another_thread():
    import threading

    stop = threading.Event()
    thread = threading.Thread(target=stop.wait)
    thread.start()
    try:
        assert forked._threads() > 1 and not forked.can_fork()
        with forked.start(os.getpid) as pending:
            assert pending.result() == os.getpid() and not pending.forked
    finally:
        stop.set()
        thread.join()


_EXPORT = r"""
import sys
from real2code_export import forked
from real2code_export.cli import run
taken = []
result = forked.Pending.result
def spy(self):
    value = result(self)
    taken.append(self.forked)
    return value
forked.Pending.result = spy
status = run(sys.argv[1:])
print(status, taken)
"""


def test_export_reads_in_the_copy_and_writes_the_same_files(tmp_path, monkeypatch):
    """``export`` reads in a forked copy; read here (this process does not fork), the same
    files, byte for byte; without --to, with MJCF and URDF unavailable, as ``--to
    usd,gltf`` (the copy read with hulls, which USD and glTF alone do not want)."""
    from real2code_export import formats

    source = urdf.save(small_cabinet(), tmp_path / "source")  # with OBJ meshes
    done = _python(_EXPORT, "export", str(source), "--to", "usd", "--out", str(tmp_path / "a"))
    assert done.splitlines()[-1] == "0 [True]", done
    assert run(["export", str(source), "--to", "usd", "--out", str(tmp_path / "b")]) == EXIT_OK
    _same_files(tmp_path / "a", tmp_path / "b")

    for name in ("mjcf", "urdf"):
        monkeypatch.setitem(formats._PROBLEMS, (name, True), "made unavailable by the test")
    assert run(["export", str(source), "--out", str(tmp_path / "c")]) == EXIT_OK
    assert run(["export", str(source), "--to", "usd,gltf", "--out", str(tmp_path / "d")]) == 0
    suffixes = {p.suffix for p in _same_files(tmp_path / "c", tmp_path / "d")}
    assert suffixes >= {".usda", ".glb"} and ".urdf" not in suffixes


def _same_files(a: Path, b: Path) -> list[Path]:
    """The files of folders ``a`` and ``b``, the same names and bytes (relative paths)."""
    names = sorted(p.relative_to(a) for p in a.rglob("*"))
    assert names == sorted(p.relative_to(b) for p in b.rglob("*"))
    for rel in names:
        if (a / rel).is_file():
            assert (a / rel).read_bytes() == (b / rel).read_bytes(), rel
    return names
