"""Worker processes that die mid-batch, on both engines: the batch finishes, the object that
crashed once is retried and done, the one that is killed every time is recorded as failed
after its retries, and every other object is done.

The crashes come from a task kind that exists only here (``crashy``), triggered by what its
input file says: ``exit-once MARKER`` leaves the process with ``os._exit`` the first time,
``kill-always`` sends the worker SIGKILL (as the out-of-memory killer would) every time.
"""

from __future__ import annotations

import json
import os
import signal
import sys
from pathlib import Path

import pytest

from real2code_export.batch import TaskResult, TaskSpec, run_batch


def crashy_task(obj, out: Path, options) -> TaskResult:
    words = obj.files[0].read_text().split()
    if words and words[0] == "exit-once":
        marker = Path(words[1])
        if not marker.exists():
            marker.write_text(str(os.getpid()))
            os._exit(3)
    elif words and words[0] == "kill-always":
        os.kill(os.getpid(), signal.SIGKILL)
    (out / "done.txt").write_text(obj.id)
    return TaskResult(["done.txt"], result={"pid": os.getpid()})


CRASHY = TaskSpec("crashy", crashy_task)


def _inputs(root: Path) -> Path:
    folder = root / "in"
    folder.mkdir()
    for name in ("a", "b", "c", "d"):
        (folder / f"{name}.urdf").write_text("fine")
    (folder / "once.urdf").write_text(f"exit-once {root / 'crashed-once'}")
    (folder / "doomed.urdf").write_text("kill-always")
    return folder


@pytest.mark.parametrize("engine", ["local", "ray"])
def test_batch_survives_dying_workers(tmp_path, engine):
    if engine == "ray":
        pytest.importorskip("ray")
        import ray.cloudpickle

        # Ray's workers cannot import this test module: send the task function by value.
        ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])
    out = tmp_path / "out"
    summary = run_batch(CRASHY, [_inputs(tmp_path)], out, inputs_kind="export",
                        engine=engine, workers=2, retries=2, progress=False)
    assert (tmp_path / "crashed-once").is_file()  # it did crash once

    records = {json.loads(x)["id"]: json.loads(x)
               for x in (out / "manifest.jsonl").read_text().splitlines()}
    assert sorted(records) == ["a", "b", "c", "d", "doomed", "once"]
    assert summary.counts == {"ok": 5, "repaired": 0, "failed": 1}
    doomed = records["doomed"]
    assert doomed["status"] == "failed" and doomed["attempts"] == 3
    assert "worker process died" in doomed["error"]
    assert not (out / "doomed").exists()
    for name in ("a", "b", "c", "d", "once"):
        assert records[name]["status"] == "ok", records[name]
        assert (out / name / "done.txt").read_text() == name
    if engine == "local":  # Ray retries on its own and does not report the count
        assert records["once"]["attempts"] == 2
        assert all(records[n]["attempts"] <= 2 for n in "abcd")
    assert not (out / ".staging").exists()
