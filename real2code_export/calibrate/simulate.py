"""Replay measured conditions in MuJoCo: initial state from the data, the measured effort as
input (or a feedback law in the loop), the simulated joint positions at the sample times.

Open-loop replays whose forces are known in advance go through ``mujoco.rollout`` (C,
several models per call on all cores: a finite-difference Jacobian is one call). A
direction-dependent viscous force (part of ``asymmetric_friction``, no MuJoCo joint
attribute) or a feedback law needs the state between steps: those replays step in Python
with the force in ``qfrc_applied``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from .feedback import CLIP_REACH, clipped_mean
from .trajectory import Trajectory

# Largest step (s) where the dynamics are not smooth (dry friction, end stops); smooth
# dynamics step at the sample period (the measured input is piecewise constant anyway)
# up to SMOOTH_TIMESTEP.
MAX_TIMESTEP = 1e-3
SMOOTH_TIMESTEP = 5e-3
THREADS = max(1, min(4, os.cpu_count() or 1))
# Sampling counts as uniform within this share of the period: time stamps stored in single
# precision jitter by ~1e-5 of a millisecond period, far below a step
UNIFORM = 1e-3
# A closed-loop replay from a perturbed initial state (a Jacobian's initial-state column)
# is compared with the unperturbed replay every FORGET_CHECK samples: once its state
# (positions over the law's memory, velocities) is back on the unperturbed one, to
# FORGOTTEN of the largest difference seen or ROUNDOFF_ULPS of the state's round-off,
# the rest of it is the unperturbed replay's (a stable loop forgets its start within a
# few of its time constants: EMPS's in under 0.2 s of a 24.8 s run)
FORGET_CHECK = 8
FORGOTTEN = 1e-9
ROUNDOFF_ULPS = 4.0


@dataclass(frozen=True)
class AppliedLaw:
    """The generalized force on one joint that MuJoCo has no joint attribute for:

        f(v) = offset - friction_asym - damping_asym * |v|

    With direction-dependent friction (Coulomb c+ for positive velocity, c- for negative;
    viscous b+, b-), friction_asym = (c+ - c-) / 2 and damping_asym = (b+ - b-) / 2; the
    symmetric halves are MuJoCo's frictionloss and damping. Coulomb asymmetry is exactly a
    constant force (in slip and in stick: the stick band [-c-, c+] is the symmetric band
    shifted by (c+ - c-) / 2), so no smoothing of the sign is needed. The constant goes
    through ``qfrc_applied``; the viscous part is written into the spec as two one-sided
    dampers b+ and b- (:func:`set_direction_dependent_damping`), ``damping_asym`` here is
    for the record.
    """

    offset: float = 0.0
    friction_asym: float = 0.0
    damping_asym: float = 0.0

    @property
    def constant(self) -> float:
        return self.offset - self.friction_asym

    def force(self, v: float) -> float:
        return self.offset - self.friction_asym - self.damping_asym * abs(v)

    def is_zero(self) -> bool:
        return not (self.offset or self.friction_asym or self.damping_asym)


def set_direction_dependent_damping(spec, joint: str, damping_pos: float,
                                    damping_neg: float) -> None:
    """Viscous damping b+ for positive velocity, b- for negative, as two one-sided dampers
    (affine-bias actuators, velocity gain -b, force clamped to one sign) in place of the
    joint's symmetric damping: MuJoCo computes it natively, in C rollouts and in any
    consumer of the spec (it accepts only dissipative velocity gains, so the two halves
    are dampers in their own right, not a correction to the symmetric one). Idempotent."""
    import mujoco

    big = 1e9
    spec.joint(joint).damping = [0.0, 0.0, 0.0]
    for suffix, b, force_range in (("pos", damping_pos, [-big, 0.0]),
                                   ("neg", damping_neg, [0.0, big])):
        name = f"real2code_{joint}_damping_{suffix}"
        act = spec.actuator(name)
        if act is None:
            act = spec.add_actuator(name=name, target=joint,
                                    trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
        act.gainprm = [0.0] * 10
        act.biastype = mujoco.mjtBias.mjBIAS_AFFINE
        act.biasprm = [0.0, 0.0, -b] + [0.0] * 7
        act.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.forcerange = force_range


@dataclass
class Rollout:
    positions: np.ndarray  # (n, joints) simulated positions at the sample times
    efforts: np.ndarray  # (n, joints) the effort applied over [t_k, t_k+1)
    # (n, joints) simulated velocities at the sample times, where the replay kept them (a
    # declared loop's: what a replay of the same model from another start is compared with)
    velocities: np.ndarray | None = None


def substeps_for(period: float, fine: bool) -> int:
    """Simulation steps per sample interval. A period over the step limit by no more than
    the sampling's jitter (UNIFORM) takes one step: a 1 kHz record whose time stamps were
    stored in single precision has a period of 1.000008 ms, and two steps per sample
    would double every replay's cost for nothing."""
    limit = MAX_TIMESTEP if fine else SMOOTH_TIMESTEP
    return max(1, math.ceil(period / limit - UNIFORM))


def compile_spec(spec):
    """Compile a replay spec (RK4: smooth joint dynamics integrate accurately at the data's
    own sample rate)."""
    import mujoco

    spec.option.integrator = int(mujoco.mjtIntegrator.mjINT_RK4)
    return spec.compile()


def joint_addresses(model, joints: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    import mujoco

    qadr, dadr = [], []
    for name in joints:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if jid < 0:
            raise KeyError(f"joint {name!r} is not in the compiled model")
        qadr.append(int(model.jnt_qposadr[jid]))
        dadr.append(int(model.jnt_dofadr[jid]))
    return np.array(qadr), np.array(dadr)


def measured_samples(traj: Trajectory) -> np.ndarray:
    """(n, joints) measured effort (zero where none was measured)."""
    u = np.zeros((traj.n, len(traj.joints)))
    for k, j in enumerate(traj.joints):
        if j in traj.efforts:
            u[:, k] = traj.efforts[j]
    return u


def recorded_late(ro: Rollout, time: np.ndarray, lag: Sequence[float],
                  speed: Sequence[float]) -> Rollout:
    """``ro`` as a position sensor ``lag`` seconds late (per joint) records it: the reading
    at t is the replayed position at t - lag (linear between samples: a cubic rings
    where dry friction stops the joint, a kink in its motion), and before
    the replay's start the position it starts from, moving at the ``speed`` it starts
    with (at rest: held there). A late position is the effort read early: shifting the
    effort instead sets the joint moving a lag before its recorded start, and where a
    load (gravity) acts from the start, its swing then runs a lag's phase ahead for good."""
    q = ro.positions.copy()
    for k, d in enumerate(lag):
        if d and len(time) >= 2:
            at = time - d
            before = at < time[0]
            q[:, k] = np.interp(at, time, ro.positions[:, k])
            q[before, k] = ro.positions[0, k] + speed[k] * (at[before] - time[0])
    return Rollout(q, ro.efforts)


def step_input(samples: np.ndarray, nsub: int, cubic: bool = False,
               held: np.ndarray | None = None) -> np.ndarray:
    """((n - 1) * nsub, joints) effort per simulation step, at each substep's midpoint:
    linear between samples (one step per interval: the mean of its two samples), or a
    cubic spline through them (the reference replay: how much the reconstruction of the
    input between samples matters is part of the replay's numerical error). ``held``
    (per joint): an effort a digital loop held over each interval, replayed as its steps
    (exact, so the reference replay holds it too)."""
    frac = (np.arange(nsub) + 0.5) / nsub
    if cubic and len(samples) >= 4:
        from scipy.interpolate import CubicSpline

        k = np.arange(len(samples), dtype=float)
        where = (k[:-1, None] + frac[None, :]).ravel()
        per = CubicSpline(k, samples, axis=0)(where)
    else:
        a, b = samples[:-1], samples[1:]
        per = a[:, None, :] * (1 - frac)[None, :, None] + b[:, None, :] * frac[None, :, None]
        per = per.reshape(-1, samples.shape[1])
    if held is not None and np.any(held):
        per[:, held] = np.repeat(samples[:-1, held], nsub, axis=0)
    return per


def held_mask(traj: Trajectory) -> np.ndarray:
    """Per joint of ``traj``: whether its effort was held over each interval."""
    return np.array([j in traj.held for j in traj.joints], bool)


def _uniform(traj: Trajectory) -> bool:
    dt = np.diff(traj.time)
    return bool(np.all(np.abs(dt - traj.sample_period) <= UNIFORM * traj.sample_period))


Initial = Mapping[str, tuple[float, float]]  # joint -> (position, velocity) at the first sample


def _start(model, data, traj: Trajectory, initial: Initial, qadr, dadr) -> None:
    import mujoco

    mujoco.mj_resetData(model, data)
    for k, j in enumerate(traj.joints):
        q0, v0 = initial.get(j, (traj.positions[j][0], 0.0))
        data.qpos[qadr[k]] = q0
        data.qvel[dadr[k]] = v0
    mujoco.mj_forward(model, data)


def rollout(model, traj: Trajectory, initial: Initial,
            laws: Mapping[str, AppliedLaw] | None = None, data=None,
            fine: bool = True, refine: int = 1) -> Rollout:
    """Simulate ``traj``'s conditions stepping in Python (feedback laws, velocity-dependent
    forces, irregular sampling)."""
    import mujoco

    joints = traj.joints
    qadr, dadr = joint_addresses(model, joints)
    laws = laws or {}
    law_list = [laws.get(j, AppliedLaw()) for j in joints]
    d = data if data is not None else mujoco.MjData(model)
    _start(model, d, traj, initial, qadr, dadr)
    n, nj = traj.n, len(joints)
    t = traj.time
    period = traj.sample_period
    nsub = substeps_for(period, fine) * refine
    model.opt.timestep = period / nsub
    h = model.opt.timestep
    uniform = _uniform(traj)
    samples = measured_samples(traj)
    held = held_mask(traj)
    per_step = step_input(samples, nsub, cubic=refine > 1, held=held) if uniform else None
    levels = None if uniform else interval_levels(samples, held)

    q_out = np.empty((n, nj))
    u_out = np.zeros((n, nj))
    controller = traj.law()
    history = {j: q_out[:, k] for k, j in enumerate(joints)}
    step = mujoco.mj_step
    qpos, qfrc = d.qpos, d.qfrc_applied
    const = np.array([law.constant for law in law_list])
    for i in range(n):
        q_out[i] = qpos[qadr]
        if controller is not None:  # a feedback law holds its output over the interval
            u = controller(i, history)
            for k, j in enumerate(joints):
                u_out[i, k] = u.get(j, 0.0)
        else:
            u_out[i] = samples[i]
        if i == n - 1:
            break
        if controller is None and per_step is not None:
            for s in range(nsub):
                qfrc[dadr] = per_step[i * nsub + s] + const
                step(model, d)
            continue
        steps = nsub if uniform else max(1, round((t[i + 1] - t[i]) / h))
        base = u_out[i] + const if controller is not None else levels[i] + const
        qfrc[dadr] = base
        for _ in range(steps):
            step(model, d)
    return Rollout(q_out, u_out)


def declared_loop(models: Sequence, traj: Trajectory, initials: Sequence[Initial],
                  laws: Sequence[Mapping[str, AppliedLaw]], fine: bool = True,
                  refine: int = 1, bases: Sequence[Rollout | None] | None = None
                  ) -> list[Rollout]:
    """Replays of a declared closed loop (``traj.feedback``, uniform samples) for several
    models: the law evaluated in plain floats each sample, each model stepped by MuJoCo.
    Same replay as :func:`rollout` (whose general controller takes a dict per sample).
    ``bases``: per model, its replay from another initial state (same model, laws and
    input) or None: once the loop has forgotten the difference (:class:`_Forgetting`),
    the rest of the replay is the base's."""
    import mujoco

    joints = traj.joints
    qadr, dadr = joint_addresses(models[0], joints)
    n, nj, nb = traj.n, len(joints), len(models)
    period = traj.sample_period
    nsub = substeps_for(period, fine) * refine
    datas = []
    for m, x0 in zip(models, initials, strict=True):
        m.opt.timestep = period / nsub
        d = mujoco.MjData(m)
        _start(m, d, traj, x0, qadr, dadr)
        datas.append(d)
    # Plain Python floats per model and sample: with one or a few joints, numpy's per-call
    # overhead on arrays of a handful of values cost over twice the MuJoCo step itself.
    # The arithmetic is Feedback.commands' own, in its order (the same floats).
    qadr_l, dadr_l = [int(a) for a in qadr], [int(a) for a in dadr]
    const = [[lw.get(j, AppliedLaw()).constant for j in joints] for lw in laws]
    loops = {k: _LoopTerms(traj.feedback[j], traj.columns, period)
             for k, j in enumerate(joints) if j in traj.feedback}
    memory = max((f.velocity_taps for f in traj.feedback.values()), default=0)
    bases = bases if bases is not None else [None] * nb
    step = mujoco.mj_step
    out = []
    for m, d, cb, base in zip(models, datas, const, bases, strict=True):
        q = [[0.0] * n for _ in range(nj)]  # joint, sample
        v = [[0.0] * n for _ in range(nj)]
        u = [[0.0] * n for _ in range(nj)]
        forget = _Forgetting(base, memory) if base is not None and \
            base.velocities is not None and m.na == 0 else None
        if nj == 1 and 0 in loops and loops[0].read is None:  # the common rig: law inline
            loops[0].replay(step, m, d, qadr_l[0], dadr_l[0], cb[0], q[0], v[0], u[0],
                            nsub, forget)
        else:
            _stepped_loop(step, m, d, qadr_l, dadr_l, cb, loops, q, v, u, nsub, forget)
        ro = Rollout(np.array(q).T.copy(), np.array(u).T.copy(), np.array(v).T.copy())
        if forget is not None and forget.at is not None:
            forget.complete(ro)
        out.append(ro)
    return out


def _stepped_loop(step, m, d, qadr, dadr, const, loops, q, v, u, nsub, forget) -> None:
    """:func:`declared_loop`'s replay of one model with several joints (or joints
    without a law), sample by sample."""
    n, nj = len(q[0]), len(q)
    read, readv, qfrc = d.qpos.item, d.qvel.item, d.qfrc_applied
    per_joint = [(qadr[k], dadr[k], const[k], q[k], v[k], u[k],
                  loops[k].effort if k in loops else None) for k in range(nj)]
    check = forget.first if forget is not None else n
    for i in range(n):
        for adr, dof, _, qk, vk, uk, law in per_joint:
            qk[i] = read(adr)
            vk[i] = readv(dof)
            if law is not None:  # the law's output is held over the interval
                uk[i] = law(i, qk)
        if i == n - 1:
            break
        if i == check:
            if forget.done(i, q, v):
                return
            check += FORGET_CHECK
        for _, dof, c, _, _, uk, _ in per_joint:
            qfrc[dof] = uk[i] + c
        for _ in range(nsub):
            step(m, d)


class _Forgetting:
    """Whether a closed-loop replay has forgotten how its start differed from its base's:
    its positions over the law's memory and its velocity back on the base's, to FORGOTTEN
    of the largest difference seen at a check or ROUNDOFF_ULPS of the state's round-off
    (a difference that does not die away, a joint stuck elsewhere by friction, never is).
    Then the rest of the replay is the base's: the same model, law and input from the same
    state."""

    def __init__(self, base: Rollout, memory: int):
        self.base = base
        self.memory = memory
        self.first = memory
        self.qb = [col.tolist() for col in base.positions.T]
        self.vb = [col.tolist() for col in base.velocities.T]
        self.tol_q = [ROUNDOFF_ULPS * float(np.spacing(np.abs(col).max())) for col in
                      base.positions.T]
        self.tol_v = [ROUNDOFF_ULPS * float(np.spacing(np.abs(col).max())) for col in
                      base.velocities.T]
        self.peak_q = [0.0] * len(self.qb)
        self.peak_v = [0.0] * len(self.qb)
        self.at: int | None = None

    def done(self, i: int, q: list[list[float]], v: list[list[float]]) -> bool:
        """At sample ``i`` (before the step to ``i + 1``): forgotten? (then remembered)"""
        forgotten = True
        for k, (qk, vk, qbk, vbk) in enumerate(zip(q, v, self.qb, self.vb, strict=True)):
            dq = max(abs(qk[j] - qbk[j]) for j in range(i - self.memory, i + 1))
            dv = abs(vk[i] - vbk[i])
            self.peak_q[k] = max(self.peak_q[k], dq)
            self.peak_v[k] = max(self.peak_v[k], dv)
            if dq > max(FORGOTTEN * self.peak_q[k], self.tol_q[k]) or \
                    dv > max(FORGOTTEN * self.peak_v[k], self.tol_v[k]):
                forgotten = False
        if forgotten:
            self.at = i
        return forgotten

    def complete(self, ro: Rollout) -> None:
        """The samples after the one where the replay forgot its start: the base's (the
        effort from that sample on: the law's output there came from the same state)."""
        i = self.at
        ro.positions[i + 1:] = self.base.positions[i + 1:]
        ro.velocities[i + 1:] = self.base.velocities[i + 1:]
        ro.efforts[i:] = self.base.efforts[i:]


class _LoopTerms:
    """One declared loop's law in plain floats (``Feedback.commands`` for one replay):
    the reference and added columns as lists, the constants unpacked."""

    def __init__(self, f, columns: Mapping[str, np.ndarray], period: float):
        self.f = f
        self.ref = [float(x) for x in columns[f.reference]]
        self.added = [float(x) for x in columns[f.added]] if f.added is not None else None
        self.period = period
        self.lo, self.hi = f.saturation if f.saturation is not None else (None, None)
        # the clipped command's mean under the encoder's noise (feedback.py), where the
        # command comes within CLIP_REACH of its noise of a limit
        self.s = f.command_noise(period)
        self.reach = CLIP_REACH * self.s
        # a draw of the encoder's noise on the position the law reads (feedback.py)
        self.read = [float(x) for x in columns[f.reading]] if f.reading is not None else None

    def effort(self, k: int, q: list[float]) -> float:
        f = self.f
        taps = min(f.velocity_taps, k)
        qk, qb = q[k], q[k - taps]
        if self.read is not None:
            qk, qb = qk + self.read[k], qb + self.read[k - taps]
        v = (qk - qb) / (taps * self.period) if taps > 0 else 0.0
        u = f.kp * (self.ref[k] - qk) - f.kd * v
        if self.added is not None:
            u = u + self.added[k]
        if self.lo is not None:
            if self.s > 0 and (u < self.lo + self.reach or u > self.hi - self.reach):
                u = float(clipped_mean(u, self.lo, self.hi, self.s))
            else:
                u = min(max(u, self.lo), self.hi)
        return f.gain * u

    def replay(self, step, m, d, qadr: int, dof: int, const: float, q: list[float],
               v: list[float], u: list[float], nsub: int,
               forget: _Forgetting | None = None) -> None:
        """One model's replay of a one-joint loop: :meth:`effort` inlined into the stepping
        loop (its arithmetic in its order, the same floats), a function call and a dozen
        attribute reads a sample fewer: a fifth of a replay's time (0.51 -> 0.42 s CPU, EMPS).
        ``forget``: stop where the replay is back on its base's (:class:`_Forgetting`)."""
        f = self.f
        kp, kd, gain, vt, period = f.kp, f.kd, f.gain, f.velocity_taps, self.period
        ref, added, lo, hi = self.ref, self.added, self.lo, self.hi
        s, reach = self.s, self.reach
        near_lo = lo + reach if lo is not None else None
        near_hi = hi - reach if hi is not None else None
        read, readv, qfrc = d.qpos.item, d.qvel.item, d.qfrc_applied
        substeps = range(nsub)
        last = len(q) - 1
        check = forget.first if forget is not None else len(q)
        for i in range(len(q)):
            qi = read(qadr)
            q[i] = qi
            v[i] = readv(dof)
            taps = vt if vt < i else i
            vel = (qi - q[i - taps]) / (taps * period) if taps > 0 else 0.0
            c = kp * (ref[i] - qi) - kd * vel
            if added is not None:
                c = c + added[i]
            if lo is not None:
                if s > 0 and (c < near_lo or c > near_hi):
                    c = float(clipped_mean(c, lo, hi, s))
                else:
                    c = min(max(c, lo), hi)
            ui = gain * c
            u[i] = ui
            if i == last:
                break
            if i == check:
                if forget.done(i, (q,), (v,)):
                    return
                check += FORGET_CHECK
            qfrc[dof] = ui + const
            for _ in substeps:
                step(m, d)


def irregular_input(time: np.ndarray, samples: np.ndarray, h: float,
                    held: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Irregular samples as steps of ``h``: each interval's effort held at the mean of its
    two samples (at its first where ``held``, per joint: :func:`step_input`) for as many
    whole steps as the interval holds (at least one), and the step count after which each
    sample after the first is read (:func:`rollout`'s stepping)."""
    steps = np.maximum(1, np.round(np.diff(time) / h).astype(int))
    return np.repeat(interval_levels(samples, held), steps, axis=0), np.cumsum(steps)


def interval_levels(samples: np.ndarray, held: np.ndarray | None = None) -> np.ndarray:
    """(n - 1, joints) the effort each interval is replayed at when it is one level: the
    mean of its two samples, or its first where ``held`` (per joint)."""
    level = 0.5 * (samples[:-1] + samples[1:])
    if held is not None and np.any(held):
        level[:, held] = samples[:-1, held]
    return level


class BatchRunner:
    """Open-loop replays of one trajectory for several models at once (``mujoco.rollout``
    on all cores, irregular samples too); falls back to Python stepping for a feedback
    law."""

    def __init__(self, traj: Trajectory, joints: Sequence[str]):
        self.traj = traj
        self.joints = list(joints)
        self._datas = None
        self._input = measured_samples(traj)

    def run(self, models: Sequence, initials: Sequence[Initial],
            laws: Sequence[Mapping[str, AppliedLaw]], fine: bool,
            refine: int = 1, bases: Sequence[Rollout | None] | None = None
            ) -> list[Rollout]:
        """``bases``: per model, its replay from another initial state or None (a declared
        loop's replay ends where it has forgotten the difference: :func:`declared_loop`;
        other replays ignore it)."""
        import mujoco
        from mujoco import rollout as mj_rollout

        traj = self.traj
        if traj.feedback and traj.controller is None and _uniform(traj):
            return declared_loop(models, traj, initials, laws, fine, refine, bases)
        if traj.law() is not None:
            data = mujoco.MjData(models[0])
            return [rollout(m, traj, x0, lw, data, fine, refine)
                    for m, x0, lw in zip(models, initials, laws, strict=True)]
        m0 = models[0]
        qadr, dadr = joint_addresses(m0, self.joints)
        period = traj.sample_period
        nsub = substeps_for(period, fine) * refine
        if _uniform(traj):
            per_step = step_input(self._input, nsub, cubic=refine > 1,
                                  held=held_mask(traj))
            ends = nsub * np.arange(1, traj.n)
        else:
            per_step, ends = irregular_input(traj.time, self._input, period / nsub,
                                             held_mask(traj))
        if self._datas is None or self._datas[0].model.nq != m0.nq:
            self._datas = [mujoco.MjData(m0) for _ in range(THREADS)]
        spec_full = int(mujoco.mjtState.mjSTATE_FULLPHYSICS)
        nstate = mujoco.mj_stateSize(m0, spec_full)
        init = np.empty((len(models), nstate))
        ctrl = np.zeros((len(models), len(per_step), m0.nv))
        for b, (m, x0, lw) in enumerate(zip(models, initials, laws, strict=True)):
            m.opt.timestep = period / nsub
            d = self._datas[0]
            _start(m, d, traj, x0, qadr, dadr)
            mujoco.mj_getState(m, d, init[b], spec_full)
            for k, j in enumerate(self.joints):
                ctrl[b, :, dadr[k]] = per_step[:, k] + lw.get(j, AppliedLaw()).constant
        state, _ = mj_rollout.rollout(list(models), self._datas, init, ctrl,
                                      control_spec=int(mujoco.mjtState.mjSTATE_QFRC_APPLIED),
                                      persistent_pool=True)
        out = []
        for b in range(len(models)):
            q = np.empty((traj.n, len(self.joints)))
            q[0] = init[b, 1 + qadr]
            q[1:] = state[b, ends - 1][:, 1 + qadr]
            out.append(Rollout(q, self._input.copy()))
        return out
