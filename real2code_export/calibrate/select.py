"""Model selection: which effects the data call for.

Forward stepwise search from the nominal model: at each step every structure one effect
richer (or friction refined into direction-dependent friction) is scored by the cheap
inverse-dynamics fit, the most promising are fitted by simulation, and the best is kept if
its BIC beats the current model's and every one of its effects is really there (its 95 %
interval, widened for residual correlation, excludes absence). BIC counts the effective
samples of the best-fitting residual so far (a correlated residual carries less evidence
than its length), the same count for every candidate compared, so extra parameters must
pay for themselves. Extensions that each lower the BIC without being significant alone
are tried together. A structure with an effect that is not there beside the others is
tried without it (the search only adds: a refinement may make an earlier effect redundant);
where no structure of a step passes, the best is fitted once more from its own
inverse-dynamics start (from the current model's values it may stop in that model's
minimum), and the next best-screened are fitted too, those the screen prefers to the
current model. A structure with an end stop is started from the same structure without
it (and, where that does not pay, from its own inverse-dynamics start) and fitted on only
if the stop pays for itself within a few evaluations (each replay of a stop steps through
its impacts). An effect whose interval reaches
absence is still there where the structure fitted without it is worse by BIC and it
explains materially more than that structure. The search
stops when no extension earns its parameters: nothing is forced onto
the data; and where no structure's replay follows every run (a person moves the joint),
since the output error then measures a divergence, not an effect (first the next
best-screened are looked at, and where the closest takes up half the miss, its
extensions, then those looked at with a stop seen in the data: two effects may be needed
before a replay follows). Direction-dependent friction found not there gives way to its
symmetric counterpart (damping, friction, a constant force), not to nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .effects import Effect, extensions, valid
from .fit import MATERIAL, Fit, fit_candidate, refine_fit
from .inverse import EquationFit, equation_fit
from .problem import Problem
from .residuals import noise_floor

SCREEN_TOP = 2  # structures per step fitted by simulation (after the inverse-dynamics screen)
# ... and where the screen is blind (it prefers no effect to the nominal model: a loop's
# effort computed from noisy positions says nothing of the plant), up to this many,
# best-screened first, at every step: the replay has to tell. (Later in a search the
# screen may prefer no extension of what the replay chose; that is no sign of blindness.)
SCREEN_BLIND = 6
MAX_EFFECTS = 4
# Where the current model's replay does not follow the data (:func:`_follows`), each
# structure of the step is first fitted with this many evaluations: enough to see whether
# its replay comes back onto the data; only one that does (or, where none does, the
# closest) is fitted to the end.
LOOK_NFEV = 4


@dataclass
class Selection:
    nominal: Fit
    chosen: Fit
    fitted: list[Fit]
    n_ref: float  # effective samples every BIC counts
    screened: list[tuple[tuple[str, ...], EquationFit]] = field(default_factory=list)
    screen_n_ref: float = 0.0
    log: list[str] = field(default_factory=list)
    # "simulation": structures compared by their replays; "effort equation": by the
    # inverse dynamics on the measured effort (select_effort.py), the chosen one replayed
    by: str = "simulation"


def _key(effects: tuple[Effect, ...]) -> tuple[str, ...]:
    return tuple(sorted(f"{e.joint}:{e.variant}" for e in effects))


def _proposals(problem: Problem, current: tuple[Effect, ...]) -> list[tuple[Effect, ...]]:
    """Structures one effect richer than ``current``: one effect added, or one swapped and
    one added (a greedy first choice must not lock the search: a spring can stand in for
    an offset early on and exclude it later)."""
    out: list[tuple[Effect, ...]] = []
    seen: set[tuple[str, ...]] = set()
    for joint in problem.joints:
        mine = tuple(sorted(e.variant for e in current if e.joint == joint))
        others = tuple(e for e in current if e.joint != joint)
        lib = problem.effects[joint]
        names_list = list(extensions(mine, list(lib)))
        for drop in mine:
            rest = tuple(n for n in mine if n != drop)
            for first in extensions(rest, list(lib)):
                for second in extensions(first, list(lib)):
                    if len(second) == len(mine) + 1 and drop not in second:
                        names_list.append(second)
        for names in names_list:
            key = tuple(sorted(f"{joint}:{n}" for n in names))
            if key in seen:
                continue
            seen.add(key)
            out.append(others + tuple(lib[n] for n in names))
    return out


def _nothing_left(fit: Fit) -> bool:
    """Whether the residual is so close to the sensor noise that no further effect could
    move the motion by MATERIAL noise deviations (what it explains adds in quadrature)."""
    return _within_noise(fit.rss, fit.n)


def _within_noise(rss: float, n: int) -> bool:
    return rss / n < 1.0 + 0.8 * MATERIAL**2


def _follows(problem: Problem, fit: Fit) -> bool:
    """Whether the replay follows the data at all: on every run it predicts the measured
    motion better than the run's mean does (R^2 > 0), or within the sensor noise. A
    replay that does worse on a run has left it (a person moves the joint, or the model
    misses more than any candidate holds); the least squares of its output error then
    reads that divergence, not an effect. (Each run on its own: their noise levels, and so
    their weights in the residual, can differ by orders of magnitude.)"""
    ev = fit.solution.ev
    for t, tr in enumerate(problem.trajectories):
        r = fit.residual[ev.offsets[t]:ev.offsets[t + 1]]
        rss = float(r @ r)
        spread = 0.0
        for k, j in enumerate(problem.joints):
            q = tr.positions[j]
            sigma = noise_floor(problem.position_noise[t][k], q)
            spread += float(np.sum(((q - q.mean()) / sigma) ** 2))
        if rss >= spread and not _within_noise(rss, r.size):
            return False
    return True


def _refine_friction(problem: Problem, current: Fit, fits: dict, log: list[str]) -> Fit:
    """Symmetric friction with an offset (or with damping) may be direction-dependent
    friction seen in part: direction dependence is tried as a refinement even when the
    residual is already near the noise, and kept if BIC prefers it (one effect with its
    four values in place of two or three)."""
    names = {e.name for e in current.effects}
    if not names & {"friction", "damping"} or "asymmetric_friction" in names:
        return current
    candidates = [p for p in _proposals(problem, current.effects)
                  if any(e.name == "asymmetric_friction" for e in p)
                  and len(p) <= len(current.effects)]
    warm = _warm_start(current)
    best = current
    for p in candidates:
        # (re)fitted from the current model's values: a refinement tried earlier, from a
        # poorer model, may have stopped in another minimum
        f = fit_candidate(problem, p, refine=False, warm=warm)
        if _key(p) in fits and fits[_key(p)].rss <= f.rss:
            f = fits[_key(p)]  # the earlier fit stopped in the better minimum
        fits[_key(p)] = f
        n_ref = _n_ref(fits.values())
        if f.bic(n_ref) < best.bic(n_ref):
            f = refine_fit(f)
            fits[_key(p)] = f
            # what only the direction dependence explains: the symmetric model refitted
            # takes up the rest (its linearised motion change, the others held, does not)
            gained = _explained(problem, current, f)
            if gained < MATERIAL:
                log.append(f"{'+'.join(f.names)} refines {'+'.join(current.names)} by "
                           f"{gained:.2f} noise deviations: not material")
            elif all(f.present(e) for e in f.effects) and not f.degenerate():
                log.append(f"refined {'+'.join(current.names)} into {'+'.join(f.names)}: "
                           f"BIC {f.bic(n_ref):.1f}")
                best = f
            elif not f.degenerate():
                best = _without_absent(problem, f, best, fits, log) or best
    return best


def _without_absent(problem: Problem, f: Fit, current: Fit, fits: dict,
                    log: list[str]) -> Fit | None:
    """A structure with an effect that is not there beside the others may be right without
    it (an encoder's zero error tried beside direction-dependent friction, whose Coulomb
    asymmetry holds the same constant force): the structure less its absent effects,
    fitted from ``f``'s values, kept if its BIC beats ``current``'s and all its effects are
    there, or else, where one of its own is not there, less that one too. (A structure is
    never reached otherwise: the search only adds.)"""
    rest = tuple(e for e in f.effects if _there(f, e, fits, _n_ref(fits.values())))
    warm = dict(f.values)
    for e in f.effects:
        if e.name == "asymmetric_friction" and e not in rest:
            # its absence is symmetric friction, not no friction: what it refines (damping,
            # friction, and the Coulomb asymmetry's constant force where nothing else holds
            # one) takes its place, from its values
            rest += _symmetric_counterpart(problem, e, rest, warm)
    if not rest or len(rest) == len(f.effects) and all(e in f.effects for e in rest) \
            or _key(rest) == _key(current.effects):
        return None
    earlier = fits.get(_key(rest))
    if earlier is not None and earlier.bic(_n_ref(fits.values())) < current.bic(
            _n_ref(fits.values())):
        return None  # already tried on its merits
    # (re)fitted from the richer fit's values: fitted earlier from a poorer model, it may
    # have stopped in another minimum (a spring's rest position far from the data's)
    g = fit_candidate(problem, rest, refine=False, warm=warm)
    if earlier is not None and earlier.rss <= g.rss:
        return None
    fits[_key(rest)] = g
    n_ref = _n_ref(fits.values())
    if g.bic(n_ref) >= current.bic(n_ref):
        log.append(f"tried {'+'.join(g.names)} (less what was not there): "
                   f"BIC {g.bic(n_ref):.1f}, no better")
        return None
    g = refine_fit(g)
    fits[_key(rest)] = g
    if g.degenerate() or not all(g.present(e) for e in g.effects):
        log.append(f"tried {'+'.join(g.names)} (less what was not there): "
                   f"BIC {g.bic(n_ref):.1f}, an effect not significant")
        # less what is not there beside the others in it too: direction-dependent friction
        # given way to damping, friction and a constant force where no force is (a lid
        # let go at rest), the force's absence is the true damping and friction
        return None if g.degenerate() else _without_absent(problem, g, current, fits, log)
    log.append(f"tried {'+'.join(g.names)} (less what was not there): BIC {g.bic(n_ref):.1f}")
    return _force_earned(problem, g, f, fits, log)


def _force_earned(problem: Problem, g: Fit, f: Fit, fits: dict, log: list[str]) -> Fit:
    """The constant force a symmetric counterpart brought in (:func:`_without_absent`, not
    in ``f``) must earn its parameter like any effect: on a joint that moves one way
    friction and a constant force are one column but where it rests (a door let go:
    friction 1.30 and a force of -0.77 N m for the true 0.52 N m of friction), so the
    counterpart without it is fitted too (from ``g``'s values and from its own
    inverse-dynamics start) and kept where BIC prefers it and its effects are there."""
    forces = [e for e in g.effects if e.name == "offset" and e not in f.effects]
    if not forces:
        return g
    plain = tuple(e for e in g.effects if e not in forces)
    if not plain or _key(plain) in fits:
        return g
    h = min((fit_candidate(problem, plain, refine=False, warm=dict(g.values)),
             fit_candidate(problem, plain, refine=False)), key=lambda x: x.rss)
    fits[_key(plain)] = h
    n_ref = _n_ref(fits.values())
    if h.bic(n_ref) >= g.bic(n_ref):
        log.append(f"tried {'+'.join(h.names)} (its force left out): BIC {h.bic(n_ref):.1f}, "
                   "no better")
        return g
    h = refine_fit(h)
    fits[_key(plain)] = h
    if h.degenerate() or not all(h.present(e) for e in h.effects):
        log.append(f"tried {'+'.join(h.names)} (its force left out): BIC {h.bic(n_ref):.1f}, "
                   "an effect not significant")
        return g
    log.append(f"tried {'+'.join(h.names)} (its force left out): BIC {h.bic(n_ref):.1f}")
    return h


def _symmetric_counterpart(problem: Problem, e: Effect, rest: tuple[Effect, ...],
                           warm: dict[str, float]) -> tuple[Effect, ...]:
    """The symmetric effects direction-dependent friction ``e`` refines (damping, friction,
    a constant force), those that go beside ``rest``; their start values, the means and
    the Coulomb asymmetry of ``e``'s, written into ``warm``."""
    j, lib = e.joint, problem.effects[e.joint]
    cp, cn = warm[f"{j}.friction_pos"], warm[f"{j}.friction_neg"]
    bp, bn = warm[f"{j}.damping_pos"], warm[f"{j}.damping_neg"]
    start = {"friction": 0.5 * (cp + cn), "offset": 0.5 * (cn - cp),
             "damping": 0.5 * (bp + bn)}
    have = {x.variant for x in rest if x.joint == j}
    out = []
    for name in ("damping", "friction", "offset"):
        if name in lib and valid(have | {name}):
            have.add(name)
            out.append(lib[name])
            warm.setdefault(f"{j}.{name}", start[name])
    return tuple(out)


def _try_aliases(problem: Problem, kept: Fit, fits: dict, log: list[str]) -> Fit:
    """An effect the data can hardly tell from another (a constant force and an encoder's
    zero error) may have won the cheap screen by a hair: its alias is fitted by simulation
    too, and the better of the two by BIC kept. So is the simpler effect one reduces to
    where its extra parameters are found absent (:func:`_reduced`)."""
    best = kept
    for e in kept.effects:
        lib = problem.effects[e.joint]
        for alias in (*e.aliases, *_reduced(kept, e, lib)):
            if alias not in lib:
                continue
            swapped = tuple(x for x in kept.effects if x is not e) + (lib[alias],)
            if _key(swapped) in fits:
                f = fits[_key(swapped)]
            else:
                f = fit_candidate(problem, swapped, refine=False, warm=dict(kept.values))
                fits[_key(swapped)] = f
            n_ref = _n_ref(fits.values())
            if f.bic(n_ref) < best.bic(n_ref):
                f = refine_fit(f)
                fits[_key(swapped)] = f
                if all(f.present(x) for x in f.effects) and not f.degenerate():
                    log.append(f"tried {'+'.join(f.names)} in place of "
                               f"{'+'.join(kept.names)}: BIC {f.bic(n_ref):.1f}, better")
                    best = f
                    continue
            log.append(f"tried {'+'.join(f.names)} in place of {'+'.join(kept.names)}: "
                       f"BIC {f.bic(n_ref):.1f}, no better")
    return best


def _slope_earned(problem: Problem, kept: Fit, fits: dict, log: list[str]) -> Fit:
    """A spring is a constant force plus a slope over the positions the runs visit: where
    the same structure with a constant force in its place (fitted, all its effects there)
    leaves the motion within MATERIAL noise deviations of the spring's fit, the slope is
    not material and the constant force is kept, one parameter fewer (a loop that moves a
    drawer little, or holds it: what its process noise lends a slope is no spring). Judged
    on the motion only: a declared loop's effort is the law's output on the same noisy
    positions, and its misfit in the effort sensor's noise counts the position's misfit
    again, amplified by the loop's gain."""
    best = kept
    for e in kept.effects:
        lib = problem.effects[e.joint]
        if e.name != "spring" or "offset" not in lib or any(
                x.joint == e.joint and x.name == "offset" for x in best.effects):
            continue
        swapped = tuple(x for x in best.effects if x is not e) + (lib["offset"],)
        f = fits.get(_key(swapped))
        if f is None:
            f = fit_candidate(problem, swapped, refine=False, warm=dict(best.values))
            fits[_key(swapped)] = f
        gained = math.sqrt(max(f.rss - best.rss, 0.0) / best.n)
        if gained >= MATERIAL:
            continue
        f = refine_fit(f)
        fits[_key(swapped)] = f
        n_ref = _n_ref(fits.values())
        if f.degenerate() or not all(_there(f, x, fits, n_ref) for x in f.effects):
            continue
        log.append(f"the spring of {'+'.join(best.names)} explains {gained:.2f} noise "
                   f"deviations of the motion beyond a constant force ({'+'.join(f.names)}, "
                   "refitted): its slope is not material, the constant force kept")
        best = f
    return best


def _reduced(f: Fit, e: Effect, lib: dict) -> tuple[str, ...]:
    """The simpler effect ``e`` of fit ``f`` is where its extra parameters are found
    absent: inertia that leaves the first moment as it was (its mass scale within its
    95 % interval of 1) is inertia about the axis alone, which on a joint that may hold a
    rotor (armature offered: the model declares an actuator or the effort is measured) is
    the rotor's armature, one parameter fewer (a driven lid's rotor read as its parts'
    rotational inertia x3.3)."""
    if e.name != "inertia" or "armature" not in lib or "armature" in e.aliases:
        return ()
    key = f"{e.joint}.inertia_scale"
    if key not in f.values or abs(f.values[key] - 1.0) > f.halfwidth.get(key, math.inf):
        return ()
    return ("armature",)


def _together(problem: Problem, current: Fit, near: list[Fit], fits: dict,
              screened: dict, log: list[str]) -> Fit | None:
    """Two effects at once, from extensions that lowered the BIC with an effect not
    significant: the union of the two best, and the best-screened extension of the best;
    kept if its BIC beats the current model's and both effects are there."""
    if not near:
        return None
    pairs = []
    richer = _proposals(problem, near[0].effects)
    if len(near) > 1:
        union = set(_key(near[0].effects)) | set(_key(near[1].effects))
        pairs += [p for p in richer if set(_key(p)) == union]
    for p in richer:
        if _key(p) not in screened:
            screened[_key(p)] = equation_fit(problem, p)
    screen_ref = _n_ref(screened.values())
    pairs += sorted((p for p in richer if p not in pairs),
                    key=lambda p: screened[_key(p)].bic(screen_ref))[:1]
    warm = _warm_start(near[0])
    best = None
    for p in pairs:
        if _key(p) in fits:
            continue
        f = fit_candidate(problem, p, refine=False, warm=warm)
        fits[_key(p)] = f
        n_ref = _n_ref(fits.values())
        if f.bic(n_ref) >= current.bic(n_ref):
            log.append(f"tried {'+'.join(f.names)} together: BIC {f.bic(n_ref):.1f}, no better")
            continue
        f = refine_fit(f)
        fits[_key(p)] = f
        if f.degenerate() or not all(f.present(e) for e in f.effects):
            log.append(f"tried {'+'.join(f.names)} together: BIC {f.bic(n_ref):.1f}, "
                       "an effect not significant")
            f = None if f.degenerate() else _without_absent(problem, f, current, fits, log)
            if f is None:
                continue
            n_ref = _n_ref(fits.values())
        log.append(f"tried {'+'.join(f.names)} together: BIC {f.bic(n_ref):.1f}")
        if best is None or f.bic(n_ref) < best.bic(n_ref):
            best = f
    return best


def _with_stop(problem: Problem, p: tuple[Effect, ...], base: Fit, warm: dict[str, float],
               fits: dict, log: list[str]) -> Fit:
    """Structure ``p``, ``base`` with a stop: started from ``base``'s values (the stop at
    the edge of the data changes its replay little at first) and looked at for LOOK_NFEV
    evaluations, and where that does not pay, from its own inverse-dynamics start (the
    samples at the stop left out): a replay without the stop bends its values to stand in
    for it (direction-dependent friction that halts the door where the stop does), and a
    look from them starts in that model's valley. Fitted to the end only if the stop
    already pays for its parameters by BIC there. A stop the data show explains its
    impacts at once; one they do not show costs a dozen fits of a structure without it to
    find so (each replay steps through the impacts with the stop's softness from a
    grid)."""
    look = None
    for start in ({**warm, **base.values}, None):
        other = fit_candidate(problem, p, refine=False, warm=start, max_nfev=LOOK_NFEV,
                              second_start=False)
        look = other if look is None or other.rss < look.rss else look
        n_ref = _n_ref([*fits.values(), look])
        if look.bic(n_ref) < base.bic(n_ref):
            return fit_candidate(problem, p, refine=False, warm=dict(look.values))
    log.append(f"{'+'.join(look.names)}: the stop does not pay within {LOOK_NFEV} "
               f"evaluations from {'+'.join(base.names) or 'the nominal model'} or from its "
               "own start, not fitted on")
    return look


def _closest_extended(problem: Problem, closest: Fit, fits: dict, screened: dict,
                      log: list[str]) -> list[Fit]:
    """Where no replay follows the data: the SCREEN_TOP best-screened structures that add
    one effect to the closest (no stop), each looked at from its values and fitted to the end
    if its replay comes back onto the data, up to the first that does."""
    richer = [p for p in _proposals(problem, closest.effects)
              if _key(p) not in fits and all(e.name != "limit" for e in p)
              and set(_key(closest.effects)) < set(_key(p))
              and len(p) == len(closest.effects) + 1]
    for p in richer:
        if _key(p) not in screened:
            screened[_key(p)] = equation_fit(problem, p)
    screen_ref = _n_ref(screened.values())
    ranked = sorted(richer, key=lambda p: screened[_key(p)].bic(screen_ref))[:SCREEN_TOP]
    return _look_until_one_follows(problem, ranked, dict(closest.values), fits, log,
                                   f"from the closest, {'+'.join(closest.names)}")


def _stops_added(problem: Problem, looked: list[Fit], fits: dict, log: list[str]
                 ) -> list[Fit]:
    """Where no replay follows the data and a stop is seen in them: the stop-free structures
    looked at, closest first, each with the stop (up to SCREEN_BLIND not yet tried), looked
    at from its values up to the first that follows. While the stop is not
    modelled every replay misses its impacts, and one with the stop follows only where its
    other effects are right too (a drawer's spring and its stop): two effects needed
    together, one of them the stop, which the screen cannot rank (its impacts are left
    out of the inverse dynamics)."""
    pairs: list[tuple[tuple[Effect, ...], Fit]] = []  # (structure, the look it extends)
    for f in sorted((f for f in looked if all(e.name != "limit" for e in f.effects)),
                    key=lambda f: f.rss):
        for joint in problem.joints:
            for stop in (e for e in problem.effects[joint].values() if e.name == "limit"):
                p = (*f.effects, stop)
                if _key(p) not in fits and _key(p) not in {_key(q) for q, _ in pairs} \
                        and valid({x.variant for x in p if x.joint == joint}):
                    pairs.append((p, f))
    out: list[Fit] = []
    for p, f in pairs[:SCREEN_BLIND]:
        out += _look_until_one_follows(problem, [p], dict(f.values), fits, log,
                                       "with the stop seen in the data")
        if _follows(problem, out[-1]):
            break
    return out


def _look_until_one_follows(problem: Problem, structures: list, warm: dict[str, float],
                            fits: dict, log: list[str], why: str) -> list[Fit]:
    """Each structure looked at (LOOK_NFEV evaluations from ``warm``) in turn, the first
    whose replay comes back onto the data fitted to the end; the fits, in order."""
    out = []
    for p in structures:
        f = fit_candidate(problem, p, refine=False, warm=warm, max_nfev=LOOK_NFEV,
                          second_start=False)
        follows = _follows(problem, f)
        if follows:
            f = fit_candidate(problem, p, refine=False, warm=dict(f.values))
        fits[_key(p)] = f
        out.append(f)
        log.append(f"{'+'.join(f.names)} looked at {why}: "
                   f"{'follows' if follows else 'off the data'}")
        if follows:
            break
    return out


def _warm_start(current: Fit) -> dict[str, float]:
    """Start values from the current model: its parameters, and direction-dependent
    friction started from the symmetric friction it refines. (Initial states start from
    the data: a poor current model may have bent them to hide its error.)"""
    warm = dict(current.values)
    for e in current.effects:
        j = e.joint
        c = current.values.get(f"{j}.friction", e.ctx.dynamics.friction)
        b = current.values.get(f"{j}.damping", e.ctx.dynamics.damping)
        o = current.values.get(f"{j}.offset", 0.0)
        # the offset becomes the Coulomb asymmetry: constant = offset - (c+ - c-) / 2
        warm.setdefault(f"{j}.friction_pos", max(c - o, 0.0))
        warm.setdefault(f"{j}.friction_neg", max(c + o, 0.0))
        warm.setdefault(f"{j}.damping_pos", b)
        warm.setdefault(f"{j}.damping_neg", b)
    return warm


def _n_ref(fits) -> float:
    best = min(fits, key=lambda f: f.rss)
    return best.n_eff


def _judge(problem: Problem, f: Fit, current: Fit, fits: dict, n_ref: float,
           log: list[str]) -> Fit | None:
    """``f`` (refined) if it beats ``current`` by BIC with all its effects there and none
    two of the same thing; else, where an effect is not there, the structure without it
    (:func:`_without_absent`); else None."""
    if f.bic(n_ref) >= current.bic(n_ref):
        log.append(f"tried {'+'.join(f.names)}: BIC {f.bic(n_ref):.1f}, no better")
        return None
    f = refine_fit(f)
    fits[_key(f.effects)] = f
    if f.degenerate():
        log.append(f"tried {'+'.join(f.names)}: BIC {f.bic(n_ref):.1f}, two effects "
                   "explain the same thing")
        return None
    if all(_there(f, e, fits, n_ref) for e in f.effects):
        rescued = [e.name for e in f.effects if not f.present(e)]
        log.append(f"tried {'+'.join(f.names)}: BIC {f.bic(n_ref):.1f}" + (
            f" ({', '.join(rescued)}: the 95 % interval reaches absence, but the structure "
            "fitted without it is worse by BIC)" if rescued else ""))
        return f
    log.append(f"tried {'+'.join(f.names)}: BIC {f.bic(n_ref):.1f}, an effect not significant")
    return _without_absent(problem, f, current, fits, log)


def _there(f: Fit, e: Effect, fits: dict, n_ref: float) -> bool:
    """Whether effect ``e`` of fit ``f`` is there: its 95 % interval excludes absence
    (:meth:`Fit.present`), or, where that linearised interval reaches absence, the
    structure without it, fitted by itself, is worse by BIC (the likelihood ratio). The
    interval is the residual's linear picture, blind to the bounds and to a valley's
    curve: an encoder's zero error on a lid trades against the Coulomb asymmetry of
    direction-dependent friction, its interval reaches zero, and yet without it the
    friction alone leaves the data far behind. Either way the effect must move the motion
    materially; where the likelihood ratio decides, by what it explains beyond the
    structure refitted without it, sqrt((rss_without - rss) / n), as the refinement into
    direction-dependent friction is judged: its linearised motion change (the others
    held) overstates it where the others take up most of what it does (a lag of a
    millisecond beside dry friction and a spring on a drifting open-loop replay: 2.3 noise
    deviations held, 0.94 refitted).
    (Direction-dependent friction's absence is symmetric friction, not no friction: only
    its interval judges it.)"""
    if f.present(e):
        return True
    if e.name == "asymmetric_friction" or f.material.get(e.name, math.inf) < MATERIAL:
        return False
    rest = tuple(x for x in f.effects if x is not e)
    without = fits.get(_key(rest))
    if without is None or without.bic(n_ref) <= f.bic(n_ref):
        return False
    # fitted earlier from a poorer model's values, the structure without it may sit in
    # another minimum (seed 55: a spring and inertia 8.3 noise deviations off the data,
    # 1.0 from the values of the fit with an encoder's zero error beside them): refitted
    # from this fit's values, the better of the two kept
    again = fit_candidate(f.solution.problem, rest, refine=False, warm=dict(f.values))
    if again.rss < without.rss:
        fits[_key(rest)] = without = again
        if without.bic(n_ref) <= f.bic(n_ref):
            return False
    return _explained(f.solution.problem, without, f) >= MATERIAL


def _effort_rss(problem: Problem, fit: Fit) -> tuple[float, int]:
    """The replay's misfit of a declared loop's measured effort, in the effort sensor's
    noise (squares summed, samples): (0, 0) where no run is a measured loop."""
    total, count = 0.0, 0
    for t, tr in enumerate(problem.trajectories):
        if tr.law() is None or not problem.effort_sensor_noise or t >= len(fit.simulated):
            continue
        for k, j in enumerate(problem.joints):
            sigma = float(problem.effort_sensor_noise[t][k])
            if j not in tr.efforts or not sigma > 0:
                continue
            d = (fit.simulated[t].efforts[:, k] - tr.efforts[j]) / sigma
            total += float(d @ d)
            count += d.size
    return total, count


def _explained(problem: Problem, without: Fit, f: Fit) -> float:
    """What ``f`` explains beyond ``without`` (a structure with less, refitted), in noise
    deviations: of the motion, or of a declared loop's measured effort where that is more
    (each in its own sensor's noise: a loop holds the motion, and what an effect does
    shows in the effort it takes)."""
    gained = math.sqrt(max(without.rss - f.rss, 0.0) / f.n)
    (e0, n), (e1, _) = _effort_rss(problem, without), _effort_rss(problem, f)
    return max(gained, math.sqrt(max(e0 - e1, 0.0) / n)) if n else gained


def select(problem: Problem, screen_top: int = SCREEN_TOP,
           max_effects: int = MAX_EFFECTS) -> Selection:
    nominal = fit_candidate(problem, ())
    fits: dict[tuple[str, ...], Fit] = {(): nominal}
    screened: dict[tuple[str, ...], EquationFit] = {}
    log = []
    current = nominal
    blind: bool | None = None  # the screen tells nothing (judged at the first step)
    if _nothing_left(nominal):
        log.append(f"residual {math.sqrt(nominal.rss / nominal.n):.2f} x noise: the nominal "
                   "model explains the data")
    while len(current.effects) < max_effects and not _nothing_left(current):
        proposals = [p for p in _proposals(problem, current.effects) if _key(p) not in fits]
        if not proposals:
            break
        for p in proposals:
            if _key(p) not in screened:
                screened[_key(p)] = equation_fit(problem, p)
        screen_ref = _n_ref(screened.values())
        scored = sorted(proposals, key=lambda p: screened[_key(p)].bic(screen_ref))
        if blind is None:  # judged once, on the nominal model's extensions
            screened[()] = equation_fit(problem, ())
            screen_ref = _n_ref(screened.values())
            blind = screened[_key(scored[0])].bic(screen_ref) >= screened[()].bic(screen_ref)
            if blind:
                log.append("the equation error prefers no effect to the nominal model: the "
                           f"replay decides among the {SCREEN_BLIND} best-screened at each step")
        # Structures with an end stop cannot be scored by the inverse dynamics (it leaves
        # the impacts out), and while a detected stop is not modelled every other
        # structure misses it: fit the best-screened ones with and without the stop, and
        # the current model with each stop. (Not every structure one richer with a stop:
        # one that swaps an effect and adds a stop makes two changes at once, and is
        # reached in two steps if the stop is there; each stop fit costs ten others.)
        has_stop = any(e.name == "limit" for e in current.effects)
        with_stop = [] if has_stop else [p for p in scored if any(e.name == "limit" for e in p)]
        chosen = [p for p in scored if p not in with_stop][:SCREEN_BLIND if blind
                                                            else screen_top]
        for without in chosen[:1] + [current.effects]:  # each with each possible stop
            chosen += [q for q in with_stop if set(_key(without)) <= set(_key(q))
                       and len(q) == len(without) + 1 and q not in chosen]
        new = []
        warm = _warm_start(current)
        lost = not _follows(problem, current)
        for p in chosen:
            base = None if lost else fits.get(_key(tuple(e for e in p if e.name != "limit")))
            if base is not None and len(base.effects) < len(p):
                f = _with_stop(problem, p, base, warm, fits, log)
            else:
                f = fit_candidate(problem, p, refine=False, warm=warm,
                                  **({"max_nfev": LOOK_NFEV, "second_start": False}
                                     if lost else {}))
            if lost:
                follows = _follows(problem, f)
                log.append(f"{'+'.join(f.names)} looked at: "
                           f"{'follows' if follows else 'off the data'}")
                if follows:  # back on the data: fitted to the end
                    f = fit_candidate(problem, p, refine=False, warm=dict(f.values))
            fits[_key(p)] = f
            new.append(f)
        if lost and new and not any(_follows(problem, f) for f in new):
            # the screen's best may all stay off the data where another effect brings the
            # replay back (an encoder's zero error on a lid ranked above the dry friction
            # that holds it): the next best-screened are looked at too, up to the first
            # that follows
            more = [p for p in scored if p not in with_stop and _key(p) not in fits][
                :max(SCREEN_BLIND - len(chosen), 0)]
            new += _look_until_one_follows(problem, more, warm, fits, log,
                                           "too (the best-screened all stay off the data)")
        if lost and new and not any(_follows(problem, f) for f in new):
            # four evaluations may not have been enough: the closest look to the end
            best = min(new, key=lambda f: f.rss)
            f = fit_candidate(problem, best.effects, refine=False, warm=dict(best.values))
            fits[_key(f.effects)] = new[new.index(best)] = f
            if not _follows(problem, f) and f.rss <= 0.5 * current.rss:
                # two effects may be needed together (a constant force and damping on an
                # open-loop integrator): where the closest takes up at least half of the
                # current model's miss, its best-screened extensions are looked at from its
                # values (where none does, a person moves the joint more likely than not)
                new += _closest_extended(problem, f, fits, screened, log)
                if not any(_follows(problem, g) for g in new):
                    new += _stops_added(problem, new, fits, log)
        n_ref = _n_ref(fits.values())
        if lost and not any(_follows(problem, f) for f in new):
            log.append("no replay follows the data (each predicts a run worse than the "
                       "run's mean): an unmeasured force drives the joint, or the model "
                       "misses more than any candidate holds; the search stops")
            break
        kept = None
        # best BIC first; each is refined (its numerical error measured) before its
        # effects are tested, and the first that passes is kept
        for f in sorted(new, key=lambda f: f.bic(n_ref)):
            kept = _judge(problem, f, current, fits, n_ref, log)
            if kept is not None:
                break
        linear = [f for f in new if all(e.name != "limit" for e in f.effects)]
        if kept is None and linear:
            # the best of them, fitted from the current model's values, may have stopped in
            # that model's minimum (a spring stiffened to stand in for a lighter lid): once
            # more from its own inverse-dynamics start, the better kept (a stop has no such
            # start: the equation error leaves its impacts out)
            f = min(linear, key=lambda f: f.bic(n_ref))
            g = fit_candidate(problem, f.effects, refine=False)
            if g.rss < f.rss:
                fits[_key(g.effects)] = g
                new[new.index(f)] = g
                n_ref = _n_ref(fits.values())
                log.append(f"{'+'.join(g.names)} again from its inverse-dynamics start")
                kept = _judge(problem, g, current, fits, n_ref, log)
        if kept is None and not blind:
            # the screen's best may all miss where the residual is far above the noise (a
            # damping the equation error ranks below two offsets whose own replays stay
            # where the nominal one was): the next best-screened are fitted too, as where
            # the screen is blind, before the search gives up on this step; only those the
            # screen prefers to the current model (the rest the screen itself rejects)
            here = _key(current.effects)
            if here not in screened:
                screened[here] = equation_fit(problem, current.effects)
            screen_ref = _n_ref(screened.values())
            more = [p for p in scored if p not in with_stop and _key(p) not in fits
                    and screened[_key(p)].bic(screen_ref) < screened[here].bic(screen_ref)]
            for p in more[:SCREEN_BLIND - screen_top]:
                f = fit_candidate(problem, p, refine=False, warm=warm,
                                  **({"max_nfev": LOOK_NFEV, "second_start": False}
                                     if lost else {}))
                if lost and _follows(problem, f):
                    f = fit_candidate(problem, p, refine=False, warm=dict(f.values))
                fits[_key(p)] = f
                new.append(f)
                n_ref = _n_ref(fits.values())
                kept = _judge(problem, f, current, fits, n_ref, log)
                if kept is not None:
                    break
        if kept is None:
            # effects that each lower the BIC but are not significant alone may be two
            # that stand in for each other (friction and inertia both slow a push): their
            # union, and the best-screened extension of the best of them, are tried
            near = sorted((f for f in new if f.bic(n_ref) < current.bic(n_ref)),
                          key=lambda f: f.bic(n_ref))
            kept = _together(problem, current, near, fits, screened, log)
        again = fits.get(_key(current.effects))
        if kept is None and again is not None and again.rss < current.rss:
            # refitted while a richer structure was judged (:func:`_there`), the current
            # structure found a better minimum: kept as it now fits, and the search goes on
            # from there
            log.append(f"{'+'.join(current.names)} refitted from a richer fit's values: "
                       f"residual {math.sqrt(current.rss / current.n):.2f} -> "
                       f"{math.sqrt(again.rss / again.n):.2f} x noise")
            current = refine_fit(again)
            fits[_key(current.effects)] = current
            continue
        if kept is None:
            log.append(f"no extension of {'+'.join(current.names) or 'the nominal model'} "
                       "earns its parameters")
            break
        current = _try_aliases(problem, kept, fits, log)
        current = _slope_earned(problem, current, fits, log)
        log.append(f"kept {'+'.join(current.names)}")
        if _nothing_left(current):
            log.append(f"residual {math.sqrt(current.rss / current.n):.2f} x noise: nothing "
                       "an effect could still explain moves the motion by the noise")
            break
    current = _refine_friction(problem, current, fits, log)
    current = refine_fit(current)
    fits[_key(current.effects)] = current
    n_ref = _n_ref(fits.values())
    screen_ref = _n_ref(screened.values()) if screened else 0.0
    return Selection(nominal, current, list(fits.values()), n_ref,
                     sorted(screened.items(), key=lambda kv: kv[1].bic(screen_ref)),
                     screen_ref, log)
