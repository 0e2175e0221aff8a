"""The calibration report: ``report.json`` (keys in docs/design.md), and a human report in
markdown with PNG plots (measured vs simulated, residuals, the candidates' scores)."""

from __future__ import annotations

import io
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..jsonsafe import finite_or_null as _num
from . import features as ft
from .effects import SENSOR, VOCABULARY, Effect, readings
from .fit import Fit
from .select import Selection

SCHEMA = "real2code_export/calibration"
# The residual left after the chosen model, in sensor-noise standard deviations (RMS),
# above which the data are called unexplained: something no candidate covers remains.
UNEXPLAINED_RATIO = 3.0


@dataclass
class Replay:
    """One trajectory replayed by the nominal and by the calibrated model."""

    label: str
    source: str
    time: np.ndarray
    measured: np.ndarray  # (n, joints)
    nominal: np.ndarray
    calibrated: np.ndarray
    joints: list[str]

    def rmse(self, which: str) -> float:
        sim = self.nominal if which == "nominal" else self.calibrated
        return float(np.sqrt(np.mean((sim - self.measured) ** 2)))


def _rmse(replays: list[Replay], which: str) -> float | None:
    if not replays:
        return None
    sq = np.concatenate([((r.nominal if which == "nominal" else r.calibrated) - r.measured)
                         .ravel() ** 2 for r in replays])
    return float(np.sqrt(sq.mean()))


def parameters_json(fit: Fit) -> dict[str, Any]:
    out = {}
    for e in fit.effects:
        for p in e.params:
            v, h = fit.values[p.key], fit.halfwidth.get(p.key, math.inf)
            out[p.key] = {
                "effect": e.name, "joint": e.joint, "name": p.name, "unit": p.unit,
                "value": v, "nominal": p.nominal,
                "ci95": [_num(v - h), _num(v + h)], "halfwidth95": _num(h),
                "identifiable": fit.identifiable.get(p.key, False),
                "correlated_with": fit.correlated.get(p.key, []),
            }
    return out


def _effort_holds(problem, chosen: Fit) -> dict[int, Effect]:
    """The chosen effort lags of at most one sample interval: below the record's time
    resolution, they are how the effort was held between samples, not a cause. The replay
    interpolates the effort linearly between samples where no loop's jitter shows it held
    (trajectory.held_efforts); a command held over each interval all the same is seen
    there as the effort felt half a sample late.
    The lag stays in the model (its replay follows the data better), reported apart."""
    period = max(tr.sample_period for tr in problem.trajectories)
    return {id(e): e for e in chosen.effects if e.name == "effort_delay"
            and abs(chosen.values[e.params[0].key]) <= period}


def build_report(problem, selection: Selection, fits: list[Replay], holdouts: list[Replay],
                 features: list[dict], sources: list[str], holdout_sources: list[str],
                 model_name: str) -> dict[str, Any]:
    chosen, n_ref = selection.chosen, selection.n_ref
    residual_to_noise = math.sqrt(chosen.rss / chosen.n)
    unexplained = residual_to_noise > UNEXPLAINED_RATIO
    order = {name: i for i, name in enumerate(VOCABULARY)}
    held = _effort_holds(problem, chosen)
    causes = sorted({e.name for e in chosen.effects if id(e) not in held}, key=order.get)
    details = []
    for e in sorted(chosen.effects, key=lambda e: (e.joint, order[e.name])):
        strength, se = e.strength(chosen.effect_values(e), chosen.effect_cov(e))
        aliases, choice = readings(e, {x.name for x in chosen.effects
                                       if x.joint == e.joint and x is not e})
        details.append({"effect": e.name, "joint": e.joint, "aliases": list(aliases),
                        "side": "recording" if id(e) in held else
                        "sensor" if e.name in SENSOR else "dynamics",
                        "indistinguishable_from": list(aliases), "choice": choice,
                        "motion_change_rms_noise": _num(chosen.material.get(e.name)),
                        "departure_from_absence": _num(strength),
                        "departure_stderr": _num(se)})
    candidates = []
    best_bic = min(f.bic(n_ref) for f in selection.fitted)
    for f in sorted(selection.fitted, key=lambda f: f.bic(n_ref)):
        candidates.append({
            "causes": sorted(f.names, key=order.get), "n_params": f.k,
            "score": "BIC", "bic": f.bic(n_ref), "delta_bic": f.bic(n_ref) - best_bic,
            "residual_rms_noise": math.sqrt(f.rss / f.n),
            "all_effects_significant": all(f.present(e) for e in f.effects),
            "fitted_by": "simulation", "selected": f is chosen,
            "parameters": {k: f.values[k] for k in sorted(f.values)},
        })
    fitted_keys = {tuple(sorted(f.names)) for f in selection.fitted}
    for key, ef in selection.screened:
        names = tuple(sorted({k.split(":")[1] for k in key}))
        if names in fitted_keys:
            continue
        candidates.append({
            "causes": sorted(names, key=order.get), "n_params": ef.k,
            "score": "BIC (inverse-dynamics screen)", "bic": ef.bic(selection.screen_n_ref),
            "fitted_by": "inverse dynamics (screened out before simulation)"
            if selection.by == "simulation" else "inverse dynamics (effort equation)",
            "selected": ef is chosen.start,  # the effort equation's own result
        })
    report = {
        "schema": SCHEMA, "schema_version": 1, "model": model_name,
        "joints": list(problem.joints), "data": sources, "holdout": holdout_sources,
        "causes": causes,
        "cause_details": details,
        "effort_hold": {e.joint: chosen.values[e.params[0].key] for e in held.values()},
        "parameters": parameters_json(chosen),
        "rmse_before": _rmse(fits, "nominal"), "rmse_after": _rmse(fits, "calibrated"),
        "holdout_rmse_before": _rmse(holdouts, "nominal"),
        "holdout_rmse_after": _rmse(holdouts, "calibrated"),
        "rmse_unit": ", ".join(sorted({problem.contexts[j].unit("position")
                                       for j in problem.joints})),
        "unexplained": bool(unexplained),
        "residual_to_noise": residual_to_noise,
        "unexplained_threshold": UNEXPLAINED_RATIO,
        "noise": {tr.source: problem.position_noise[i].tolist()
                  for i, tr in enumerate(problem.trajectories)},
        "candidates": candidates,
        "criterion": "BIC with the effective sample count of the best-fitting residual "
                     f"({n_ref:.1f} of {chosen.n}); an effect is named only if its 95 % "
                     "interval excludes absence and it moves the motion by more than the "
                     "sensor noise",
        "features": features,
        "trajectories": [{"file": r.source, "use": r.label, "rmse_before": r.rmse("nominal"),
                          "rmse_after": r.rmse("calibrated")} for r in fits + holdouts],
        "selection_log": selection.log,
        "selected_by": selection.by,
        "smoothing": smoothing(problem),
    }
    return report


def smoothing(problem) -> list[dict]:
    """Per run, the smoothing its equation error used (features.chosen_window): the
    Savitzky-Golay window, in samples and seconds, and the low-pass cut-off it amounts to
    (motion and effort filtered alike)."""
    out = []
    for tr, sig in zip(problem.trajectories, problem.signals, strict=False):
        period = tr.sample_period
        out.append({"file": tr.source, "window_samples": int(sig.window),
                    "window_seconds": float(sig.window * period),
                    "cutoff_hz": ft.cutoff(sig.window, period),
                    "polyorder": min(ft.POLYORDER, sig.window - 1),
                    "default_window_samples": ft.smoothing_window(period)})
    return out


def json_text(report: dict[str, Any]) -> str:
    return json.dumps(report, indent=1, allow_nan=False) + "\n"


# -- plots -----------------------------------------------------------------------------------
def _figure_bytes(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90, metadata={"Software": None})
    import matplotlib.pyplot as plt

    plt.close(fig)
    return buf.getvalue()


def replay_plot(r: Replay, unit: str) -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True,
                           gridspec_kw={"height_ratios": [2, 1]})
    for k, j in enumerate(r.joints):
        ax[0].plot(r.time, r.measured[:, k], ".", ms=2, color="0.3", label=f"measured {j}")
        ax[0].plot(r.time, r.nominal[:, k], "-", lw=1.2, color="tab:red", label="nominal model")
        ax[0].plot(r.time, r.calibrated[:, k], "--", lw=1.2, color="tab:blue",
                   label="calibrated model")
        ax[1].plot(r.time, r.nominal[:, k] - r.measured[:, k], color="tab:red", lw=1)
        ax[1].plot(r.time, r.calibrated[:, k] - r.measured[:, k], color="tab:blue", lw=1)
    ax[0].set_ylabel(f"position [{unit}]")
    ax[0].legend(loc="best", fontsize=8)
    ax[0].set_title(f"{r.label}: {Path(r.source).name}")
    ax[1].set_ylabel(f"residual [{unit}]")
    ax[1].set_xlabel("time [s]")
    ax[1].axhline(0, color="0.5", lw=0.5)
    fig.tight_layout()
    return _figure_bytes(fig)


def candidates_plot(report: dict[str, Any]) -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sim = [c for c in report["candidates"] if c["fitted_by"] == "simulation"]
    labels = ["+".join(c["causes"]) or "nominal" for c in sim]
    values = [c["delta_bic"] for c in sim]
    fig, ax = plt.subplots(figsize=(8, 0.3 * len(sim) + 1.2))
    colors = ["tab:blue" if c["selected"] else ("0.6" if c["all_effects_significant"]
                                                else "0.85") for c in sim]
    y = np.arange(len(sim))
    ax.barh(y, np.maximum(values, 1e-3), color=colors)
    ax.set_xscale("symlog", linthresh=10)
    ax.set_yticks(y, labels, fontsize=8)
    ax.invert_yaxis()
    ax.set_xlabel("BIC above the best candidate (blue: chosen; light: an effect not significant)")
    fig.tight_layout()
    return _figure_bytes(fig)


# -- markdown ----------------------------------------------------------------------------------
def _fmt(x, digits: int = 4) -> str:
    if x is None:
        return "—"
    if isinstance(x, float):
        return f"{x:.{digits}g}"
    return str(x)


def markdown(report: dict[str, Any], images: dict[str, str]) -> str:
    unit = report["rmse_unit"]
    lines = [f"# Calibration of `{report['model']}`", ""]
    joints = ", ".join(f"`{j}`" for j in report["joints"])
    if report["causes"]:
        named = ", ".join(f"**{c}**" for c in report["causes"])
        lines.append(f"Joint(s) {joints}: the measurements call for {named}.")
    else:
        lines.append(f"Joint(s) {joints}: the nominal model already explains the measurements;"
                     " no effect earns its parameters.")
    for joint, lag in report["effort_hold"].items():
        lines.append(f"- The effort on `{joint}` is replayed {lag * 1e3:.3g} ms late: within one "
                     "sample interval, how the record held it between samples (a digital "
                     "controller holds its command), not a cause.")
    for d in report["cause_details"]:
        if d["aliases"]:
            lines.append(f"- `{d['effect']}` on `{d['joint']}` is indistinguishable here from "
                         f"{', '.join(d['aliases'])}: {d.get('choice', '')}.")
    if report["unexplained"]:
        lines += ["", f"**Unexplained:** the residual left by the best model is "
                  f"{report['residual_to_noise']:.1f} times the sensor noise (threshold "
                  f"{report['unexplained_threshold']}): something none of the candidate effects "
                  "covers remains in the data (see the residual plots)."]
    else:
        lines += ["", f"The residual left is {report['residual_to_noise']:.2f} times the "
                  "sensor noise."]
    lines += ["", "## Gain", "", f"| data | RMSE nominal [{unit}] | RMSE calibrated [{unit}] |",
              "|---|---|---|",
              f"| fitted | {_fmt(report['rmse_before'])} | {_fmt(report['rmse_after'])} |",
              f"| held out | {_fmt(report['holdout_rmse_before'])} | "
              f"{_fmt(report['holdout_rmse_after'])} |", ""]
    if report["parameters"]:
        lines += ["## Fitted parameters", "",
                  "| parameter | value | 95 % interval | unit | identifiable |", "|---|---|---|---|---|"]
        for key, p in report["parameters"].items():
            lo, hi = p["ci95"]
            interval = f"[{_fmt(lo)}, {_fmt(hi)}]" if lo is not None else "unbounded"
            ident = "yes" if p["identifiable"] else "**no**"
            if p["correlated_with"]:
                ident += f" (correlated with {', '.join(p['correlated_with'])})"
            lines.append(f"| `{key}` | {_fmt(p['value'], 6)} | {interval} | {p['unit']} | {ident} |")
        lines.append("")
    lines += _checks_markdown(report)
    lines += ["## What the data show", ""]
    for f in report["features"]:
        lines.append(f"- `{Path(f['file']).name}`: " + "; ".join(f["summary"]))
    if report.get("smoothing"):
        lines += ["", "Smoothing of the effort equation (motion and effort filtered alike; "
                  "the window chosen from each run's noise, features.chosen_window):", "",
                  "| run | window [samples] | window [s] | cut-off (-3 dB) [Hz] |",
                  "|---|---|---|---|"]
        lines += [f"| `{Path(r['file']).name}` | {r['window_samples']} | "
                  f"{r['window_seconds']:.3g} | {r['cutoff_hz']:.3g} |"
                  for r in report["smoothing"]]
    lines += ["", "## Candidates", "", f"Criterion: {report['criterion']}.", "",
              "| causes | parameters | ΔBIC | residual / noise | all significant | chosen |",
              "|---|---|---|---|---|---|"]
    for c in report["candidates"]:
        if c["fitted_by"] != "simulation":
            continue
        lines.append(f"| {' + '.join(c['causes']) or 'nominal'} | {c['n_params']} | "
                     f"{c['delta_bic']:.1f} | {c['residual_rms_noise']:.2f} | "
                     f"{'yes' if c['all_effects_significant'] else 'no'} | "
                     f"{'**yes**' if c['selected'] else ''} |")
    screened = [c for c in report["candidates"] if c["fitted_by"] != "simulation"]
    if screened:
        lines += ["", f"{len(screened)} more structures were scored by the inverse-dynamics "
                  "screen only: " + ", ".join(" + ".join(c["causes"]) for c in screened) + "."]
    lines += ["", "## Plots", ""]
    for title, path in images.items():
        lines += [f"![{title}]({path})", ""]
    lines += ["## Selection", ""] + [f"1. {s}" for s in report["selection_log"]] + [""]
    return "\n".join(lines)


def _checks_markdown(report: dict[str, Any]) -> list[str]:
    """What was left out, whether the result held on data it was not fitted on, the
    inverse-dynamics estimate, the base inertial parameters."""
    lines: list[str] = []
    if report.get("excluded"):
        lines += ["## Left out", ""]
        for e in report["excluded"]:
            lines.append(f"- `{Path(e['file']).name}` {e['start']:.3f}-{e['end']:.3f} s, "
                         f"joint `{e['joint']}`: {e['reason']}")
        lines.append("")
    cv = report.get("cross_validation")
    if report.get("rejected"):
        lines += ["## Rejected", "", f"{report['rejected']}: the nominal model is kept.", ""]
    elif cv and cv["folds"]:
        each = " (each part from its own opening)" if cv["error"] == "position" else ""
        lines += ["## Cross-validation", "", f"Refitted without each of {cv['folds']} "
                  f"{cv['by']}, the calibrated structure predicts the left-out data{each} "
                  f"with squared error {cv['sse_calibrated']:.4g} against the nominal "
                  f"model's {cv['sse_nominal']:.4g} (noise units).", ""]
    held = report.get("holdout_effort")
    if held:
        lines += ["## Held out, judged by the effort", "",
                  "Neither model's open-loop replay follows these held-out runs (each is "
                  "further from the motion than the run's mean), or the effort equation "
                  "alone chose the structure: each model predicts the measured effort from "
                  "the measured motion instead (inverse dynamics), and that error judged "
                  "them (squared, in effort-noise units, summed).", "",
                  "| run | joint | effort RMS nominal | calibrated | inverse-dynamics "
                  "estimate |", "|---|---|---|---|---|"]
        for e in held:
            lines.append(f"| `{Path(e['file']).name}` | `{e['joint']}` | "
                         f"{_fmt(e['rms_nominal'])} | {_fmt(e['rms_calibrated'])} | "
                         f"{_fmt(e.get('rms_inverse_dynamics'))} |")
        lines.append("")
    est = report.get("holdout_estimate")
    if est:
        lines += ["The same structure fitted on the held-out runs' effort (not written into "
                  "the model), beside the fit's own effort-equation estimate: "
                  + ("they agree." if est["agree"] else "they disagree beyond both 95 % "
                     "intervals: the runs do not share these values."), "",
                  "| parameter | fit | 95 % half-width | held-out runs | 95 % half-width "
                  "| agree |", "|---|---|---|---|---|---|"]
        for key, v in est["parameters"].items():
            lines.append(f"| `{key}` | {_fmt(v['fit'])} | {_fmt(v['fit_halfwidth95'], 2)} | "
                         f"{_fmt(v['held_out'])} | {_fmt(v['held_out_halfwidth95'], 2)} | "
                         f"{'yes' if v['agree'] else 'no'} |")
        lines.append("")
    sym = report.get("symmetric_alternative")
    if sym:
        eq_sym = (sym.get("equation_error") or {}).get("parameters") or {}
        lines += ["## The symmetric model beside it", "",
                  f"{' + '.join(sym['refined_by'])} refines {' + '.join(sym['causes'])} "
                  "(the same friction both ways and a constant force), fitted on the same "
                  f"data: residual {sym['residual_to_noise']:.2f} x noise against "
                  f"{sym['residual_to_noise_refined']:.2f}, BIC {sym['delta_bic']:+.1f} for "
                  "the symmetric model.", "",
                  "| parameter | simulation fit | 95 % half-width | inverse dynamics |",
                  "|---|---|---|---|"]
        for key, v in sym["parameters"].items():
            inv = eq_sym.get(key, {}).get("value")
            lines.append(f"| `{key}` | {_fmt(v['value'], 6)} | {_fmt(v['halfwidth95'])} | "
                         f"{_fmt(inv, 6)} |")
        lines.append("")
    eq = report.get("equation_error")
    if eq and eq.get("parameters"):
        lines += ["## Inverse dynamics (equation error)", ""]
        if eq.get("rejected"):
            lines += ["The structure rejected above, as the effort equation estimates it "
                      "(the nominal model was kept):", ""]
        lines += ["| parameter | equation error | 95 % half-width | simulation |",
                  "|---|---|---|---|"]
        for key, v in eq["parameters"].items():
            sim = report["parameters"].get(key, {}).get("value")
            half = (eq.get("halfwidth95") or {}).get(key)
            lines.append(f"| `{key}` | {_fmt(v, 6)} | {_fmt(half)} | {_fmt(sim, 6)} |")
        for joint, b in (eq.get("base_parameters") or {}).items():
            half = b.get("halfwidth95") or {}
            for name in b.get("unit", {}):
                value, h = b[name], half.get(name)
                fmt = (lambda x: ", ".join(_fmt(v) for v in x)) if isinstance(value, list) \
                    else _fmt
                lines.append(f"| `{joint}` {name} | {fmt(value)} | "
                             f"{fmt(h) if h is not None else '—'} | |")
        lines.append("")
    base = report.get("base_parameters") or {}
    if base:
        lines += ["## Base inertial parameters", "", "| joint | parameter | nominal | "
                  "calibrated | 95 % half-width | unit |", "|---|---|---|---|---|---|"]
        for joint, both in base.items():
            units = both["nominal"]["unit"]
            for name, unit in units.items():
                a, b = both["nominal"][name], both["calibrated"][name]
                h = (both.get("halfwidth95") or {}).get(name)
                fmt = (lambda x: ", ".join(_fmt(v) for v in x)) if isinstance(a, list) \
                    else _fmt
                lines.append(f"| `{joint}` | {name} | {fmt(a)} | {fmt(b)} | "
                             f"{fmt(h) if h is not None else '—'} | {unit} |")
        lines.append("")
    return lines
