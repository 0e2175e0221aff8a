"""The hidden-effect suite's judge: each seeded case (synthetic_scenarios.py) written as the
CSV files (and experiment files) a user would have, calibrated as a user would calibrate it
(fitted run + held-out run), and scored against the hidden truth:

- right causes: the named causes are exactly the hidden ones (aliases as a physicist would
  name them);
- quiet: on effect-free data no cause is named;
- covered: each fitted value that has a true counterpart lies within its reported 95 %
  interval;
- never worse: the calibrated model predicts the held-out run no worse than the nominal one.

Used by tests/test_calibrate_synthetic.py (a share of the cases) and bench/calibrate_suite.py
(all of them, the table in docs/calibration.md).
"""

from __future__ import annotations

import math
import multiprocessing
import os
import tempfile
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

from synthetic_scenarios import NAMES, make, scenario_for

N_CASES = 210  # 10 scenarios x 21 seeds; 42 of them effect-free


def truth_params(case) -> dict[str, float]:
    """The hidden values under calibrate's parameter names (joint.name)."""
    j = case.joint
    out = {}
    for effect, values in case.truth.items():
        for name, value in values.items():
            if effect == "inertia":
                out[f"{j}.inertia_scale"] = value
                if case.kind == "lid":  # mass and inertia scaled alike: nothing extra
                    out[f"{j}.rotational_scale"] = 1.0
            elif effect == "limit":
                out[f"{j}.limit_{name}"] = value
            elif effect == "armature" and "inertia" in case.expected_causes():
                if case.kind != "lid":  # no gravity load: the inertia scale holds it
                    out[f"{j}.inertia_scale"] = 1.0 + value / case.notes["inertia"]
            else:
                out[f"{j}.{name}"] = value
    return out


def right_causes(report: dict, expected: set[str]) -> bool:
    """Whether the named causes are the hidden ones, or a reading the data cannot tell from
    them that the report names as such (issue 16, rule 6): direction-dependent friction
    whose viscous part does not show with the direction is symmetric damping and friction
    plus a constant force, accepted only where the report's ``indistinguishable_from``
    says that constant force is direction-dependent friction."""
    named = set(report["causes"])
    if named == expected:
        return True
    if "asymmetric_friction" not in expected:
        return False
    reading = expected - {"asymmetric_friction"} | {"damping", "friction", "offset"}
    return named == reading and any(
        d["effect"] == "offset" and "asymmetric_friction" in d["indistinguishable_from"]
        for d in report["cause_details"])


def run_case(seed: int) -> dict:
    """Calibrate one case; what the judge needs, as plain data (for a process pool)."""
    from real2code_export.calibrate import calibrate

    case = make(seed)
    with tempfile.TemporaryDirectory() as tmp:
        fit, held = case.write(Path(tmp))
        t0, c0 = time.perf_counter(), time.process_time()
        report = calibrate(case.obj, [fit], [held]).report
        seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    checks = []
    for key, truth in truth_params(case).items():
        p = report["parameters"].get(key)
        if p is None:
            continue
        hw = p["halfwidth95"]
        inside = hw is not None and math.isfinite(hw) and abs(p["value"] - truth) <= hw
        checks.append((key, float(p["value"]), hw, float(truth), bool(inside)))
    before, after = report["holdout_rmse_before"], report["holdout_rmse_after"]
    return {"seed": seed, "scenario": case.scenario, "kind": case.kind,
            "truth": sorted(case.truth), "expected": sorted(case.expected_causes()),
            "named": list(report["causes"]), "clean": not case.truth,
            "right": right_causes(report, case.expected_causes()),
            # right as a reading the data cannot tell from the truth (said so)
            "indistinguishable": set(report["causes"]) != case.expected_causes()
            and right_causes(report, case.expected_causes()),
            "checks": checks,
            "unexplained": bool(report["unexplained"]), "holdout_before": before,
            "holdout_after": after, "worse": after > before * (1 + 1e-9), "seconds": seconds,
            "cpu": cpu, "selected_by": report["selected_by"],
            "holdout_judged_by": "effort" if report.get("holdout_effort") else "position"}


def run_cases(seeds: list[int], workers: int | None = None,
              on_result: Callable[[dict], None] | None = None) -> list[dict]:
    """Every case's result, in the order of ``seeds``; ``on_result`` sees each as it ends
    (a long run's progress)."""
    workers = max(1, min(len(seeds), workers or os.cpu_count() or 1))
    # Fresh interpreters: forking a pytest process whose earlier tests started threads
    # (torch, open3d, tqdm) can deadlock the children on a lock held at the fork.
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
        futures = [pool.submit(run_case, seed) for seed in seeds]
        for future in as_completed(futures):
            if on_result is not None:
                on_result(future.result())
        return [future.result() for future in futures]


def ci_seeds(rounds: int) -> list[int]:
    """The first ``rounds`` rounds of the scenarios (every scenario once a round; round 0,
    3, ... effect-free where the scenario comes so): CI's share of the suite."""
    return list(range(min(rounds * len(NAMES), N_CASES)))


def score(results: list[dict]) -> dict:
    effect = [r for r in results if not r["clean"]]
    clean = [r for r in results if r["clean"]]
    checks = [c for r in effect if r["right"] for c in r["checks"]]

    def rate(n, d):
        return n / d if d else float("nan")

    return {
        "cases": len(results), "effect_cases": len(effect), "clean_cases": len(clean),
        "right": rate(sum(r["right"] for r in effect), len(effect)),
        "quiet": rate(sum(not r["named"] for r in clean), len(clean)),
        "covered": rate(sum(c[4] for c in checks), len(checks)), "values": len(checks),
        "worse": sum(r["worse"] for r in results),
        "wrong": [(r["seed"], r["scenario"], r["expected"], r["named"]) for r in effect
                  if not r["right"]],
        "noisy": [(r["seed"], r["scenario"], r["named"]) for r in clean if r["named"]],
        "outside": [(r["seed"], c[0], c[1], c[2], c[3]) for r in effect if r["right"]
                    for c in r["checks"] if not c[4]],
        "worse_cases": [(r["seed"], r["scenario"], r["holdout_before"], r["holdout_after"])
                        for r in results if r["worse"]],
        "seconds": sum(r["seconds"] for r in results),
        "cpu": sum(r.get("cpu", 0.0) for r in results),
    }


def markdown(results: list[dict]) -> str:
    """The table by scenario, then the totals against the targets."""
    lines = ["| scenario | cases (effect-free) | right causes | no cause on effect-free | "
             "values inside 95 % | held out worse than nominal | mean time [s] |",
             "|---|---|---|---|---|---|---|"]

    def pct(x):
        return "—" if math.isnan(x) else f"{100 * x:.0f} %"

    for name in NAMES:
        rs = [r for r in results if r["scenario"] == name]
        if not rs:
            continue
        s = score(rs)
        lines.append(f"| {name} | {s['cases']} ({s['clean_cases']}) | {pct(s['right'])} | "
                     f"{pct(s['quiet'])} | {pct(s['covered'])} ({s['values']}) | "
                     f"{s['worse']} | {s['seconds'] / s['cases']:.1f} |")
    s = score(results)
    lines.append(f"| **all** | {s['cases']} ({s['clean_cases']}) | **{pct(s['right'])}** "
                 f"(target >= 95 %) | **{pct(s['quiet'])}** (>= 97 %) | "
                 f"**{pct(s['covered'])}** ({s['values']}; >= 90 %) | **{s['worse']}** (0) | "
                 f"{s['seconds'] / max(s['cases'], 1):.1f} |")
    return "\n".join(lines)


__all__ = ["N_CASES", "ci_seeds", "markdown", "right_causes", "run_case", "run_cases",
           "scenario_for", "score", "truth_params"]
