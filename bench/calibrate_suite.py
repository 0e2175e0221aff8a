"""The hidden-effect suite, all of it: 210 seeded cases in ten scenarios of the data users
have (tests/synthetic_scenarios.py), each calibrated from its CSV (and experiment file) with
a held-out run, scored against the hidden truth; prints the table of docs/calibration.md.

    python bench/calibrate_suite.py [--rounds 21 | --cases 60:120,7] [--workers N]
                                    [--json results.json]
    python bench/calibrate_suite.py --table results.json   # the table of a saved run

(--json is rewritten after every case: a run stopped part-way keeps the cases it did, and
--table prints their table.)

(CI runs the first rounds only: tests/test_calibrate_synthetic.py.)
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the independent generator and its judge
sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT))

from _machine import describe  # noqa: E402
from synthetic_suite import N_CASES, ci_seeds, markdown, run_cases, score  # noqa: E402


def _cases(text: str) -> list[int]:
    seeds: list[int] = []
    for part in text.split(","):
        a, _, b = part.partition(":")
        seeds += list(range(int(a), int(b))) if b else [int(a)]
    if not all(0 <= s < N_CASES for s in seeds):
        raise argparse.ArgumentTypeError(f"seeds run from 0 to {N_CASES - 1}")
    return seeds


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=None,
                        help="only the first rounds (10 cases each; default: all)")
    parser.add_argument("--cases", type=_cases, default=None,
                        help="only these seeds: ranges and single seeds, e.g. 60:120,7")
    parser.add_argument("--workers", type=int, default=os.cpu_count())
    parser.add_argument("--json", type=Path, help="also write every case's result here")
    parser.add_argument("--table", type=Path,
                        help="print the table of a saved --json file (of a run stopped "
                             "part-way too) and run nothing")
    args = parser.parse_args()
    if args.table:
        results = sorted(json.loads(args.table.read_text()), key=lambda r: r["seed"])
        _summary(results)
        return 0
    seeds = args.cases or (ci_seeds(args.rounds) if args.rounds else list(range(N_CASES)))
    print(f"machine      {describe()}, load average {os.getloadavg()[0]:.1f}")
    t0 = time.perf_counter()
    done = []

    def progress(r: dict) -> None:  # one line a case: a run of hours shows how far it got
        done.append(r)
        inside = sum(c[4] for c in r["checks"])
        print(f"[{len(done)}/{len(seeds)}] seed {r['seed']} {r['scenario']}: named "
              f"{r['named']} (expected {r['expected']}, {'right' if r['right'] else 'WRONG'}), "
              f"{inside} of {len(r['checks'])} values inside, "
              f"held out {r['holdout_before']:.4g} -> {r['holdout_after']:.4g}"
              f"{' WORSE' if r['worse'] else ''}, {r['cpu']:.0f} s CPU",
              file=sys.stderr, flush=True)
        if args.json:
            args.json.write_text(json.dumps(done, indent=1, default=str))

    results = run_cases(seeds, args.workers, progress)
    wall = time.perf_counter() - t0
    s = _summary(results)
    print(f"{len(results)} cases in {wall:.0f} s wall ({s['seconds']:.0f} s of calibration, "
          f"{s['cpu']:.0f} s of its CPU, {args.workers} workers, load average "
          f"{os.getloadavg()[0]:.1f} at the end)")
    if args.json:
        args.json.write_text(json.dumps(results, indent=1, default=str))
    return 0


def _summary(results: list[dict]) -> dict:
    """Print the table and what failed; the score."""
    s = score(results)
    print(markdown(results))
    print()
    for label, key in (("wrong causes", "wrong"), ("named on effect-free data", "noisy"),
                       ("values outside their intervals", "outside"),
                       ("held out worse than nominal", "worse_cases")):
        if s[key]:
            print(f"{label}: {s[key]}")
    return s


if __name__ == "__main__":
    raise SystemExit(main())
