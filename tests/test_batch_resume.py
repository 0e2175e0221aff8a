"""An interrupted batch continues where it stopped: the same command, run again, skips the
objects already done (their files are not touched) and does the rest.

The batch runs as its own process, as a user's would: first stopped with Ctrl-C (SIGINT to
its process group: it finishes the object in flight and exits 130), then killed outright
(SIGKILL to the whole group, as when a machine is taken away), then run to the end.
Changing one input redoes that object only.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from real2code_export.formats import object_json

from helpers import small_cabinet

# An object takes about 30 ms here: enough of them that the signals surely land mid-batch.
N_OBJECTS = 96


def _start(inputs: Path, out: Path) -> subprocess.Popen:
    command = [sys.executable, "-m", "real2code_export.batch", "export", str(inputs),
               "--out", str(out), "--workers", "1", "--to", "json,mjcf,urdf",
               "--configurations", "10", "--quiet", "--json"]
    return subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True,  # its own process group, as in a terminal
                            preexec_fn=_terminal_signals)


def _terminal_signals() -> None:
    """Ctrl-C as a terminal delivers it: a test run started in the background by a
    non-interactive shell ignores SIGINT, and ignored signals stay ignored in children."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _lines(out: Path) -> list[dict]:
    path = out / "manifest.jsonl"
    if not path.is_file():
        return []
    return [json.loads(x) for x in path.read_text().splitlines() if x.endswith("}")]


def _stop_after(proc: subprocess.Popen, out: Path, done: int, sig: signal.Signals) -> None:
    deadline = time.monotonic() + 120
    while len(_lines(out)) < done:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "the batch made no progress"
        time.sleep(0.05)
    os.killpg(proc.pid, sig)


def _stamps(out: Path, ids) -> dict[str, tuple[int, int]]:
    """(inode, mtime) of every output file of these objects."""
    return {p.relative_to(out).as_posix(): (p.stat().st_ino, p.stat().st_mtime_ns)
            for i in ids for p in (out / i).rglob("*") if p.is_file()}


def test_interrupted_batch_resumes_without_redoing(tmp_path):
    inputs = tmp_path / "in"
    for k in range(N_OBJECTS):
        object_json.save(small_cabinet(), inputs / f"cabinet_{k:02d}")
    out = tmp_path / "out"

    # 1. Ctrl-C after three objects: the one in flight is finished and recorded.
    proc = _start(inputs, out)
    _stop_after(proc, out, 3, signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, stderr
    assert "interrupted" in stderr
    summary = json.loads(stdout)
    assert summary["interrupted"] and summary["remaining"] > 0
    first = {r["id"]: r for r in _lines(out)}
    assert 3 <= len(first) < N_OBJECTS
    assert all(r["status"] == "ok" for r in first.values())
    stamps = _stamps(out, first)

    # 2. The same command, killed outright (driver and workers) a few objects later.
    proc = _start(inputs, out)
    _stop_after(proc, out, len(first) + 2, signal.SIGKILL)
    proc.communicate(timeout=120)
    second = {r["id"]: r for r in _lines(out)}
    assert len(second) >= len(first) + 2
    assert _stamps(out, first) == stamps  # not redone
    stamps = _stamps(out, second)

    # 3. The same command to the end.
    proc = _start(inputs, out)
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 0, stderr
    summary = json.loads(stdout)
    assert summary["skipped"] == len(second)
    assert summary["ok"] == N_OBJECTS - len(second)
    final = {r["id"]: r for r in _lines(out)}
    assert sorted(final) == [f"cabinet_{k:02d}" for k in range(N_OBJECTS)]
    assert all(r["status"] == "ok" and r["check"]["ok"] for r in final.values())
    assert _stamps(out, second) == stamps  # not redone
    for i, r in second.items():  # earlier records kept as they were
        assert final[i]["finished_at"] == r["finished_at"] and final[i]["key"] == r["key"]
    assert not (out / ".staging").exists()

    # 4. One input changes: that object alone is redone.
    changed = "cabinet_00"
    model = inputs / changed / "object.json"
    model.write_text(model.read_text().replace('"small_cabinet"', '"small_cabinet_v2"'))
    proc = _start(inputs, out)
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 0, stderr
    summary = json.loads(stdout)
    assert (summary["skipped"], summary["ok"]) == (N_OBJECTS - 1, 1)
    redone = {r["id"]: r for r in _lines(out)}[changed]
    assert redone["key"] != final[changed]["key"]
    assert f"{changed}/small_cabinet_v2.urdf" in redone["outputs"]
    assert not (out / changed / "small_cabinet.urdf").exists()  # no stale file of the old run
