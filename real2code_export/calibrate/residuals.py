"""Residuals of one candidate's replays against the measured motion, and their Jacobian:
the candidate compiled into MuJoCo (its effects written into the nominal replay spec by
``mujoco.sysid`` parameter modifiers), replayed under each run's conditions from a
parameter vector (effect values, then the fitted initial states), the positions compared
in noise units; multiple shooting's continuity between pieces of one run; forward
differences in which an initial state moves only its own run (and a closed loop's replay
from a moved start only until the loop has forgotten the move).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .effects import Effect
from .problem import Problem
from .simulate import MAX_TIMESTEP, AppliedLaw, BatchRunner, Rollout, compile_spec, recorded_late

FD_STEP = 3e-4  # forward-difference step, relative to each parameter's scale
# Multiple shooting: a gap of one noise deviation between a piece's replayed end and the
# next piece's start weighs as much as CONTINUITY**2 samples off by one deviation
CONTINUITY = 10.0


def sysid_parameters(effects: tuple[Effect, ...]):
    """The candidate's parameters as a ``mujoco.sysid.ParameterDict`` (one vector
    parameter per effect; its modifier writes the effect into an MjSpec)."""
    from mujoco import sysid

    pd = sysid.ParameterDict()
    for e in effects:
        pd.add(e.sysid_parameter())
    return pd


def laws_for(effects: tuple[Effect, ...], values: dict[str, float],
             base: dict[str, AppliedLaw] | None = None) -> dict[str, AppliedLaw]:
    """Applied-force laws per joint: the model's own, with the candidate's effects in
    place of the terms they refit."""
    out = dict(base or {})
    for e in effects:
        old = out.get(e.joint, AppliedLaw())
        law = e.law({p.name: values[p.key] for p in e.params})
        if e.name == "offset":
            out[e.joint] = AppliedLaw(law.offset, old.friction_asym, old.damping_asym)
        elif e.name == "asymmetric_friction":
            out[e.joint] = AppliedLaw(old.offset, law.friction_asym, law.damping_asym)
    return out


def build_model(problem: Problem, effects: tuple[Effect, ...], values: dict[str, float],
                refine: int = 1):
    """Compile the candidate: the nominal replay spec with each effect's sysid parameter
    modifier applied. ``refine`` > 1: the reference replay (dry friction as stiff as its
    finer step allows)."""
    from mujoco import sysid

    params = sysid_parameters(effects)
    params.update_from_vector(np.array([values[p.key] for e in effects for p in e.params]))
    spec = problem.spec.copy()
    if refine > 1:
        for name in problem.joints:
            spec.joint(name).solref_friction = [2 * MAX_TIMESTEP / refine, 1.0]
    return compile_spec(sysid.apply_param_modifiers_spec(params, spec))


NONSMOOTH = {"friction", "asymmetric_friction", "limit"}


def initial_slots(problem: Problem) -> list[tuple[int, int, int]]:
    """(trajectory, joint, 0 position / 1 velocity) of every fitted initial-state value."""
    return [(t, k, c) for t, free in enumerate(problem.initial_free)
            for k in range(len(problem.joints)) for c in (0, 1) if free[k, c]]


class Evaluator:
    """Residuals of one candidate as a function of the scaled parameter vector."""

    def __init__(self, problem: Problem, effects: tuple[Effect, ...], scales: np.ndarray,
                 refine: int = 1, origin: np.ndarray | None = None):
        self.problem = problem
        self.refine = refine
        self.effects = effects
        self.scales = scales
        # value = origin + x * scale: an initial state is measured from where the data put
        # it (from zero, a start of 0.2 rad over a scale of 1e-3 rad is a variable in the
        # hundreds, and the optimiser's relative step tolerance stops every fit early)
        self.origin = np.zeros(len(scales)) if origin is None else origin
        self.params = [p for e in effects for p in e.params]
        self.slots = initial_slots(problem)
        self.fine = problem.nonsmooth or any(e.name in NONSMOOTH for e in effects)
        self.count = 0
        self._models: dict[tuple, object] = {}
        self._lagged: dict[tuple, BatchRunner] = {}
        self.runners = [BatchRunner(tr, problem.joints) for tr in problem.trajectories]
        sizes = [tr.n * len(problem.joints) for tr in problem.trajectories]
        self.offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(int)

    def split(self, x: np.ndarray):
        theta = self.origin + x * self.scales
        values = {p.key: float(theta[i]) for i, p in enumerate(self.params)}
        x0 = [v.copy() for v in self.problem.initial]
        for i, (t, k, c) in enumerate(self.slots):
            x0[t][k, c] = float(theta[len(self.params) + i])
        return values, x0

    def model(self, values: dict[str, float]):
        key = tuple(values[p.key] for p in self.params)
        if key not in self._models:
            if len(self._models) > 64:
                self._models.clear()
            self._models[key] = build_model(self.problem, self.effects, values, self.refine)
        return self._models[key]

    def _block(self, t: int, ro: Rollout) -> np.ndarray:
        pr = self.problem
        tr = pr.trajectories[t]
        # Positions only, also in closed loop: there the recorded effort is the feedback
        # law applied to the measured positions, so fitting it too would count the same
        # information twice (the simulated effort is compared in the report).
        parts = []
        for k, j in enumerate(pr.joints):
            sigma = noise_floor(pr.position_noise[t][k], tr.positions[j])
            parts.append((ro.positions[:, k] - tr.positions[j]) / sigma)
        return np.concatenate(parts)

    def run(self, t: int, points: list[np.ndarray], runner: BatchRunner | None = None,
            bases: list[Rollout | None] | None = None) -> list[tuple[np.ndarray, Rollout]]:
        """Residual block of trajectory ``t`` and its rollout at each point (``runner``:
        another replay of the same trajectory, e.g. with a perturbed input; ``bases``: per
        point, the replay of a point that differs from it in the initial state only, or
        None: :meth:`BatchRunner.run`)."""
        if not points:
            return []
        models, initials, laws, zeros = [], [], [], []
        for x in points:
            values, x0 = self.split(x)
            models.append(self.model(values))
            # the initial state is fitted as read; the joint starts at the reading less the
            # encoder's zero error, and what the encoder reads is compared with the data
            zero = self.sensor_offsets(values)
            zeros.append(zero)
            initials.append({j: (float(x0[t][k, 0] - zero[k]), float(x0[t][k, 1]))
                             for k, j in enumerate(self.problem.joints)})
            laws.append(laws_for(self.effects, values, self.problem.base_laws))
        self.count += len(points)
        if bases is not None:  # a base as replayed, before the encoder's zero error
            bases = [b if b is None or not np.any(zero) else
                     dataclasses.replace(b, positions=b.positions - zero)
                     for b, zero in zip(bases, zeros, strict=True)]
        ros: list = [None] * len(points)
        groups: dict[tuple, list[int]] = {}
        for i, x in enumerate(points):  # points with one lag replay one input
            groups.setdefault(self.delays(self.split(x)[0]), []).append(i)
        tr = self.problem.trajectories[t]
        for lag, idx in groups.items():
            # open loop, a lag beyond a sample interval is the position recorded late (the
            # replay's output shifted); within one it is how the effort was held between
            # samples (report._effort_holds), and a loop's law acts on the late positions:
            # there the effort is shifted
            late = any(abs(d) > tr.sample_period for d in lag) and \
                tr.controller is None and not tr.feedback
            use = (runner or self.runners[t]) if late else self._runner(t, lag, runner)
            # the initial state stays the one read at the first sample; the replay starts
            # where the joint then is, a lag on
            starts = [{j: (q + v * lag[k], v) for k, (j, (q, v)) in
                       enumerate(initials[i].items())} if late else initials[i] for i in idx]
            out = use.run([models[i] for i in idx], starts,
                          [laws[i] for i in idx], self.fine, self.refine,
                          [bases[i] for i in idx] if bases is not None else None)
            for i, ro in zip(idx, out, strict=True):
                ros[i] = recorded_late(ro, tr.time, lag, [initials[i][j][1] for j in
                                                          self.problem.joints]) if late else ro
        for zero, ro in zip(zeros, ros, strict=True):
            if np.any(zero):
                ro.positions = ro.positions + zero
        return [(self._block(t, ro), ro) for ro in ros]

    def delays(self, values: dict[str, float]) -> tuple[float, ...]:
        pr = self.problem
        return tuple(values.get(f"{j}.effort_delay", pr.contexts[j].effort_delay)
                     for j in pr.joints)

    def _runner(self, t: int, lag: tuple[float, ...], given: BatchRunner | None = None
                ) -> BatchRunner:
        """The replay of trajectory ``t`` (or of ``given``'s input) with each joint's effort
        felt ``lag`` seconds after it was recorded (cached: a fit tries few lags)."""
        base = given if given is not None else self.runners[t]
        if not any(lag):
            return base
        key = (t, lag)
        if given is None and key in self._lagged:
            return self._lagged[key]
        tr = base.traj
        efforts = {j: np.interp(tr.time - lag[k], tr.time, tr.efforts[j])
                   for k, j in enumerate(self.problem.joints) if j in tr.efforts}
        lagged = BatchRunner(dataclasses.replace(tr, efforts=efforts), self.problem.joints)
        if given is None:
            if len(self._lagged) > 16:
                self._lagged.clear()
            self._lagged[key] = lagged
        return lagged

    def sensor_offsets(self, values: dict[str, float]) -> np.ndarray:
        pr = self.problem
        return np.array([values.get(f"{j}.encoder_offset", pr.contexts[j].sensor_offset)
                         for j in pr.joints])

    def residual(self, x: np.ndarray) -> tuple[np.ndarray, list[Rollout]]:
        out = [self.run(t, [x])[0] for t in range(len(self.problem.trajectories))]
        ros = [ro for _, ro in out]
        links = [self._link(ros[a], x, b) for a, b in self.problem.links]
        return np.concatenate([r for r, _ in out] + links), ros

    def _link(self, ro_prev: Rollout, x: np.ndarray, nxt: int) -> np.ndarray:
        """Continuity between pieces of one run: where the previous piece's replay ends
        against where the next one's fitted start is (noise units, CONTINUITY weight)."""
        pr = self.problem
        _, x0 = self.split(x)
        out = np.empty(len(pr.joints))
        for k, j in enumerate(pr.joints):
            sigma = noise_floor(pr.position_noise[nxt][k], pr.trajectories[nxt].positions[j])
            out[k] = CONTINUITY * (ro_prev.positions[-1, k] - x0[nxt][k, 0]) / sigma
        return out

    def jacobian(self, x: np.ndarray, r0: np.ndarray, ub: np.ndarray,
                 ros0: list[Rollout] | None = None) -> np.ndarray:
        """Forward differences; an initial velocity moves only its own trajectory.
        ``ros0``: the rollouts at ``x`` (``r0``'s): an initial state's column replays the
        same model from a moved start, and a closed loop that forgets the move ends it
        there (:func:`simulate.declared_loop`)."""
        p = len(self.params)
        steps = []
        for i in range(len(x)):
            h = FD_STEP if x[i] + FD_STEP <= ub[i] else -FD_STEP
            steps.append(h)
        jmat = np.zeros((len(r0), len(x)))
        for t in range(len(self.problem.trajectories)):
            cols = list(range(p)) + [p + i for i, slot in enumerate(self.slots) if slot[0] == t]
            points = []
            for c in cols:
                x1 = x.copy()
                x1[c] += steps[c]
                points.append(x1)
            a, b = self.offsets[t], self.offsets[t + 1]
            bases = [ros0[t] if ros0 is not None and c >= p else None for c in cols]
            for c, x1, (r1, ro) in zip(cols, points, self.run(t, points, bases=bases),
                                       strict=True):
                jmat[a:b, c] = (r1 - r0[a:b]) / steps[c]
                for n, (prev, nxt) in enumerate(self.problem.links):
                    if prev == t:
                        rows = self._link_rows(n)
                        jmat[rows, c] = (self._link(ro, x1, nxt) - r0[rows]) / steps[c]
        # the next piece's start enters its link directly
        for n, (_, nxt) in enumerate(self.problem.links):
            rows = self._link_rows(n)
            for i, (t, k, c) in enumerate(self.slots):
                if t == nxt and c == 0:
                    j = self.problem.joints[k]
                    sigma = noise_floor(self.problem.position_noise[nxt][k],
                                   self.problem.trajectories[nxt].positions[j])
                    jmat[rows[k], p + i] = -CONTINUITY * self.scales[p + i] / sigma
        return jmat

    def _link_rows(self, n: int) -> np.ndarray:
        nj = len(self.problem.joints)
        return self.offsets[-1] + n * nj + np.arange(nj)


def noise_floor(sigma: float, x: np.ndarray) -> float:
    return max(float(sigma), 1e-6 * max(float(np.ptp(x)), 1e-3), 1e-12)
