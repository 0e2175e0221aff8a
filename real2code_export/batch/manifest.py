"""``DIR/manifest.jsonl``: one JSON line per object, the record of a batch.

Lines are appended (and flushed to disk) as objects finish, so an interrupted batch keeps
what it did; at the end the file is rewritten atomically with one line per object, in id
order. When an id has several lines (a rerun appended a newer one), the last one counts.

A line holds: ``id``, ``task``, ``input`` (the model file or folder), ``status`` (``ok``,
``repaired`` -- done, with the repairs listed in ``warnings`` -- or ``failed``), ``error``
(why it failed, else null), ``outputs`` (files relative to DIR), ``check`` (the check's
summary, null without one), ``result`` (task figures, e.g. calibration causes),
``inputs_hash`` and ``key`` (content hash of the inputs; hash of task, options, package
version and inputs), ``timings`` (seconds: ``total_s`` and the task's stages), ``attempts``,
``engine``, ``worker`` (host and pid), ``version``, ``finished_at`` (UTC).
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable
from pathlib import Path

from .. import atomic

FILENAME = "manifest.jsonl"
STATUSES = ("ok", "repaired", "failed")
DONE = ("ok", "repaired")


def read(path: Path) -> dict[str, dict]:
    """id -> its last record. Lines that do not parse (a line cut short when the machine
    stopped mid-write) are skipped: their objects are simply redone."""
    records: dict[str, dict] = {}
    if not path.is_file():
        return records
    for line in path.read_text(encoding="utf-8").splitlines():
        try:
            record = json.loads(line)
        except json.JSONDecodeError:
            continue
        if isinstance(record, dict) and isinstance(record.get("id"), str):
            records[record["id"]] = record
    return records


def append(path: Path, record: dict) -> None:
    """Add one line and make it durable before the next object is counted done."""
    with path.open("a", encoding="utf-8") as f:
        f.write(_line(record))
        f.flush()
        os.fsync(f.fileno())


def rewrite(path: Path, records: Iterable[dict]) -> None:
    """The compact manifest: one line per object (atomic, so a crash keeps the old file)."""
    atomic.write_text(path, "".join(_line(r) for r in sorted(records, key=lambda r: r["id"])))


def is_done(record: dict | None, key: str, out_dir: Path) -> bool:
    """Whether an earlier result stands: done with the same key, and every output present."""
    return (record is not None and record.get("status") in DONE and record.get("key") == key
            and bool(record.get("outputs"))
            and all((out_dir / rel).is_file() for rel in record["outputs"]))


def _line(record: dict) -> str:
    return json.dumps(record) + "\n"
