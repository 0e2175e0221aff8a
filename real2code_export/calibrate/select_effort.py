"""Model selection on the effort equation, where the measured effort tells the causes
apart better than the replay does: a declared closed loop whose effort is recorded clean.
A stiff loop holds the position to its reference whatever the plant, so its replay barely
moves with the causes, while the recorded effort is what the loop spent on them (the
inverse-dynamics identification of the robotics literature and of the EMPS benchmark).
The structures are compared on the equation error; only the chosen one and the one before
it are replayed (each closed-loop replay steps the law sample by sample).
"""

from __future__ import annotations

from . import features
from .effects import Effect
from .fit import DEGENERATE, MATERIAL, Fit, fit_candidate, refine_fit
from .inverse import EquationFit, equation_fit
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
        gain = features.smoothing_gain(tr.sample_period)
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


def effort_search(problem: Problem, log: list[str], max_effects: int = MAX_EFFECTS
                  ) -> tuple[list[tuple[Effect, ...]], dict[tuple[str, ...], EquationFit]]:
    """The stepwise search of :func:`select_by_effort`: the structure kept at each step
    (the last is the chosen one), and every structure scored."""
    screened: dict[tuple[str, ...], EquationFit] = {(): equation_fit(problem, ())}
    current: tuple[Effect, ...] = ()
    path: list[tuple[Effect, ...]] = []
    while len(current) < max_effects:
        proposals = [p for p in _proposals(problem, current) if _key(p) not in screened]
        for p in proposals:
            screened[_key(p)] = equation_fit(problem, p)
        n_ref = _n_ref(screened.values())
        here = screened[_key(current)]
        kept = None
        for p in sorted(proposals, key=lambda p: screened[_key(p)].bic(n_ref)):
            ef = screened[_key(p)]
            label = "+".join(ef.names)
            if ef.bic(n_ref) >= here.bic(n_ref):
                break
            if ef.degenerate(DEGENERATE):
                log.append(f"tried {label}: BIC {ef.bic(n_ref):.1f}, two effects explain "
                           "the same thing")
            elif all(ef.present(e, MATERIAL) for e in ef.effects):
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
