"""Progress on the terminal while a batch runs (tqdm: objects done, rate, time left, with
the ok / repaired / failed counts), and the summary at the end (a table, or JSON)."""

from __future__ import annotations

import statistics
import sys
from dataclasses import dataclass, field
from typing import Any, TextIO


class Progress:
    """A progress bar on stderr; silent when ``enabled`` is False."""

    def __init__(self, total: int, done_before: int, label: str, enabled: bool = True,
                 stream: TextIO | None = None):
        from tqdm import tqdm

        stream = stream or sys.stderr
        self.counts = {"ok": 0, "repaired": 0, "failed": 0}
        # Rate and time left count only this run's objects (tqdm leaves ``initial`` out).
        self._bar = tqdm(total=total, initial=done_before, desc=label, unit="obj",
                         file=stream, disable=not enabled, dynamic_ncols=True,
                         mininterval=0.5 if stream.isatty() else 10.0, smoothing=0.1)

    def update(self, record: dict) -> None:
        self.counts[record["status"]] += 1
        self._bar.set_postfix(self.counts, refresh=False)
        self._bar.update(1)

    def close(self) -> None:
        self._bar.close()


@dataclass
class Summary:
    task: str
    engine: str
    workers: int
    out_dir: str
    objects: int
    skipped: int  # done by an earlier run, inputs unchanged
    counts: dict[str, int]  # this run: ok / repaired / failed
    wall_s: float  # this run's objects, start-up excluded
    startup_s: float  # starting the engine (the pool, or Ray) and warming its workers
    object_seconds: list[float] = field(default_factory=list)  # each object's total_s
    cpu_seconds: list[float] = field(default_factory=list)  # each object's cpu_s
    failed: list[dict] = field(default_factory=list)  # {"id", "error"} of failed objects
    check: dict[str, int] = field(default_factory=dict)  # agree / disagree
    interrupted: bool = False

    @property
    def done(self) -> int:
        return sum(self.counts.values())

    @property
    def rate(self) -> float | None:
        return self.done / self.wall_s if self.done and self.wall_s > 0 else None

    def to_json(self) -> dict[str, Any]:
        times = self.object_seconds
        return {
            "task": self.task, "engine": self.engine, "workers": self.workers,
            "out": self.out_dir, "manifest": f"{self.out_dir}/manifest.jsonl",
            "objects": self.objects, "skipped": self.skipped, **self.counts,
            "interrupted": self.interrupted, "remaining": self.objects - self.skipped - self.done,
            "wall_s": round(self.wall_s, 3), "startup_s": round(self.startup_s, 3),
            "objects_per_s": None if self.rate is None else round(self.rate, 4),
            "object_s_median": round(statistics.median(times), 4) if times else None,
            "object_s_max": round(max(times), 4) if times else None,
            "check": self.check, "failed_objects": self.failed,
        }


def format_summary(s: Summary, max_failed: int = 20) -> str:
    """The table printed at the end of a batch."""
    head = (f"batch {s.task}: {s.objects} object(s), engine {s.engine} with {s.workers} "
            f"worker(s), outputs in {s.out_dir}")
    rows = [("ok", s.counts["ok"]), ("repaired", s.counts["repaired"]),
            ("failed", s.counts["failed"]), ("skipped (done before)", s.skipped)]
    if s.interrupted:
        rows.append(("not done (interrupted)", s.objects - s.skipped - s.done))
    lines = [head, f"{'status':24s} {'objects':>8s}"]
    lines += [f"{name:24s} {n:8d}" for name, n in rows]
    if s.check:
        lines.append(f"check: {s.check.get('agree', 0)} agree, {s.check.get('disagree', 0)} "
                     "disagree")
    timing = f"time: {s.wall_s:.1f} s for {s.done} object(s)"
    if s.rate is not None:
        timing += f", {s.rate:.2f} objects/s"
    if s.object_seconds:
        timing += (f", per object median {statistics.median(s.object_seconds):.2f} s, "
                   f"max {max(s.object_seconds):.2f} s")
    lines.append(timing + f"; engine start-up {s.startup_s:.1f} s")
    if s.failed:
        lines.append("failed:")
        lines += [f"  {f['id']}: {f['error']}" for f in s.failed[:max_failed]]
        if len(s.failed) > max_failed:
            lines.append(f"  ... and {len(s.failed) - max_failed} more (see the manifest)")
    lines.append(f"manifest: {s.out_dir}/manifest.jsonl")
    return "\n".join(lines)
