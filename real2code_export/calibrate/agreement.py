"""Whether a fit's values hold on the held-out runs: where the held-out runs measure the
effort and are judged by it, the chosen structure's inverse-dynamics (effort-equation)
estimate is made on them as well and set beside the fit's, parameter by parameter.

A structure the held-out effort judges worse than the nominal model is either the wrong
structure or the right one with values the other runs do not share. The estimate on the
held-out runs tells which: where it differs from the fit's beyond both 95 % intervals the
runs disagree about the cause's value (a torque that reads another scale in each run, an
effect none of the candidates holds), so no single calibrated value can be right for all of
them; where it agrees, the fit's values stand and the held-out residual is something else.
Nothing here is fitted into the model: the held-out runs stay held out.
"""

from __future__ import annotations

import dataclasses
import math

from ..model import ArticulatedObject
from .alternatives import finite_or_none
from .apply import base_parameter_halfwidths, calibrated_object
from .fit import Fit
from .inertial import compared
from .inverse import equation_fit
from .problem import Problem

# two estimates agree where their difference is within this many standard errors of it
# (each estimate's own, independent: different runs)
AGREE_Z = 1.96


def held_out_estimate(model: ArticulatedObject, held: Problem, chosen: Fit) -> dict | None:
    """The chosen structure's effort-equation estimate on the held-out runs of ``held``
    beside the fit's own (``chosen.start``), each parameter's agreement, and the base
    inertial parameters it gives; None where nothing was fitted by the effort equation."""
    fitted = chosen.start
    if not chosen.effects or fitted is None:
        return None
    effects = tuple(held.effects[e.joint].get(e.variant) for e in chosen.effects)
    if any(e is None for e in effects):
        return None
    there = equation_fit(held, effects)
    parameters = {}
    for key, value in there.values.items():
        mine, h_mine, h_there = fitted.values.get(key), fitted.halfwidth(key), \
            there.halfwidth(key)
        se = math.hypot(h_mine, h_there) / 1.96
        agree = mine is None or not math.isfinite(se) or abs(value - mine) <= AGREE_Z * se
        parameters[key] = {"fit": mine, "fit_halfwidth95": finite_or_none(h_mine),
                           "held_out": value, "held_out_halfwidth95": finite_or_none(h_there),
                           "agree": bool(agree)}
    as_fit = dataclasses.replace(chosen, values={**chosen.values, **there.values},
                                 cov=dict(there.cov))
    held_model = calibrated_object(model, as_fit)
    return {"causes": sorted(chosen.names),
            "runs": [tr.source for tr in held.trajectories],
            "parameters": parameters,
            "agree": all(p["agree"] for p in parameters.values()),
            "base_parameters": {j: {**compared(model, held_model, j)["calibrated"],
                                    "halfwidth95": base_parameter_halfwidths(model, as_fit, j)}
                                for j in held.joints},
            "note": "the chosen structure's effort-equation estimate on the held-out runs "
                    "(not written into the model); agree: within 1.96 standard errors of "
                    "the fit's own"}


def disagreement(estimate: dict | None) -> str:
    """The parameters on which the held-out runs disagree with the fit, said in a clause
    (empty where they agree or nothing was estimated)."""
    if not estimate or estimate["agree"]:
        return ""

    def pm(value: float, half: float | None) -> str:
        return f"{value:.4g}" + (f" ± {half:.2g}" if half is not None else "")

    parts = [f"{key} {pm(p['held_out'], p['held_out_halfwidth95'])} against "
             f"{pm(p['fit'], p['fit_halfwidth95'])}"
             for key, p in estimate["parameters"].items() if not p["agree"]]
    return ("; fitted on the held-out runs' effort the same structure gives " +
            ", ".join(parts) + ": the runs disagree about its value beyond both intervals")
