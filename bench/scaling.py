"""Benchmark: how load, export and check grow with the number of parts. A generated MJCF of
N point bodies on three slides each (as a flex's vertex bodies: every body of several joints
becomes a chain of parts) beside a 40-body chain of hinges, at each N; CPU seconds of each
stage in this process (``time.process_time``; the check's validators off, its MuJoCo and
UsdPhysics probes, the source as reference and the dynamics comparison on).

    .venv/bin/python bench/scaling.py [--bodies 125,250,500,1000]

Work that grows linearly doubles from one N to the next; a stage whose time quadruples grows
with the square of the parts (issue 18: a 3881-part flex took 910 s). The last column is
MuJoCo alone loading the MJCF export (``MjSpec.from_file`` and compile): the MJCF export and
the check build MuJoCo specs of the same size (the source's, the exports'), so that much of
their growth is MuJoCo's.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import mujoco  # noqa: E402
from _machine import describe  # noqa: E402

from real2code_export.check import check_files  # noqa: E402
from real2code_export.formats import FORMATS, export, load  # noqa: E402

CHAIN = 40


def source(n: int) -> str:
    """An MJCF of ``n`` point bodies on x, y and z slides and a chain of hinged capsules."""
    side = max(1, round(n ** 0.5))
    points = "".join(
        f'<body name="v{k}" pos="{0.05 * (k % side):.3f} {0.05 * (k // side):.3f} 0.5">'
        '<joint type="slide" axis="1 0 0"/><joint type="slide" axis="0 1 0"/>'
        '<joint type="slide" axis="0 0 1"/>'
        '<geom type="sphere" size="0.01" mass="0.01"/></body>' for k in range(n))
    chain = "".join(f'<body name="c{k}" pos="0 0 0.1"><joint name="h{k}" axis="0 1 0" '
                    'range="-1 1"/><geom type="capsule" fromto="0 0 0 0 0 0.1" size="0.01"/>'
                    for k in range(CHAIN)) + "</body>" * CHAIN
    return (f'<mujoco model="scaling{n}"><worldbody><body name="base" pos="-1 0 0">'
            f'<geom type="box" size="0.1 0.1 0.1"/>{chain}</body>{points}'
            "</worldbody></mujoco>")


def stages(n: int, tmp: Path) -> dict[str, float]:
    src = tmp / f"scaling{n}{FORMATS['mjcf'].output_suffix}"
    src.write_text(source(n))
    seconds = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = time.process_time()
        obj = load(src)
        seconds["load"] = time.process_time() - start
        written = []
        for fmt in ("mjcf", "urdf", "usd", "gltf"):
            start = time.process_time()
            written += export(obj, tmp / f"{n}-{fmt}", formats=[fmt]).values()
            seconds[f"export {fmt}"] = time.process_time() - start
        start = time.process_time()
        report = check_files(written, source=src, validate=False)
        seconds["check"] = time.process_time() - start
        # MuJoCo's own load of the MJCF export: what any MJCF work here pays MuJoCo, whose
        # spec grows with the square of the bodies (each added element re-hashes the whole
        # model: google-deepmind/mujoco#3397)
        start = time.process_time()
        mujoco.MjSpec.from_file(str(written[0])).compile()
        seconds["MuJoCo load"] = time.process_time() - start
    if not report.ok:
        raise SystemExit(f"N={n}: the check disagrees: {report.mismatches[:2]}")
    seconds["parts"] = len(obj.parts)
    return seconds


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--bodies", default="125,250,500,1000")
    args = p.parse_args()
    print(f"machine: {describe()}")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in map(int, args.bodies.split(",")):
            rows.append((n, stages(n, Path(tmp))))
            n, s = rows[-1]
            print(f"N={n:5d} parts={int(s['parts']):5d}  " + "  ".join(
                f"{k} {v:7.2f}" for k, v in s.items() if k != "parts"), flush=True)
    print("CPU seconds per stage; ratio to the previous N:")
    for (_, a), (n, b) in zip(rows, rows[1:], strict=False):
        print(f"N={n:5d}  " + "  ".join(f"{k} x{b[k] / max(a[k], 1e-9):4.1f}"
                                         for k in b if k != "parts"))


if __name__ == "__main__":
    main()
