"""The real data sets through the general command, as a user runs them: each converter, then
``real2code calibrate``; prints the commands and the tables of docs/calibration.md (figures
from the reports the command wrote, set beside the published ones).

    python bench/calibrate_measured.py [--data ../shared/data/measured] [--work DIR]
        [--only emps,free_swing,dfki]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT))

import convert_dfki_pendulum as dfki  # noqa: E402
import convert_emps as emps  # noqa: E402
import convert_free_swing as swing  # noqa: E402
from _convert import MEASURED  # noqa: E402
from _machine import describe  # noqa: E402

from real2code_export.formats import load  # noqa: E402


def run(cmd: list[str], shown: str) -> tuple[float, float]:
    """Run a command (shown as a user types it); its wall and CPU time (on a shared
    machine the wall time measures the load as much as the command)."""
    t0 = time.perf_counter()
    cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run(cmd, capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})
    seconds = time.perf_counter() - t0
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise SystemExit(f"{shown}\nfailed ({done.returncode}):\n{done.stderr}")
    return seconds, cpu1.ru_utime + cpu1.ru_stime - cpu0.ru_utime - cpu0.ru_stime


def convert(script: str, data: Path, out: Path) -> str:
    shown = f"python bench/{script} --data {data} --out {out}"
    if REUSE and (out / "object.json").is_file():
        return shown
    run([sys.executable, str(ROOT / "bench" / script), "--data", str(data), "--out", str(out)],
        shown)
    return shown


REUSE = False  # --reuse: render from the reports already in the work folder


def calibrate(folder: Path, data: list[str], holdout: list[str], out: str
              ) -> tuple[str, dict, float]:
    args = ["calibrate", str(folder / "object.json")]
    for d in data:
        args += ["--data", str(folder / d)]
    for h in holdout:
        args += ["--holdout", str(folder / h)]
    args += ["--out", str(folder / out)]
    shown = "real2code " + " ".join(args)
    timing = folder / out / "seconds.txt"
    if REUSE and timing.is_file():
        wall, *cpu = (float(x) for x in timing.read_text().split())
        seconds = (wall, cpu[0] if cpu else math.nan)
    else:
        seconds = run([sys.executable, "-m", "real2code_export.cli", *args], shown)
        timing.write_text(f"{seconds[0]:.3f} {seconds[1]:.3f}\n")
    return shown, json.loads((folder / out / "report.json").read_text()), seconds


def _pct(x: float) -> str:
    return f"{100 * x:+.2f} %"


def _value(v) -> str:
    v = v.get("value") if isinstance(v, dict) else v
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    return f"{v:.6g}" if isinstance(v, (int, float)) else str(v)


def parameters_table(report: dict) -> list[str]:
    """The chosen model's parameters (simulation fit), the inverse-dynamics estimate beside
    them where an effort is measured, and the base inertial parameters."""
    eq = (report.get("equation_error") or {}).get("parameters") or {}
    lines = ["| parameter | simulation fit | 95 % interval | inverse dynamics | unit |",
             "|---|---|---|---|---|"]
    for key, p in report["parameters"].items():
        ci = p.get("ci95")
        ci = f"[{ci[0]:.4g}, {ci[1]:.4g}]" if ci and None not in ci else "not identifiable"
        inverse = _value(eq[key]) if key in eq else "—"
        lines.append(f"| {key} | {p['value']:.6g} | {ci} | {inverse} | {p['unit']} |")
    for joint, base in (report.get("base_parameters") or {}).items():
        for which in ("nominal", "calibrated"):
            terms = ", ".join(f"{k} = {_value(v)}" for k, v in (base.get(which) or {}).items()
                              if v is not None and k != "unit")
            lines.append(f"| {joint} base parameters, {which} | {terms} | | | |")
    return lines


def summary(report: dict, seconds: tuple[float, float]) -> list[str]:
    out = [f"- causes named: **{', '.join(report['causes']) or 'none'}**"
           f"{' — unexplained residual: ' if report['unexplained'] else ''}"
           f"{format(report['residual_to_noise'], '.0f') + ' x sensor noise' if report['unexplained'] else ''}",
           f"- position RMSE, fitted: {report['rmse_before']:.4g} -> {report['rmse_after']:.4g} "
           f"{report['rmse_unit']}"]
    if report.get("holdout_rmse_before") is not None:
        before, after = report["holdout_rmse_before"], report["holdout_rmse_after"]
        out.append(f"- held out: {before:.4g} -> {after:.4g} {report['rmse_unit']} "
                   f"({100 * (1 - after / before):.1f} % lower)")
    for e in report.get("excluded") or []:
        out.append(f"- left out by the command: {Path(e['file']).name} "
                   f"{e['start']:.3f}-{e['end']:.3f} s ({e['reason']})")
    out.append(f"- time: {seconds[0]:.0f} s wall, {seconds[1]:.0f} s CPU")
    return out


def joint_terms(obj_path: Path, joint: str) -> dict[str, float]:
    """Mass, inertia about the axis (with armature) and first moment normal to it of what
    the joint moves (its child and the parts fixed to it), and the joint's dynamics, read
    from an object file."""
    obj = load(obj_path)
    j = obj.joint(joint)
    axis = np.asarray(j.axis, float)
    mass, moment, about_axis = 0.0, np.zeros(3), 0.0
    frames = {j.child: np.eye(4)}  # part -> its pose in the child's frame
    while True:
        more = {f.child: frames[f.parent] @ f.origin for f in obj.joints
                if not f.type.movable and f.parent in frames and f.child not in frames}
        if not more:
            break
        frames.update(more)
    for name, pose in frames.items():
        inertial = obj.part(name).inertial
        if inertial is None:
            continue
        r = pose[:3, :3]
        c = r @ inertial.com + pose[:3, 3]
        parallel = inertial.mass * (float(c @ c) * np.eye(3) - np.outer(c, c))
        about_axis += float(axis @ (r @ inertial.inertia @ r.T + parallel) @ axis)
        mass += inertial.mass
        moment += inertial.mass * (c - axis * float(axis @ c))
    d = j.dynamics
    return {"mass": mass, "J": about_axis + d.armature, "m_cx": float(np.linalg.norm(moment)),
            "damping": d.damping, "friction": d.friction, "armature": d.armature}


# -- the data sets ----------------------------------------------------------------------------
def section_emps(data: Path, work: Path) -> list[str]:
    folder = work / "emps"
    cmds = [convert("convert_emps.py", data / "emps", folder)]
    shown, report, seconds = calibrate(folder, ["DATA_EMPS.csv"], ["DATA_EMPS_PULSES.csv"],
                                       "calibrated")
    cmds.append(shown)
    fitted = joint_terms(folder / "calibrated" / "object.json", emps.JOINT)
    params = {p["name"]: p["value"] for p in report["parameters"].values()}
    mass = fitted["mass"] + fitted["armature"]
    pub = emps.PUBLISHED
    lines = ["## EMPS: a prismatic axis in closed loop, real friction", "",
             "Janot, Gautier, Brunot (2019). The converter writes the position, the force "
             "on the load and the reference (and the validation file's pulses) as CSV, the "
             "position loop as each CSV's experiment file, and a nominal carriage of a "
             f"guessed {emps.NOMINAL_MASS:g} kg on a frictionless slide.", "", "```",
             *cmds, "```", "", *summary(report, seconds), "", *parameters_table(report), ""]
    rows = [("M [kg]", mass, pub["M"])]
    damping = params.get("damping", fitted["damping"] or None)
    friction = params.get("friction", fitted["friction"] or None)
    if damping:
        rows.append(("Fv [N s/m]", damping, pub["Fv"]))
    if friction:
        rows.append(("Fc [N]", friction, pub["Fc"]))
    lines += ["| published term | published (IDIM-LS) | calibrated | difference |",
              "|---|---|---|---|"]
    lines += [f"| {name} | {ref:.4f} | {ours:.4f} | {_pct((ours - ref) / ref)} |"
              for name, ours, ref in rows]
    lines += symmetric_table(report, fitted["armature"], pub)
    # the benchmark's cross-validation figure, with the calibrated model's terms
    if "damping_pos" in params:
        damping = (params["damping_pos"], params["damping_neg"])
        friction = (params["friction_pos"], params["friction_neg"])
    if damping and friction:
        val = emps.read_mat(data / "emps" / "DATA_EMPS_PULSES.mat")
        err = emps.relative_force_error(val, mass, damping, friction,
                                        -params.get("offset", 0.0))
        lines += ["", "Inverse-model force error on the pulses file (the benchmark's "
                  "cross-validation figure) with the calibrated model's mass, friction and "
                  f"constant force: {err:.2f} % (published, symmetric model: "
                  f"{emps.PUBLISHED_FORCE_ERROR['cross_validation']} %)."]
    else:
        lines += ["", "The calibrated model holds no friction terms, so the benchmark's "
                  "cross-validation force error is not computed for it."]
    return lines + [""]


def symmetric_table(report: dict, armature: float, pub: dict) -> list[str]:
    """The report's symmetric alternative (the model the chosen direction-dependent
    friction refines, fitted by the command beside it) set beside the published symmetric
    model."""
    sym = report.get("symmetric_alternative")
    if not sym:
        return []
    joint = emps.JOINT
    moving = report["base_parameters"][joint]["nominal"]["moving_mass"]
    eq = (sym.get("equation_error") or {}).get("parameters") or {}

    def terms(values: dict) -> list[tuple[str, float, float]]:
        get = {k.split(".", 1)[1]: v["value"] for k, v in values.items()}
        return [("M [kg]", moving * get.get("inertia_scale", 1.0) + armature, pub["M"]),
                ("Fv [N s/m]", get["damping"], pub["Fv"]), ("Fc [N]", get["friction"], pub["Fc"]),
                ("offset [N]", -get["offset"], pub["OF"])]

    rows = terms(sym["parameters"])
    inverse = terms(eq) if eq else [(n, math.nan, r) for n, _, r in rows]
    return ["", f"The symmetric model the command fitted beside the chosen one "
            f"({' + '.join(sym['causes'])}; report.json `symmetric_alternative`; BIC "
            f"{sym['delta_bic']:+.0f} against {' + '.join(sym['refined_by'])}, residual "
            f"{sym['residual_to_noise']:.2f} against {sym['residual_to_noise_refined']:.2f} "
            "x noise):", "",
            "| published term | published (IDIM-LS) | symmetric, simulation fit | difference "
            "| symmetric, inverse dynamics | difference |", "|---|---|---|---|---|---|",
            *(f"| {name} | {ref:.4f} | {ours:.4f} | {_pct((ours - ref) / ref)} | {inv:.4f} | "
              f"{_pct((inv - ref) / ref)} |"
              for (name, ours, ref), (_, inv, _) in zip(rows, inverse, strict=True))]


def section_free_swing(data: Path, work: Path) -> list[str]:
    folder = work / "free_swing"
    cmds = [convert("convert_free_swing.py", data / "pendulum_free_swing", folder)]
    shown, report, seconds = calibrate(
        folder, ["free_swing_01.csv", "free_swing_02.csv"], ["free_swing_03.csv"], "calibrated")
    cmds.append(shown)
    fitted = joint_terms(folder / "calibrated" / "object.json", swing.JOINT)
    return ["## Free-swing pendulum, whole files", "",
            "jensen-benard/rotary-inverted-pendulum. The converter writes each run whole "
            "(the hand that lets go is in it) and the rig from its stated geometry, without "
            f"damping (inertia about the axis {swing.inertia_about_axis():.3g} kg m^2, small-"
            f"swing frequency {swing.small_swing_frequency():.3f} Hz). Runs 1 and 2 are "
            "fitted, run 3 held out.", "", "```", *cmds, "```", "", *summary(report, seconds),
            "", *parameters_table(report), "",
            f"Calibrated inertia about the axis {fitted['J']:.4g} kg m^2 (stated rig "
            f"{swing.inertia_about_axis():.4g}); the author's viscous damping "
            f"{swing.AUTHOR_DAMPING} N m s/rad (decay of the peaks).", ""]


def section_dfki(data: Path, work: Path) -> list[str]:
    folder = work / "dfki"
    cmds = [convert("convert_dfki_pendulum.py", data / "dfki_pendulum", folder)]
    shown, report, seconds = calibrate(
        folder, ["pd_system_identification.csv"],
        ["energy_shaping.csv", "ilqr.csv", "sac.csv"], "calibrated")
    cmds.append(shown)
    shown_hand, hand, hand_seconds = calibrate(folder, ["gravity_compensation.csv"], [], "hand")
    cmds.append(shown_hand)
    fitted = joint_terms(folder / "calibrated" / "object.json", dfki.JOINT)
    rig, pub = dfki.stated_rig(), dfki.PUBLISHED
    half = report["base_parameters"][dfki.JOINT].get("halfwidth95") or {}
    eq = report.get("equation_error") or {}
    inverse = _inverse_terms(eq, fitted["armature"]) or fitted
    # the same structure fitted on the held-out runs' effort (report.json holdout_estimate)
    there = _inverse_terms(report.get("holdout_estimate") or {}, fitted["armature"])
    head_there = " | the same structure on the held-out runs' effort" if there else ""
    col = (lambda key: f" | {there[key]:.4f} {_pm(there[key + '_half'])}") if there \
        else (lambda key: "")
    return ["## DFKI torque-limited pendulum", "",
            "dfki-ric-underactuated-lab/torque_limited_simple_pendulum. The converter writes "
            "position and the motor's current-derived torque per run and the rig as its "
            "authors state it (bob 0.546 kg at 0.5 m, rod and mounts 0.13 kg, centre of mass "
            "0.45 m, the AK80-6 rotor reflected through 6:1 as armature). The identification "
            "run is fitted, the other controllers' runs are held out.", "", "```", *cmds,
            "```", "", *summary(report, seconds), "", *parameters_table(report), "",
            *judged_by(report), "",
            "| term | stated rig | authors' published fit | calibrated (written) | "
            f"the command's inverse dynamics{' (rejected)' if eq.get('rejected') else ''}"
            f"{head_there} |", "|---|---|---|---|---|" + ("---|" if there else ""),
            f"| J, inertia about the axis, armature included [kg m^2] | {rig['J']:.4f} | "
            f"{pub['J']:.4f} | {fitted['J']:.4f} {_pm(half.get('inertia_about_axis'))} | "
            f"{inverse['J']:.4f} {_pm(inverse['J_half'])}{col('J')} |",
            f"| m cx, first moment [kg m] | {rig['m_cx']:.4f} | {pub['m_cx']:.4f} | "
            f"{fitted['m_cx']:.4f} {_pm((half.get('first_moment') or [None])[0])} | "
            f"{inverse['m_cx']:.4f} {_pm(inverse['m_cx_half'])}{col('m_cx')} |",
            f"| sqrt(g m cx / J) [rad/s] | {_omega(rig):.3f} | {_omega(pub):.3f} | "
            f"{_omega(fitted):.3f} | {_omega(inverse):.3f}"
            f"{f' | {_omega(there):.3f}' if there else ''} |", "",
            "The evidence (bench/calibrate_measured.py, from the converted CSVs): the "
            "measured torque predicted from the measured motion by the authors' model "
            "structure with each set of inertial terms, its friction and offset fitted on "
            "the identification run, over whole runs (the stretches the command leaves out "
            "as pushes included: they decide the second table, docs/calibration.md):", "",
            *torque_evidence(folder, {"stated rig": (rig["J"], rig["m_cx"]),
                                      "published fit": (pub["J"], pub["m_cx"]),
                                      "calibrated": (fitted["J"], fitted["m_cx"]),
                                      "the command's inverse dynamics":
                                      (inverse["J"], inverse["m_cx"])}), "",
            "The gravity-compensation run (a person moves the arm):", "",
            *summary(hand, hand_seconds), ""]


def _inverse_terms(eq: dict, armature: float) -> dict | None:
    """J (with the joint's armature) and m cx the command's inverse-dynamics estimate
    gives (report.json ``equation_error``), with their 95 % half-widths."""
    base = (eq.get("base_parameters") or {}).get(dfki.JOINT)
    if not base:
        return None
    half = base.get("halfwidth95") or {}
    return {"J": base["inertia_about_axis"] + armature, "m_cx": base["first_moment"][0],
            "J_half": half.get("inertia_about_axis"),
            "m_cx_half": (half.get("first_moment") or [None])[0]}


def _pm(h) -> str:
    return f"± {h:.4f}" if h is not None else ""


def _omega(terms: dict) -> float:
    return math.sqrt(9.81 * terms["m_cx"] / terms["J"])


def judged_by(report: dict) -> list[str]:
    """Which error chose the structure and judged the held-out runs, and the held-out
    runs' effort errors where the effort judged them."""
    out = [f"- chosen by: {report['selected_by']}; held out judged by: "
           f"{'effort' if report.get('holdout_effort') else 'position'}; its residual: "
           f"{report.get('residual_error', 'position')}; cross-validation by "
           f"{report['cross_validation']['by']} on the {report['cross_validation']['error']}"]
    est = report.get("holdout_estimate")
    if est:
        out[0] += ("; the same structure fitted on the held-out runs' effort " +
                   ("agrees with the fit" if est["agree"] else "disagrees with the fit ("
                    + ", ".join(f"{k} {v['held_out']:.3g} {_pm(v['held_out_halfwidth95'])} "
                                f"against {v['fit']:.3g} {_pm(v['fit_halfwidth95'])}"
                                for k, v in est["parameters"].items() if not v["agree"])
                    + ")"))
    held = report.get("holdout_effort")
    if held:
        which = "the rejected structure" if report["rejected"] else "calibrated"
        out += ["", "| held-out run | effort RMS, nominal [N m] | "
                f"{which} [N m] |", "|---|---|---|"]
        out += [f"| {Path(e['file']).name} | {e['rms_nominal']:.4f} | "
                f"{e['rms_calibrated']:.4f} |" for e in held]
    return out


def _dfki_signals(folder: Path, name: str, cutoff: float):
    """Position, velocity, acceleration and torque of one run on a uniform grid: the
    torque's spikes out (a running median over 11 samples), both low-passed at ``cutoff``
    Hz (zero phase), the ends (5 % each) dropped."""
    from scipy.signal import butter, filtfilt, medfilt

    d = np.loadtxt(folder / f"{name}.csv", delimiter=",", comments="#", skiprows=2)
    h = float(np.median(np.diff(d[:, 0])))
    t = np.arange(d[0, 0], d[-1, 0], h)
    b, a = butter(4, min(cutoff * 2 * h, 0.95))
    q = filtfilt(b, a, np.interp(t, d[:, 0], d[:, 1]))
    tau = filtfilt(b, a, medfilt(np.interp(t, d[:, 0], d[:, 2]), 11))
    dq = np.gradient(q, h)
    ddq = np.gradient(dq, h)
    keep = slice(len(t) // 20, -(len(t) // 20))
    return q[keep], dq[keep], ddq[keep], tau[keep]


def _regressors(q, dq, ddq) -> np.ndarray:
    """The authors' model: J ddq + m cx g sin q + Fv dq + Fc atan(100 dq) + offset."""
    return np.column_stack([ddq, 9.81 * np.sin(q), dq, np.arctan(100 * dq), np.ones_like(q)])


def torque_evidence(folder: Path, candidates: dict[str, tuple[float, float]],
                    cutoff: float = 5.0) -> list[str]:
    """Which inertial terms the measured motion and torque support. First the plain least
    squares of the authors' model on the identification run at three low-pass cutoffs;
    then, for each candidate (J, m cx), its small-swing frequency sqrt(g m cx / J), and the
    torque it predicts from the measured motion on every run (friction and offset fitted on
    the identification run with J and m cx held), RMS."""
    runs = ["pd_system_identification", "energy_shaping", "ilqr", "sac"]
    lines = ["| least squares on the identification run, low-pass | J [kg m^2] | "
             "m cx [kg m] | sqrt(g m cx / J) [rad/s] |", "|---|---|---|---|"]
    for fc in (3.0, 5.0, 8.0):
        q, dq, ddq, tau = _dfki_signals(folder, runs[0], fc)
        coef, *_ = np.linalg.lstsq(_regressors(q, dq, ddq), tau, rcond=None)
        lines.append(f"| {fc:g} Hz | {coef[0]:.4f} | {coef[1]:.4f} | "
                     f"{np.sqrt(9.81 * coef[1] / coef[0]):.3f} |")
    signals = {name: _dfki_signals(folder, name, cutoff) for name in runs}
    lines += ["", "| inertial terms | J | m cx | sqrt(g m cx / J) [rad/s] | "
              + " | ".join(f"torque RMS error, {r} [N m]" for r in runs) + " |",
              "|---|---|---|---|" + "---|" * len(runs)]
    for label, (inertia, moment) in candidates.items():
        q, dq, ddq, tau = signals[runs[0]]
        x = _regressors(q, dq, ddq)
        coef, *_ = np.linalg.lstsq(x[:, 2:], tau - x[:, :2] @ [inertia, moment], rcond=None)
        errs = []
        for name in runs:
            q, dq, ddq, tau = signals[name]
            pred = _regressors(q, dq, ddq) @ np.concatenate([[inertia, moment], coef])
            errs.append(float(np.sqrt(np.mean((tau - pred) ** 2))))
        lines.append(f"| {label} | {inertia:.4f} | {moment:.4f} | "
                     f"{np.sqrt(9.81 * moment / inertia):.3f} | "
                     + " | ".join(f"{e:.3f}" for e in errs) + " |")
    return lines


SECTIONS = {"emps": section_emps, "free_swing": section_free_swing, "dfki": section_dfki}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", type=Path, default=MEASURED)
    parser.add_argument("--work", type=Path, help="where the converted data and the "
                        "calibrations go (default: a temporary folder)")
    parser.add_argument("--only", default=",".join(SECTIONS))
    parser.add_argument("--reuse", action="store_true", help="render from the reports a "
                        "previous run left in --work (its commands and their times)")
    args = parser.parse_args()
    names = [name.strip() for name in args.only.split(",") if name.strip()]
    unknown = [name for name in names if name not in SECTIONS]
    if unknown:  # before any work: a typo must not cost a calibration first
        parser.error(f"--only: unknown section(s) {', '.join(unknown)}; choose from "
                     f"{', '.join(SECTIONS)}")
    global REUSE
    REUSE = args.reuse
    print(f"<!-- machine: {describe()}, load average {os.getloadavg()[0]:.1f} -->")
    with tempfile.TemporaryDirectory() as tmp:
        work = args.work or Path(tmp)
        for name in names:
            print("\n".join(SECTIONS[name](args.data, work)), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
