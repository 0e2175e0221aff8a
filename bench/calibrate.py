"""Benchmark: a full calibration of a 5 s, 1 kHz trajectory (a door with dry friction and
viscous damping hidden in it), timed; optionally every single effect and pair fitted by
simulation too (``--exhaustive``); and the EMPS benchmark's estimation file (24.8 s at
1 kHz in a declared closed loop, the pulses file held out) converted by
bench/convert_emps.py and calibrated (``--emps``, when ../shared/data is there).

    python bench/calibrate.py [--exhaustive] [--emps] [--seed 0]
"""

from __future__ import annotations

import argparse
import itertools
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the independent trajectory generator
sys.path.insert(0, str(ROOT / "bench"))

from _machine import describe  # noqa: E402

from real2code_export.calibrate import calibrate  # noqa: E402
from real2code_export.calibrate.effects import valid  # noqa: E402
from real2code_export.calibrate.fit import fit_candidate  # noqa: E402
from real2code_export.calibrate.problem import build_problem  # noqa: E402
from real2code_export.calibrate.trajectory import read_csv  # noqa: E402
from real2code_export.formats import load  # noqa: E402

from synthetic_joint_data import make_case  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--exhaustive", action="store_true",
                        help="also fit every single effect and every pair by simulation")
    parser.add_argument("--emps", action="store_true",
                        help="also calibrate the EMPS benchmark (estimation file fitted, "
                        "pulses file held out)")
    args = parser.parse_args()
    print(f"machine      {describe()}, load average {os.getloadavg()[0]:.1f}")
    case = make_case(args.seed, kind="door", effects=["damping", "friction"], rate=1000.0,
                     duration=5.0)
    with tempfile.TemporaryDirectory() as tmp:
        csv = Path(tmp) / "door.csv"
        csv.write_text(case.csv())
        t0, c0 = time.perf_counter(), time.process_time()
        result = calibrate(case.obj, [csv], [], Path(tmp) / "out")
        elapsed, cpu = time.perf_counter() - t0, time.process_time() - c0
        sel = result.selection
        rollouts = sum(f.rollouts for f in sel.fitted)
        print(f"trajectory   {case.time[-1] - case.time[0] + 1e-3:.1f} s at "
              f"{1 / (case.time[1] - case.time[0]):.0f} Hz ({len(case.time)} samples), "
              f"hidden: {sorted(case.truth)}")
        print(f"causes       {result.causes}")
        print(f"candidates   {len(result.report['candidates'])} scored, {len(sel.fitted)} "
              f"fitted by simulation ({rollouts} MuJoCo replays)")
        print(f"calibrate    {elapsed:.2f} s wall, {cpu:.2f} s CPU (report, plots and every "
              "export included; CPU: all the process's threads)")
        if args.exhaustive:
            problem = build_problem(case.obj, [read_csv(csv, case.obj)])
            lib = problem.effects[case.joint]
            structures = [(v,) for v in lib] + [
                pair for pair in itertools.combinations(sorted(lib), 2) if valid(set(pair))]
            t0 = time.perf_counter()
            for structure in structures:
                fit_candidate(problem, tuple(lib[v] for v in structure), refine=False)
            print(f"exhaustive   {len(structures)} structures (all singles and valid pairs) "
                  f"fitted by simulation in {time.perf_counter() - t0:.2f} s")
        if args.emps:
            emps(Path(tmp) / "emps")
    return 0


def emps(folder: Path) -> None:
    import convert_emps
    from _convert import MEASURED

    source = MEASURED / "emps"
    if not source.is_dir():
        print(f"emps         skipped: no data at {source}")
        return
    convert_emps.convert(source, folder)
    model = load(folder / "object.json")
    t0, c0 = time.perf_counter(), time.process_time()
    result = calibrate(model, [folder / "DATA_EMPS.csv"], [folder / "DATA_EMPS_PULSES.csv"],
                       folder / "out")
    elapsed, cpu = time.perf_counter() - t0, time.process_time() - c0
    print(f"emps         {elapsed:.1f} s wall, {cpu:.1f} s CPU (24.8 s at 1 kHz fitted in "
          f"closed loop, 24.8 s held out; report and exports included), causes "
          f"{result.causes}, selected by {result.report['selected_by']}")


if __name__ == "__main__":
    raise SystemExit(main())
