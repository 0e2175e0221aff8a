"""Everything a calibration keeps fixed while candidates are tried: the replay spec, the
measured signals, their noise levels, the joints' contexts and candidate libraries."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import FormatError, ModelError
from ..model import ArticulatedObject
from . import features
from .effects import Effect, JointContext, library
from .extras import base_law, write_spec_extras
from .simulate import MAX_TIMESTEP
from .spec import gravity_loaded, replay_spec, subtree_bodies
from .trajectory import Trajectory


@dataclass
class Signals:
    """One trajectory, smoothed for the inverse-dynamics start: positions, velocities,
    accelerations, the measured effort and the nominal rigid-body effort (n, joints)."""

    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    tau: np.ndarray
    tau_rb: np.ndarray
    tau_rot: np.ndarray  # the part of tau_rb due to rotational inertia about the com
    tau_dq: np.ndarray  # d(nominal effort)/d(position): what an encoder zero error moves
    tau_dt: np.ndarray  # the measured effort's time derivative: what a lag moves
    dq_noise: np.ndarray  # per joint: noise of the smoothed velocity
    usable: np.ndarray  # (n,) samples away from impacts and the ends
    stops: list[list[str]]  # per joint: the sides this run shows the joint stopped hard


@dataclass
class Problem:
    obj: ArticulatedObject
    joints: list[str]
    trajectories: list[Trajectory]
    spec: object  # the nominal replay MjSpec (copied per candidate)
    contexts: dict[str, JointContext]
    effects: dict[str, dict[str, Effect]]  # joint -> effect variant -> Effect
    position_noise: list[np.ndarray]  # per trajectory: per joint sigma
    # per trajectory: per joint sigma of the measured effort's jitter (what smoothing
    # leaves in it, a loop's reaction to the encoder's noise included)
    effort_noise: list[np.ndarray]
    signals: list[Signals]
    # per trajectory, (joints, 2): initial position and velocity, which of them are fitted
    # (positions always: one noisy first sample would offset a whole run; velocities when
    # the run starts moving), and their standard errors from the data
    initial: list[np.ndarray]
    initial_free: list[np.ndarray]
    initial_stderr: list[np.ndarray]
    stops: dict[str, list[str]] = field(default_factory=dict)
    nonsmooth: bool = False  # the nominal model has dry friction or the data reach a limit
    base_laws: dict = field(default_factory=dict)  # joint -> the model's own AppliedLaw
    # (previous, next) trajectory indices of pieces of one run (multiple shooting)
    links: list[tuple[int, int]] = field(default_factory=list)
    # per trajectory: per joint sigma of the effort sensor's own noise (the jitter less what
    # the position's jitter explains: features.sensor_noise_level)
    effort_sensor_noise: list[np.ndarray] = field(default_factory=list)


FRICTION_TIMECONST = 2 * MAX_TIMESTEP
# s: where 40 ms of samples cannot tell a run's start from rest, this long a look can
# (a creep of a few noise levels per second; a piece is at least windows.MIN_PIECE long)
CREEP_SECONDS = 0.25


def calibration_spec(obj: ArticulatedObject, joints: list[str], gravity=None):
    spec = replay_spec(obj, joints)
    if gravity is not None:  # the experiment's, in the model's world frame
        spec.option.gravity = list(gravity)
    # Dry friction as stiff as the step allows (MuJoCo's default 0.02 s time constant lets
    # a stuck joint creep); kept with the calibrated model for every MJCF consumer.
    for name in joints:
        spec.joint(name).solref_friction = [FRICTION_TIMECONST, 1.0]
    write_spec_extras(obj, spec, joints)
    return spec


def rigid_effort(spec, joints: list[str], traj_q: np.ndarray, dq: np.ndarray,
                 ddq: np.ndarray, point_masses: bool = False) -> np.ndarray:
    """Rigid-body inverse dynamics (inertia, Coriolis, gravity) of the nominal model at each
    sample, with the joints' own passive forces, armature and constraints left out
    (``point_masses``: every body's rotational inertia about its centre of mass too)."""
    import mujoco

    from .simulate import joint_addresses

    s = spec.copy()
    if point_masses:
        for body in s.bodies:
            if body.mass > 0:
                body.fullinertia = [1e-12, 1e-12, 1e-12, 0.0, 0.0, 0.0]
    for name in joints:
        j = s.joint(name)
        j.damping = [0.0, 0.0, 0.0]
        j.stiffness = [0.0, 0.0, 0.0]
        j.frictionloss = 0.0
        j.armature = 0.0
    s.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    m = s.compile()
    d = mujoco.MjData(m)
    qadr, dadr = joint_addresses(m, joints)
    out = np.empty_like(traj_q)
    for i in range(len(traj_q)):
        d.qpos[qadr] = traj_q[i]
        d.qvel[dadr] = dq[i]
        d.qacc[dadr] = ddq[i]
        mujoco.mj_inverse(m, d)
        out[i] = d.qfrc_inverse[dadr]
    return out


IMPACT_SECONDS = 0.08  # impacts are short: looked for with a shorter smoothing window


def stops_seen(spec, joints: list[str], tr: Trajectory, armature: dict[str, float]
               ) -> list[list[str]]:
    """Per joint, the sides where ``tr`` shows a joint stopped hard
    (:func:`features.sudden_stops`), judged on the acceleration no measured effort drives:
    the effort over the joint-space inertia (the nominal model's, with ``armature``)."""
    period = tr.sample_period
    short = features.smoothing_window(period, seconds=IMPACT_SECONDS)
    qs = np.column_stack([tr.positions[j] for j in joints])
    smooth = [features.derivatives(qs[:, k], period, short) for k in range(len(joints))]
    q = np.column_stack([s[0] for s in smooth])
    ddq = np.column_stack([s[2] for s in smooth])
    measured = [k for k, j in enumerate(joints) if j in tr.efforts]
    if measured:
        zero = np.zeros_like(q)
        weight = rigid_effort(spec, joints, q, zero, zero)
        for k in measured:
            unit = zero.copy()
            unit[:, k] = 1.0
            inertia = rigid_effort(spec, joints, q, zero, unit)[:, k] - weight[:, k] \
                + armature[joints[k]]
            effort = features.derivatives(features.despike(tr.efforts[joints[k]])[0],
                                          period, short)[0]
            ddq[:, k] = ddq[:, k] - effort / np.maximum(inertia, 1e-12)
    return [features.sudden_stops(q[:, k], smooth[k][1], ddq[:, k],
                                  features.noise_level(qs[:, k]), short // 2 + 1)
            for k in range(len(joints))]


def _initial_state(t: np.ndarray, q: np.ndarray, noise: float, seconds: float = 0.04
                   ) -> tuple[tuple[float, float], tuple[float, float]]:
    """Position and velocity at the first sample from a local quadratic over ``seconds``,
    and their standard errors."""
    period = float(np.median(np.diff(t)))
    n = int(min(len(t), max(6, round(seconds / period))))
    tt = t[:n] - t[0]
    a = np.column_stack([np.ones(n), tt, tt**2])
    coef, *_ = np.linalg.lstsq(a, q[:n], rcond=None)
    cov = np.linalg.pinv(a.T @ a) * max(noise, 1e-12) ** 2
    return (float(coef[0]), float(coef[1])), (float(np.sqrt(cov[0, 0])),
                                              float(np.sqrt(cov[1, 1])))


def sensor_offset(obj: ArticulatedObject, joint: str) -> float:
    """The encoder zero error the model's metadata records for ``joint`` (0 if none)."""
    from .extras import joint_extras

    return float(joint_extras(obj, joint).get("encoder_offset", {}).get("position", 0.0))


def effort_delay(obj: ArticulatedObject, joint: str) -> float:
    """The lag of the effort behind the position the model's metadata records (s)."""
    from .extras import joint_extras

    return float(joint_extras(obj, joint).get("effort_delay", {}).get("seconds", 0.0))


def _actuated(joint, trajectories: list[Trajectory]) -> bool:
    """Whether a rotor may drive ``joint``: the model declares one (armature, an effort
    limit) or the data show the joint driven (a measured effort, a closed loop)."""
    declared = joint.dynamics.armature > 0 or (joint.limits is not None and
                                               bool(joint.limits.effort))
    return declared or any(joint.name in tr.efforts or tr.law() is not None
                           for tr in trajectories)


def build_problem(obj: ArticulatedObject, trajectories: list[Trajectory],
                  inverse: bool = True) -> Problem:
    """The calibration problem of ``obj`` on ``trajectories``. ``inverse``: also the
    smoothed signals, the nominal inverse dynamics, the stops the data show and the
    candidate effects, which fitting effects needs; a replay of the model as it is (only
    the initial states fitted: a prediction, the calibrated model's replay) needs none of
    them, and on long runs the inverse dynamics are most of the problem's cost (its
    ``signals`` and ``effects`` are then empty, every effort scale NaN)."""
    joints = trajectories[0].joints
    for name in joints:
        try:
            j = obj.joint(name)
        except KeyError as e:
            raise ModelError(f"object {obj.name!r}", f"has no joint {name!r}") from e
        if not j.type.movable:
            raise ModelError(f"joint {name!r}", "is fixed: nothing to calibrate")
    gravity = trajectories[0].gravity
    for tr in trajectories[1:]:
        if tr.gravity != gravity:
            raise FormatError(tr.source, "gravity", f"declares {tr.gravity}, "
                             f"{trajectories[0].source} {gravity}: fit them separately")
    spec = calibration_spec(obj, joints, gravity)
    nominal = spec.copy().compile()
    from .simulate import joint_addresses

    _, dadr = joint_addresses(nominal, joints)

    signals, pos_noise, eff_noise, x0s, x0_free, x0_se = [], [], [], [], [], []
    eff_sensor = []
    stops: dict[str, list[str]] = {j: [] for j in joints}
    for tr in trajectories:
        period = tr.sample_period
        qs = np.column_stack([tr.positions[j] for j in joints])
        sig_q = np.array([features.noise_level(qs[:, k]) for k in range(len(joints))])
        pos_noise.append(sig_q)
        taus = np.column_stack([tr.efforts.get(j, np.zeros(tr.n)) for j in joints])
        eff_noise.append(np.array([features.noise_level(taus[:, k]) if j in tr.efforts
                                   else 0.0 for k, j in enumerate(joints)]))
        eff_sensor.append(np.array([features.sensor_noise_level(taus[:, k], qs[:, k])
                                    if j in tr.efforts else 0.0
                                    for k, j in enumerate(joints)]))
        x0s.append(np.zeros((len(joints), 2)))
        x0_free.append(np.zeros((len(joints), 2), bool))
        x0_se.append(np.zeros((len(joints), 2)))
        for k in range(len(joints)):
            (q0, v0), (sq, sv) = _initial_state(tr.time, qs[:, k], sig_q[k])
            x0s[-1][k] = (q0, v0)
            x0_se[-1][k] = (sq, sv)
            moving = abs(v0) > 4 * sv
            if not moving:
                # a slow creep hides in 40 ms of noise but drifts a replay away over
                # seconds (a piece that starts where a push was left out): a longer look
                (_, v_long), (_, sv_long) = _initial_state(tr.time, qs[:, k], sig_q[k],
                                                           CREEP_SECONDS)
                if abs(v_long) > 4 * sv_long:
                    moving, x0s[-1][k, 1] = True, v_long
            x0_free[-1][k] = (True, moving)
            if not moving:
                x0s[-1][k, 1] = 0.0
        if not inverse:
            continue
        smoothed = [features.derivatives(qs[:, k], period) for k in range(len(joints))]
        q_s = np.column_stack([s[0] for s in smoothed])
        dq = np.column_stack([s[1] for s in smoothed])
        ddq = np.column_stack([s[2] for s in smoothed])
        tau_d = [features.derivatives(features.despike(taus[:, k])[0], period)
                 for k in range(len(joints))]
        tau_s = np.column_stack([d[0] for d in tau_d])
        tau_dt = np.column_stack([d[1] for d in tau_d])
        tau_rb = rigid_effort(spec, joints, q_s, dq, ddq)
        tau_rot = tau_rb - rigid_effort(spec, joints, q_s, dq, ddq, point_masses=True)
        eps = 1e-5 * max(float(np.ptp(qs)), 1e-3)
        tau_dq = (rigid_effort(spec, joints, q_s + eps, dq, ddq) - tau_rb) / eps
        tau_dq += np.array([obj.joint(j).dynamics.stiffness for j in joints])
        w = features.smoothing_window(period)
        dq_noise = sig_q * features.derivative_gain(period)
        usable = np.ones(tr.n, bool)
        usable[: w // 2 + 1] = False
        usable[-(w // 2 + 1):] = False
        seen = stops_seen(spec, joints, tr, {j: obj.joint(j).dynamics.armature
                                             for j in joints})
        for j, sides in zip(joints, seen, strict=True):
            for side in sides:
                if side not in stops[j]:
                    stops[j].append(side)
        signals.append(Signals(q_s, dq, ddq, tau_s, tau_rb, tau_rot, tau_dq, tau_dt,
                               dq_noise, usable, seen))

    # samples near an end stop are left out of the inverse-dynamics start (impacts)
    for sig in signals:
        for k, j in enumerate(joints):
            if not stops[j]:
                continue
            lo, hi = sig.q[:, k].min(), sig.q[:, k].max()
            span = hi - lo
            if "upper" in stops[j]:
                sig.usable &= sig.q[:, k] < hi - 0.05 * span
            if "lower" in stops[j]:
                sig.usable &= sig.q[:, k] > lo + 0.05 * span

    contexts, effects = {}, {}
    for k, name in enumerate(joints):
        j = obj.joint(name)
        q_all = np.concatenate([tr.positions[name] for tr in trajectories])
        inertia = float(nominal.dof_M0[dadr[k]]) if hasattr(nominal, "dof_M0") else 1.0
        scale = float("nan")  # from the inverse dynamics, where computed
        if inverse:
            tau_all = np.concatenate([np.abs(s.tau[:, k]) for s in signals] +
                                     [np.abs(s.tau_rb[:, k]) for s in signals])
            scale = float(np.percentile(tau_all, 95)) if tau_all.size else 1.0
            if scale <= 0:
                scale = inertia * 1.0
        ctx = JointContext(
            joint=name, angular=j.type.angular, dynamics=j.dynamics, limits=j.limits,
            bodies=tuple(subtree_bodies(obj, name)),
            gravity_loaded=gravity_loaded(obj, name, *([gravity] if gravity else [])),
            inertia=inertia, q_low=float(q_all.min()), q_high=float(q_all.max()),
            effort_scale=scale, stops=tuple(sorted(stops[name])), timestep=MAX_TIMESTEP,
            law=base_law(obj, name),
            has_effort=any(name in tr.efforts or tr.law() is not None
                           for tr in trajectories),
            actuated=_actuated(j, trajectories),
            sensor_offset=sensor_offset(obj, name),
            measured_effort=any(name in tr.efforts and tr.law() is None
                                for tr in trajectories),
            effort_delay=effort_delay(obj, name),
        )
        contexts[name] = ctx
        effects[name] = {e.variant: e for e in library(ctx)} if inverse else {}
    nonsmooth = False
    for name in joints:
        j, ctx = obj.joint(name), contexts[name]
        margin = 0.05 * max(ctx.q_high - ctx.q_low, 1e-9)
        if j.dynamics.friction > 0 or ctx.law.damping_asym:
            nonsmooth = True
        if j.limits is not None and (ctx.q_low < j.limits.lower + margin
                                     or ctx.q_high > j.limits.upper - margin):
            nonsmooth = True
    links = [(t - 1, t) for t in range(1, len(trajectories)) if trajectories[t].continues]
    return Problem(obj, joints, trajectories, spec, contexts, effects, pos_noise, eff_noise,
                   signals, x0s, x0_free, x0_se, stops, nonsmooth,
                   {name: contexts[name].law for name in joints}, links, eff_sensor)
