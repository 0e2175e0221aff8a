"""Calibration against real measurements, published figures beside ours: the EMPS benchmark
(closed loop, real friction) and the free-swing pendulum. Writes ``docs/calibration.md``.

    python -m real2code_export.calibrate.evaluate [--data ../shared/data/measured]
        [--out docs/calibration.md]
"""

from __future__ import annotations

import argparse
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .. import atomic
from . import emps, pendulum
from .fit import fit_candidate
from .run import CalibrationResult, calibrate_trajectories

DEFAULT_DATA = Path(os.environ.get(
    "REAL2CODE_SHARED_DATA", Path(__file__).resolve().parents[3] / "shared" / "data")) / "measured"


# -- EMPS ------------------------------------------------------------------------------------
@dataclass
class EmpsResult:
    nominal_mass: float
    calibration: CalibrationResult
    symmetric: dict[str, float]  # our symmetric-friction fit (model terms)
    extended: dict[str, float]  # the chosen model (model terms)
    published_ls: dict[str, float]  # the benchmark's IDIM-LS, rerun here
    published_ls_asym: dict[str, float]
    errors: dict[str, dict[str, float]] = field(default_factory=dict)  # percent
    seconds: float = 0.0


def _model_terms(fit, nominal_mass: float) -> dict[str, float]:
    """mass, damping, friction (or the four directional values), offset from a fit."""
    v = {p.name: fit.values[p.key] for e in fit.effects for p in e.params}
    out = {"mass": nominal_mass * v.get("inertia_scale", 1.0)}
    for key in ("damping", "friction", "offset", "friction_pos", "friction_neg",
                "damping_pos", "damping_neg"):
        if key in v:
            out[key] = v[key]
    return out


def run_emps(folder: Path, nominal_mass: float = 50.0) -> EmpsResult:
    t0 = time.perf_counter()
    est = emps.read_mat(folder / "DATA_EMPS.mat")
    val = emps.read_mat(folder / "DATA_EMPS_PULSES.mat")
    model = emps.nominal_model(nominal_mass)
    result = calibrate_trajectories(model, [emps.trajectory(est)], [emps.trajectory(val)])
    chosen = result.selection.chosen
    # the benchmark's own model structure, symmetric friction: mass, viscous and Coulomb
    # friction, a constant force, fitted by the same closed-loop simulation
    lib = result.problem.effects[emps.JOINT]
    symmetric = fit_candidate(result.problem, tuple(lib[n] for n in (
        "inertia", "damping", "friction", "offset")), warm=_symmetric_start(chosen))
    sym = _model_terms(symmetric, nominal_mass)
    ext = _model_terms(chosen, nominal_mass)
    out = EmpsResult(nominal_mass, result, sym, ext, emps.published_inverse_fit(est),
                     emps.published_inverse_fit(est, asymmetric=True))
    published = {"mass": emps.PUBLISHED["M"], "damping": emps.PUBLISHED["Fv"],
                 "friction": emps.PUBLISHED["Fc"], "offset": -emps.PUBLISHED["OF"]}
    for label, params in (("published", published), ("symmetric", sym), ("extended", ext)):
        if not params:
            continue
        errs = {"force_estimation": emps.relative_force_error(est, params),
                "force_cross_validation": emps.relative_force_error(val, params)}
        out.errors[label] = errs
    # closed-loop replays of both files by the published model and by ours
    for label, obj in (("published", _published_object(nominal_mass)),
                       ("extended", result.model)):
        from .run import replay

        for name, rec in (("estimation", est), ("validation", val)):
            fit = replay(obj, [emps.trajectory(rec)])
            ro = fit.simulated[0]
            rel = emps.relative_errors(rec, ro.positions[:, 0], ro.efforts[:, 0])
            out.errors.setdefault(label, {})[f"closed_loop_position_{name}"] = rel["position"]
            out.errors[label][f"closed_loop_force_{name}"] = rel["force"]
    out.seconds = time.perf_counter() - t0
    return out


def _symmetric_start(chosen) -> dict[str, float]:
    """Start the symmetric fit from the chosen direction-dependent one."""
    j = emps.JOINT
    v = dict(chosen.values)
    if f"{j}.friction_pos" in v:
        v[f"{j}.friction"] = 0.5 * (v[f"{j}.friction_pos"] + v[f"{j}.friction_neg"])
        v[f"{j}.damping"] = 0.5 * (v[f"{j}.damping_pos"] + v[f"{j}.damping_neg"])
        v[f"{j}.offset"] = -0.5 * (v[f"{j}.friction_pos"] - v[f"{j}.friction_neg"])
    return v


def _published_object(nominal_mass: float):
    """The benchmark's published model as a calibrated object (closed-loop check)."""
    from .extras import set_joint_extras

    obj = emps.nominal_model(emps.PUBLISHED["M"])
    d = obj.joint(emps.JOINT).dynamics
    d.damping, d.friction = emps.PUBLISHED["Fv"], emps.PUBLISHED["Fc"]
    set_joint_extras(obj, emps.JOINT, {"offset": {"effort": -emps.PUBLISHED["OF"]}})
    return obj


# -- pendulum --------------------------------------------------------------------------------
@dataclass
class PendulumFold:
    viscous_only: float  # damping of the author's structure (viscous only), fitted here
    decay_rate: float  # b / (2 I) of that fit, 1/s: what the decay itself fixes
    inertia: float  # the nominal rig's inertia about the axis
    fitted: list[str]
    held_out: str
    causes: list[str]
    parameters: dict[str, Any]
    holdout_before: float
    holdout_after: float
    fitted_before: float
    fitted_after: float
    unexplained: bool
    residual_to_noise: float

    @property
    def reduction(self) -> float:
        return 100.0 * (1.0 - self.holdout_after / self.holdout_before)


def run_pendulum(folder: Path) -> list[PendulumFold]:
    runs = pendulum.runs(folder)
    trajs = [pendulum.read_run(p) for p in runs]
    model = pendulum.nominal_model()
    folds = []
    for k in range(len(trajs)):
        fit = [t for i, t in enumerate(trajs) if i != k]
        res = calibrate_trajectories(model, fit, [trajs[k]])
        r = res.report
        lib = res.problem.effects[pendulum.JOINT]
        viscous = fit_candidate(res.problem, (lib["damping"], lib["inertia"]))
        b = viscous.values[f"{pendulum.JOINT}.damping"]
        inertia = res.problem.contexts[pendulum.JOINT].inertia
        folds.append(PendulumFold(b, b / (2 * inertia), inertia,
                                  [Path(t.source).name for t in fit], Path(trajs[k].source).name,
                                  r["causes"], r["parameters"], r["holdout_rmse_before"],
                                  r["holdout_rmse_after"], r["rmse_before"], r["rmse_after"],
                                  r["unexplained"], r["residual_to_noise"]))
    return folds


# -- the document ------------------------------------------------------------------------------
def _f(x: float | None, fmt: str = ".4g") -> str:
    return "—" if x is None else format(x, fmt)


def _rel(ours: float, ref: float) -> str:
    return f"{100.0 * (ours - ref) / ref:+.2f} %"


def markdown(emps_result: EmpsResult | None, folds: list[PendulumFold] | None) -> str:
    lines = ["# Calibration against real measurements", "",
             "Produced by `python -m real2code_export.calibrate.evaluate` (rerun it to "
             "reproduce every figure here). Data: `../shared/data/measured` (see its README).",
             ""]
    if emps_result is not None:
        e = emps_result
        r = e.calibration.report
        lines += ["## EMPS: a prismatic axis in closed loop, real friction", "",
                  "Janot, Gautier, Brunot (2019), *Data Set and Reference Models of EMPS*. The "
                  "nominal model is a carriage of a guessed "
                  f"{e.nominal_mass:g} kg on a frictionless slide; calibration replays the "
                  "estimation file in MuJoCo with the benchmark's position loop in the loop "
                  "(the law recovered exactly from the recorded voltage), fits the candidate "
                  "effects by simulation (position and force), and selects by BIC.", "",
                  f"Causes named: **{', '.join(r['causes']) or 'none'}**"
                  f"{' (unexplained residual remains)' if r['unexplained'] else ''}.", "",
                  "Selection path: " + "; ".join(e.calibration.selection.log) + ".", "",
                  "### Parameters, symmetric friction model", "",
                  "| parameter | published (IDIM-LS) | benchmark script rerun here | ours "
                  "(closed-loop simulation fit) | ours vs published |", "|---|---|---|---|---|"]
        pub = {"mass": emps.PUBLISHED["M"], "damping": emps.PUBLISHED["Fv"],
               "friction": emps.PUBLISHED["Fc"], "offset": -emps.PUBLISHED["OF"]}
        names = {"mass": "M [kg]", "damping": "Fv [N s/m]", "friction": "Fc [N]",
                 "offset": "offset, applied [N] (published OF = -offset)"}
        for key, label in names.items():
            ours = e.symmetric.get(key)
            lines.append(f"| {label} | {pub[key]:.4f} | {e.published_ls.get(key, 0):.4f} | "
                         f"{_f(ours, '.4f')} | {_rel(ours, pub[key]) if ours else '—'} |")
        lines += ["", "Our values are fitted by replaying the closed loop in MuJoCo (the "
                  "simulation error of the position), not by the benchmark's inverse "
                  "model; the benchmark's least squares, rerun here on its own signals, is "
                  "shown for reference."]
        lines += ["", "### Extended model (the chosen one)", "",
                  "| parameter | ours | benchmark's asymmetric IDIM-LS rerun here |",
                  "|---|---|---|"]
        for key, value in e.extended.items():
            ref = e.published_ls_asym.get(key)
            lines.append(f"| {key} | {value:.4f} | {_f(ref, '.4f')} |")
        lines += ["", "### Errors (percent; the benchmark's definitions)", "",
                  "| figure | published | published model, rerun here | ours, symmetric | "
                  "ours, extended |", "|---|---|---|---|---|"]
        rows = [("force, inverse model, estimation file", "force_estimation"),
                ("force, inverse model, cross-validation (pulses file)",
                 "force_cross_validation"),
                ("position, closed-loop simulation, estimation file",
                 "closed_loop_position_estimation"),
                ("position, closed-loop simulation, validation file",
                 "closed_loop_position_validation"),
                ("force, closed-loop simulation, validation file",
                 "closed_loop_force_validation")]
        for label, key in rows:
            lines.append(f"| {label} | {emps.PUBLISHED_ERRORS.get(key, float('nan')):.4g} | "
                         f"{_f(e.errors.get('published', {}).get(key))} | "
                         f"{_f(e.errors.get('symmetric', {}).get(key))} | "
                         f"{_f(e.errors.get('extended', {}).get(key))} |")
        lines += ["", f"Calibration time: {e.seconds:.0f} s.", ""]
    if folds:
        lines += ["## Free-swing pendulum", "",
                  "jensen-benard/rotary-inverted-pendulum. The nominal model is the rig from "
                  "its stated geometry (rod, hinge piece, coupler offset), with no damping: "
                  "it swings forever. Each row fits two runs and holds out the third.", "",
                  "| fitted | held out | causes | values | held-out RMSE nominal [rad] | "
                  "calibrated [rad] | reduction |", "|---|---|---|---|---|---|---|"]
        for f in folds:
            values = ", ".join(f"{k.split('.', 1)[1]} = {p['value']:.4g} {p['unit']}"
                               for k, p in f.parameters.items())
            lines.append(f"| {' + '.join(f.fitted)} | {f.held_out} | {', '.join(f.causes)} | "
                         f"{values} | {f.holdout_before:.4g} | {f.holdout_after:.4g} | "
                         f"{f.reduction:.1f} % |")
        mean_b = sum(f.viscous_only for f in folds) / len(folds)
        mean_rate = sum(f.decay_rate for f in folds) / len(folds)
        lines += ["", "The named cause beside the author's: with the author's structure (viscous "
                  "damping only, plus the inertia correction), fitted here on the same folds, "
                  f"damping = {mean_b:.3g} N m s/rad (folds: "
                  f"{', '.join(f'{f.viscous_only:.3g}' for f in folds)}), against the "
                  f"author's {pendulum.AUTHOR_DAMPING} N m s/rad (decay of the peaks, mean of "
                  "the three runs). What the swing decay fixes is b / (2 I), "
                  f"{mean_rate:.3f} 1/s here; with the rig's inertia from its stated geometry "
                  f"(I = {folds[0].inertia:.2g} kg m^2 about the axis, frequency "
                  f"{pendulum.small_swing_frequency():.2f} Hz against the measured ~1.74 Hz) "
                  "that is an order of magnitude below the author's value, which implies an "
                  "inertia about ten times larger than the stated rod and hinge piece have.",
                  "", "Notes: the first half second of each run is left out (the hand is "
                  "still on the pendulum: its energy rises, then drops, before it swings "
                  "free). A constant torque, or equally Coulomb friction that differs with "
                  "the direction (the two are the same law), stands here for the encoder's "
                  "zero being a fraction of a degree off the hanging position; the residual "
                  "left (unexplained) is tens of sensor-noise deviations, more than these "
                  "effects cover.", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m real2code_export.calibrate.evaluate")
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA)
    parser.add_argument("--out", type=Path, default=Path("docs/calibration.md"))
    parser.add_argument("--skip-emps", action="store_true")
    parser.add_argument("--skip-pendulum", action="store_true")
    args = parser.parse_args(argv)
    e = None if args.skip_emps else run_emps(args.data / "emps")
    folds = None if args.skip_pendulum else run_pendulum(args.data / "pendulum_free_swing")
    atomic.write_text(args.out, markdown(e, folds))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
