"""What a chosen structure refines, fitted beside it: where direction-dependent friction is
named, the symmetric model it refines (viscous and Coulomb friction the same both ways, and
a constant force), so that a reader who needs the symmetric model (a benchmark's published
values, a simulator without direction dependence) has its values fitted on the same data,
and sees what the direction dependence gains.

Fitted as the chosen structure was (by simulation), its inverse-dynamics estimate beside
it (the identification literature's symmetric model is an equation-error fit).
"""

from __future__ import annotations

import math

from .effects import Effect
from .fit import Fit, fit_candidate
from .prediction import initial_values
from .problem import Problem

# the symmetric effects a direction-dependent friction splits into
SYMMETRIC = ("damping", "friction", "offset")


def symmetric_structure(problem: Problem, effects: tuple[Effect, ...]
                        ) -> tuple[Effect, ...] | None:
    """``effects`` with each direction-dependent friction replaced by its symmetric
    counterpart; None where none is named (or a joint's library lacks the counterpart)."""
    if not any(e.name == "asymmetric_friction" for e in effects):
        return None
    out = [e for e in effects if e.name != "asymmetric_friction"]
    for e in effects:
        if e.name != "asymmetric_friction":
            continue
        lib = problem.effects[e.joint]
        for name in SYMMETRIC:
            if name not in lib:
                return None
            if not any(x.joint == e.joint and x.name == name for x in out):
                out.append(lib[name])
    return tuple(out)


def symmetric_alternative(problem: Problem, chosen: Fit) -> dict | None:
    """The symmetric model a chosen direction-dependent friction refines, fitted beside
    it: its values with 95 % intervals, by simulation and by inverse dynamics, and the
    BIC difference from the chosen structure; None where nothing is refined."""
    structure = symmetric_structure(problem, chosen.effects)
    if structure is None:
        return None
    # started from the chosen fit's shared values and initial states; the symmetric
    # effects from their own inverse-dynamics start (nearer the optimum than the chosen
    # fit's symmetric reading: a fifth fewer replays on a closed loop)
    fit = fit_candidate(problem, structure, refine=False,
                        warm={**chosen.values, **initial_values(chosen)})
    n_ref = min(fit.n_eff, chosen.n_eff)
    out = {
        "causes": sorted(fit.names),
        "refined_by": sorted(chosen.names),
        "fitted_by": "simulation",
        "parameters": {k: {"value": v, "halfwidth95": finite_or_none(fit.halfwidth.get(k, math.inf))}
                       for k, v in fit.values.items()},
        "residual_to_noise": math.sqrt(fit.rss / fit.n),
        "residual_to_noise_refined": math.sqrt(chosen.rss / chosen.n),
        "delta_bic": fit.bic(n_ref) - chosen.bic(n_ref),
        "equation_error": None,
    }
    if fit.start is not None:
        out["equation_error"] = {
            "parameters": {k: {"value": v, "halfwidth95": finite_or_none(fit.start.halfwidth(k))}
                           for k, v in fit.start.values.items()}}
    return out


def finite_or_none(x: float) -> float | None:
    """``x`` where finite, else None (JSON has no infinity: an unidentified half-width)."""
    return float(x) if math.isfinite(x) else None
