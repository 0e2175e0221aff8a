"""A function run in a forked copy of the process (``export`` reads its input there while it
imports the writers' libraries): the same result, the same errors, nothing left running."""

from __future__ import annotations

import os

import numpy as np
import pytest

from real2code_export import forked
from real2code_export.cli import EXIT_OK, run
from real2code_export.errors import FormatError
from real2code_export.formats import urdf

from helpers import small_cabinet


@pytest.fixture(autouse=True)
def _forking_here():
    """Asked as each test runs: a thread an earlier test left alive turns forking off."""
    if not forked.can_fork():
        pytest.skip("no fork here (not Linux, or another thread alive in the test process)")


def _pid_and_array(n: int):
    return os.getpid(), np.arange(n, dtype=np.float64) / 3.0


def test_the_result_comes_from_the_copy():
    with forked.start(_pid_and_array, 100_000) as pending:  # 800 kB: more than a pipe holds
        pid, array = pending.result()
    assert pending.forked and pid != os.getpid()
    assert np.array_equal(array, np.arange(100_000, dtype=np.float64) / 3.0)


def _fail(path):
    raise FormatError(path, "<robot>", "what is wrong")


def test_an_error_in_the_copy_is_raised_here():
    with forked.start(_fail, "x.urdf") as pending, pytest.raises(FormatError, match="x.urdf"):
        pending.result()
    assert not pending.forked


def _unpicklable():
    return lambda: None


def test_a_result_that_does_not_pickle_is_made_here():
    with forked.start(_unpicklable) as pending:
        assert callable(pending.result())
    assert not pending.forked


def _sleep():
    import time

    time.sleep(60)


def test_leaving_without_the_result_ends_the_copy():
    with forked.start(_sleep) as pending:
        pid = pending.pid
    with pytest.raises(ChildProcessError):
        os.waitpid(pid, os.WNOHANG)  # reaped: not left running, nor a zombie


def test_export_reads_in_the_copy_and_writes_the_same_files(tmp_path, monkeypatch):
    """``export --to`` reads in a forked copy; with forking off it reads here: the same
    files, byte for byte."""
    source = urdf.save(small_cabinet(), tmp_path / "source")  # with OBJ meshes
    taken = []
    result = forked.Pending.result

    def spy(self):
        value = result(self)
        taken.append(self.forked)
        return value

    monkeypatch.setattr(forked.Pending, "result", spy)
    assert run(["export", str(source), "--to", "usd", "--out",
                str(tmp_path / "a")]) == EXIT_OK
    assert taken == [True]
    monkeypatch.setattr(forked, "can_fork", lambda: False)
    assert run(["export", str(source), "--to", "usd", "--out",
                str(tmp_path / "b")]) == EXIT_OK
    assert taken == [True, False]
    _same_files(tmp_path / "a", tmp_path / "b")


def test_a_fork_that_fails_leaves_the_function_to_run_here(monkeypatch):
    def no_fork():
        raise BlockingIOError(11, "Resource temporarily unavailable")

    monkeypatch.setattr(os, "fork", no_fork)
    with forked.start(_pid_and_array, 3) as pending:
        pid, _ = pending.result()
    assert pid == os.getpid() and not pending.forked


def test_the_default_export_reads_as_the_formats_that_work_here_want(tmp_path, monkeypatch):
    """Without --to the copy reads for every exported format (hulls, for MJCF and URDF);
    where only USD and glTF can be written here, the export is the same as ``--to usd,gltf``
    (read again here, without hulls)."""
    from real2code_export import formats

    source = urdf.save(small_cabinet(), tmp_path / "source")
    for name in ("mjcf", "urdf"):
        monkeypatch.setitem(formats._PROBLEMS, (name, True), "made unavailable by the test")
    assert run(["export", str(source), "--out", str(tmp_path / "a")]) == EXIT_OK
    assert run(["export", str(source), "--to", "usd,gltf", "--out", str(tmp_path / "b")]) == 0
    suffixes = {p.suffix for p in _same_files(tmp_path / "a", tmp_path / "b")}
    assert suffixes >= {".usda", ".glb"} and ".urdf" not in suffixes


def _same_files(a, b) -> list:
    """The files of folders ``a`` and ``b``, the same names and bytes (relative paths)."""
    names = sorted(p.relative_to(a) for p in a.rglob("*"))
    assert names == sorted(p.relative_to(b) for p in b.rglob("*"))
    for rel in names:
        if (a / rel).is_file():
            assert (a / rel).read_bytes() == (b / rel).read_bytes(), rel
    return names
