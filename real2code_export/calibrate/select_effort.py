"""Model selection on the effort equation, where the measured effort tells the causes
apart better than the replay does: a declared closed loop whose effort is recorded clean.
A stiff loop holds the position to its reference whatever the plant, so its replay barely
moves with the causes, while the recorded effort is what the loop spent on them (the
inverse-dynamics identification of the robotics literature and of the EMPS benchmark).
The structures are compared on the equation error; only the chosen one and the one before
it are replayed (each closed-loop replay steps the law sample by sample).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from . import features
from .effects import Effect
from .fit import DEGENERATE, MATERIAL, Fit, fit_candidate, refine_fit
from .inverse import EquationFit, coefficients, design, equation_fit
from .problem import Problem
from .select import MAX_EFFECTS, Selection, _key, _n_ref, _proposals

EFFORT_CLEAN = 0.01  # smoothed effort noise / effort scale below which the effort decides
# the structure before the last step starts from the chosen one's values, a few steps away
BEFORE_NFEV = 10


def effort_decides(problem: Problem) -> bool:
    """Whether the measured effort, not the replay, tells the structures apart: every run
    is a declared closed loop with its effort recorded and clean (its noise, smoothed as
    the equation smooths it, below EFFORT_CLEAN of the effort the joint needs), and every
    candidate is linear in its parameters (no end stop). A stiff loop holds the position
    to its reference whatever the plant, so the replayed motion barely depends on the
    causes, while the recorded effort is what the loop had to spend on them (the
    inverse-dynamics identification of the robotics literature and of the EMPS
    benchmark); each closed-loop replay also steps the law sample by sample, at a cost the
    search cannot afford. A noisy effort (a loop that differentiates a coarse encoder
    feeds its noise into the force) biases the equation error: the replay decides."""
    for t, tr in enumerate(problem.trajectories):
        if tr.law() is None or not all(j in tr.efforts for j in problem.joints):
            return False
        gain = features.smoothing_gain(tr.sample_period, problem.signals[t].window)
        for k, j in enumerate(problem.joints):
            noise = float(problem.effort_noise[t][k]) * gain
            if not noise < EFFORT_CLEAN * problem.contexts[j].effort_scale:
                return False
    return all(e.coefficient_names for lib in problem.effects.values() for e in lib.values())


def select_by_effort(problem: Problem, max_effects: int = MAX_EFFECTS) -> Selection:
    """Forward stepwise search on the effort equation: each step the structure one effect
    richer with the best BIC (effective samples of the best-fitting residual) is kept if
    it beats the current one and each of its effects is there (its 95 % interval excludes
    absence; it changes the effort by at least MATERIAL noise deviations); the chosen
    structure alone is then fitted by simulation (the values reported, the replays)."""
    log = ["closed loop with its effort measured: structures compared on the effort "
           "equation (equation error); the chosen one fitted by simulation"]
    path, screened = effort_search(problem, log, max_effects)
    nominal = fit_candidate(problem, ())
    fits = [nominal]
    chosen = nominal
    if path:
        # the last step must pay in the replay too (the effort equation is biased by the
        # smoothing and may buy a small term with it): the chosen structure and the one
        # before it are fitted by simulation, and the last effect kept only if the BIC of
        # the replay prefers it
        # (refined, its numerical error measured, only once it is kept: refining leaves
        # the residual the BIC compares alone)
        chosen = fit_candidate(problem, path[-1], refine=False)
        fits.append(chosen)
        before = nominal if len(path) == 1 else fit_candidate(
            problem, path[-2], refine=False, warm=dict(chosen.values), max_nfev=BEFORE_NFEV)
        if before is not nominal:
            fits.append(before)
        n_ref = _n_ref(fits)
        if before.bic(n_ref) <= chosen.bic(n_ref):
            log.append(f"replayed, {'+'.join(chosen.names)} (BIC {chosen.bic(n_ref):.1f}) "
                       f"is no better than {'+'.join(before.names) or 'the nominal model'} "
                       f"(BIC {before.bic(n_ref):.1f}): the last effect is not kept")
            chosen = refine_fit(before)
            fits[-1 if before is not nominal else 0] = chosen
        else:
            chosen = fits[1] = refine_fit(chosen)
        # an effect the replay's estimate puts within its interval of absence is left out
        # (the effort equation's smoothing bias can make a small term look real)
        held = tuple(e for e in chosen.effects if _departs(chosen, e))
        if len(held) < len(chosen.effects):
            log.append(f"replayed, {'+'.join(sorted(e.name for e in chosen.effects))} has "
                       "effects within their 95 % interval of absence: kept "
                       f"{'+'.join(sorted(e.name for e in held)) or 'the nominal model'}")
            chosen = fit_candidate(problem, held, warm=dict(chosen.values)) if held \
                else nominal
            if held:
                fits.append(chosen)
    screen_ref = _n_ref(screened.values())
    return Selection(nominal, chosen, fits, _n_ref(fits),
                     sorted(screened.items(), key=lambda kv: kv[1].bic(screen_ref)),
                     screen_ref, log, by="effort equation")


def _departs(f: Fit, e: Effect) -> bool:
    """The effect's departure from absence exceeds its 95 % interval in fit ``f``."""
    strength, se = e.strength(f.effect_values(e), f.effect_cov(e))
    return bool(strength > 1.96 * se)


def effort_search(problem: Problem, log: list[str], max_effects: int = MAX_EFFECTS,
                  screened: dict[tuple[str, ...], EquationFit] | None = None
                  ) -> tuple[list[tuple[Effect, ...]], dict[tuple[str, ...], EquationFit]]:
    """The stepwise search of :func:`select_by_effort`: the structure kept at each step
    (the last is the chosen one), and every structure scored (``screened``: those scored
    already, by key)."""
    screened = dict(screened or {})
    if () not in screened:
        screened[()] = equation_fit(problem, ())
    current: tuple[Effect, ...] = ()
    path: list[tuple[Effect, ...]] = []
    while len(current) < max_effects:
        proposals = _proposals(problem, current)
        for p in proposals:
            if _key(p) not in screened:
                screened[_key(p)] = equation_fit(problem, p)
        n_ref = _n_ref(screened.values())
        here = screened[_key(current)]
        material = MATERIAL * _noise_share(problem, screened.values())
        kept = None
        for p in sorted(proposals, key=lambda p: screened[_key(p)].bic(n_ref)):
            ef = screened[_key(p)]
            label = "+".join(ef.names)
            if ef.bic(n_ref) >= here.bic(n_ref):
                break
            if ef.degenerate(DEGENERATE):
                log.append(f"tried {label}: BIC {ef.bic(n_ref):.1f}, two effects explain "
                           "the same thing")
            elif all(ef.present(e, material) for e in ef.effects):
                log.append(f"tried {label}: BIC {ef.bic(n_ref):.1f}")
                kept = p
                break
            else:
                log.append(f"tried {label}: BIC {ef.bic(n_ref):.1f}, an effect not "
                           "significant")
        if kept is None:
            label = "+".join(screened[_key(current)].names) or "the nominal model"
            log.append(f"no extension of {label} earns its parameters")
            break
        current = kept
        path.append(kept)
        log.append(f"kept {'+'.join(screened[_key(current)].names)}")
    return path, screened


def _noise_share(problem: Problem, screened) -> float:
    """The share of the effort noise, as the equation assumes it (the sensor's, smoothed
    as white noise is), that the data leave room for: at most the best-fitting structure's
    residual (noise and what it misses). A loop's effort noise is its reaction to the
    encoder's, not white: smoothed, it falls further than white noise does, and effects
    measured against the assumed noise would all look smaller than a deviation."""
    d = design(problem, ())
    if not len(d.noise):
        return 1.0
    best = min(ef.rss / ef.n for ef in screened if ef.n)
    return min(1.0, math.sqrt(best / float(np.mean(d.noise ** 2))))


# Where no replay can judge the structures (below), the selection is made and its values
# taken on the effort equation alone: ``Selection.by`` says so.
EFFORT_ONLY = "effort equation only"


def replay_cannot_judge(problem: Problem, selection: Selection) -> bool:
    """Whether the output error cannot judge this problem but the effort equation can:
    every run's effort is measured and replayed open loop (no declared law), no candidate
    is an end stop (the effort equation leaves impacts out), and even the simulation
    search's choice leaves the motion more than UNEXPLAINED_RATIO noise deviations off
    (RMS). An unstable plant its controller held up (a swing-up), replayed open loop on
    the recorded effort, leaves the data whatever its parameters: the output error then
    measures that divergence, not the causes, while the effort each structure says the
    measured motion needs is still a least squares of the identification literature."""
    from .report import UNEXPLAINED_RATIO

    if any(tr.law() is not None or not all(j in tr.efforts for j in problem.joints)
           for tr in problem.trajectories):
        return False
    if not all(e.coefficient_names for lib in problem.effects.values() for e in lib.values()):
        return False
    chosen = selection.chosen
    return math.sqrt(chosen.rss / chosen.n) > UNEXPLAINED_RATIO


def select_on_effort_only(problem: Problem, after: Selection,
                          max_effects: int = MAX_EFFECTS) -> Selection:
    """Where :func:`replay_cannot_judge`: the forward search of :func:`select_by_effort`
    on the effort equation (started from the structures the simulation search already
    screened), and the chosen structure's inverse-dynamics estimate is the result, its
    95 % intervals from the equation's covariance; no structure is replayed (the
    simulation search's nominal fit stays, for the replays of the report)."""
    log = after.log + [
        f"the simulation search's choice ({'+'.join(after.chosen.names) or 'nominal'}) "
        f"leaves the motion {math.sqrt(after.chosen.rss / after.chosen.n):.0f} noise "
        "deviations off, and every run's effort is measured and replayed open loop: the "
        "replay cannot judge the structures (it diverges whatever the parameters); they "
        "are compared on the effort equation, and its estimate is the result"]
    path, screened = effort_search(problem, log, max_effects, dict(after.screened))
    nominal = after.nominal
    chosen = as_fit(problem, nominal, screened[_key(path[-1])]) if path else nominal
    screen_ref = _n_ref(screened.values())
    return Selection(nominal, chosen, [nominal], after.n_ref,
                     sorted(screened.items(), key=lambda kv: kv[1].bic(screen_ref)),
                     screen_ref, log, by=EFFORT_ONLY)


def as_fit(problem: Problem, nominal: Fit, ef: EquationFit) -> Fit:
    """An effort-equation fit as the result: its structure, values and covariance, its
    residual the effort's (in effort-noise deviations), the initial states and replays the
    nominal fit's (nothing was replayed)."""
    d = design(problem, ef.effects)
    coef = np.concatenate([[coefficients(e, {p.name: ef.values[p.key] for p in e.params})[n]
                            for n in e.coefficient_names] for e in ef.effects]) \
        if d.columns else np.zeros(0)
    residual = (d.y - d.x @ coef) / d.noise
    halfwidth = {k: ef.halfwidth(k) for k in ef.values}
    return dataclasses.replace(
        nominal, effects=ef.effects, values=dict(ef.values), halfwidth=halfwidth,
        cov=dict(ef.cov), identifiable={k: math.isfinite(h) for k, h in halfwidth.items()},
        correlated={}, residual=residual, rss=float(residual @ residual),
        n_eff=ef.n_eff, k=ef.k, start=ef, material=dict(ef.material), refined=False)
