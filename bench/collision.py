"""Benchmark: the collision geometry's cost and what it fixes, per object.

    .venv/bin/python bench/collision.py [--demo DIR/object.json] [--split dev|holdout|all]
                                        [--coacd]

For each PartNet-Mobility object (../shared/data, read with ``faithful_collision``; its
links' collision OBJs are the source pieces; "making pieces" is then the whole URDF load less
the separation) and, with --demo, a reconstruction's parts (their visual meshes, split into connected
components as the pipeline does): the seconds spent making convex pieces (hulls, hollow pieces
split into boxes: ``collision.collision_pieces``) and separating the parts' pieces
(``collision_separation.separate``, q = 0 and every joint's range), the piece count, and the
part pairs whose pieces overlap at q = 0 before and after separation (MuJoCo's collision
detection, every pair, deeper than 0.1 mm), and after it the joints whose child meets its
parent's pieces along its range (at the values separation sweeps and halfway between). With --coacd, CoACD (the decomposition a
user would otherwise reach for; threshold 0.1, at most 32 pieces, no cache) on the demo's
largest part, beside ours on the same part, as a ratio from one run.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))
from _data import SHARED_DATA  # noqa: E402
from _machine import describe  # noqa: E402

from real2code_export import collision_separation  # noqa: E402
from real2code_export.collision import collision_pieces  # noqa: E402
from real2code_export.dynamics.overlap import overlaps, overlaps_along_ranges  # noqa: E402
from real2code_export.formats import load, write_formats  # noqa: E402
from real2code_export.formats.urdf import read as urdf_read  # noqa: E402
from real2code_export.model import Mesh  # noqa: E402

PARTNET = SHARED_DATA / "partnet_mobility"


def overlap_summary(obj) -> str:
    with tempfile.TemporaryDirectory() as folder:
        found = overlaps(write_formats(obj, folder, ["mjcf"])["mjcf"])
    if not found:
        return "0"
    return f"{len(found)} ({max(o.depth for o in found) * 1000:.1f} mm)"


def range_summary(obj) -> str:
    """Joints whose child meets its parent's pieces along the range (at the values separation
    sweeps and halfway between)."""
    with tempfile.TemporaryDirectory() as folder:
        found = overlaps_along_ranges(write_formats(obj, folder, ["mjcf"])["mjcf"], obj)
    if not found:
        return "0"
    return f"{len(found)} ({max(o.depth for o in found) * 1000:.1f} mm)"


def timed_separation():
    """Wrap the URDF reader's separation: what it was given, what it made, its seconds."""
    seen = {}
    original = collision_separation.separate

    def wrapper(obj, **kwargs):
        start = time.perf_counter()
        out, cuts = original(obj, **kwargs)
        seen.update(before=obj, seconds=time.perf_counter() - start, cuts=cuts)
        return out, cuts

    return seen, wrapper


def partnet_row(path: Path) -> tuple[str, ...]:
    seen, wrapper = timed_separation()
    urdf_read.separate = wrapper
    try:
        start = time.perf_counter()
        obj = load(path, faithful_collision=True)
        total = time.perf_counter() - start
    finally:
        urdf_read.separate = collision_separation.separate
    pieces = sum(len(p.collision) for p in obj.parts)
    separation = seen.get("seconds", 0.0)
    before = overlap_summary(seen["before"]) if "before" in seen else "-"
    return (f"{total - separation:.1f}", f"{separation:.1f}", str(pieces), before,
            overlap_summary(obj), range_summary(obj))


def demo_row(path: Path, coacd: bool) -> tuple[tuple[str, ...], str | None]:

    obj = load(path)
    start = time.perf_counter()
    largest, largest_seconds = None, 0.0
    for part in obj.parts:
        if part.visual is None:
            continue
        t = time.perf_counter()
        tm = part.visual.to_trimesh()
        components = [Mesh.from_trimesh(c) for c in tm.split(only_watertight=False)]
        part.collision = collision_pieces(part.visual, "pieces", source_pieces=components)
        if largest is None or len(part.visual.faces) > len(largest.visual.faces):
            largest, largest_seconds = part, time.perf_counter() - t
    pieces_seconds = time.perf_counter() - start
    before = overlap_summary(obj)
    start = time.perf_counter()
    separated, _ = collision_separation.separate(obj)
    separation = time.perf_counter() - start
    row = (f"{pieces_seconds:.1f}", f"{separation:.1f}",
           str(sum(len(p.collision) for p in separated.parts)), before,
           overlap_summary(separated), range_summary(separated))
    note = None
    if coacd and largest is not None:
        mesh = max(largest.visual.to_trimesh().split(only_watertight=False),
                   key=lambda m: len(m.faces))
        with tempfile.TemporaryDirectory() as cache:
            t = time.perf_counter()
            got = collision_pieces(Mesh.from_trimesh(mesh), "coacd", cache_dir=Path(cache))
            coacd_seconds = time.perf_counter() - t
        note = (f"CoACD on the demo's largest part ({largest.name}, its largest component, "
                f"{len(mesh.faces)} faces): {coacd_seconds:.1f} s, {len(got)} pieces; ours on "
                f"the whole part {largest_seconds:.1f} s (x{coacd_seconds / largest_seconds:.0f})")
    return row, note


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--demo", help="a reconstruction's object.json (real2code demo's output)")
    p.add_argument("--split", default="all", choices=["dev", "holdout", "all"])
    p.add_argument("--coacd", action="store_true", help="time CoACD on the demo's largest part")
    args = p.parse_args()
    print(f"machine: {describe()}")
    rows, notes = [], []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if args.demo:
            row, note = demo_row(Path(args.demo), args.coacd)
            rows.append(("demo reconstruction", *row))
            notes += [note] if note else []
            print(rows[-1], flush=True)
        if (PARTNET / "index.json").is_file():
            for e in json.loads((PARTNET / "index.json").read_text()):
                if args.split in ("all", e["split"]):
                    rows.append((f"PartNet {e['id']} ({e['category']}, {e['split']})",
                                 *partnet_row(PARTNET / e["id"] / "mobility.urdf")))
                    print(rows[-1], flush=True)
    print()
    print("| object | making pieces s | separation s | pieces | overlapping pairs before | "
          "after | joints meeting their parent along the range, after |")
    print("|---|---|---|---|---|---|---|")
    for row in rows:
        print("| " + " | ".join(row) + " |")
    print()
    print(f"total: making pieces {sum(float(r[1]) for r in rows):.1f} s, separation "
          f"{sum(float(r[2]) for r in rows):.1f} s; objects with overlapping pieces after: "
          f"{sum(r[5] != '0' for r in rows)} of {len(rows)}; with a joint meeting its parent "
          f"along the range: {sum(r[6] != '0' for r in rows)}")
    for note in notes:
        print(note)


if __name__ == "__main__":
    main()
