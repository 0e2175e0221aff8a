"""Measured-looking joint trajectories with hidden effects, made independently of the code
under test: the joint's equation of motion is written out here and integrated with scipy's
``solve_ivp`` (not MuJoCo), Coulomb friction as true stick-slip (events at zero velocity and
at breakaway), end stops as stiff spring-dampers. The nominal model (an ArticulatedObject)
is what the calibration is given; the truth is the nominal model plus one or two effects.

Realistic sensing: Gaussian noise plus encoder quantisation on the position, noise on the
measured effort.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

from real2code_export import transforms as tf
from real2code_export.model import ArticulatedObject, Inertial, Joint, Limits, Part

GRAVITY = 9.81
KINDS = ("door", "drawer", "lid")
EFFECTS = ("damping", "friction", "asymmetric_friction", "spring", "limit", "inertia",
           "armature", "offset")


@dataclass
class Case:
    kind: str
    seed: int
    obj: ArticulatedObject  # the nominal model given to the calibration
    joint: str
    truth: dict[str, dict[str, float]]  # effect -> its parameters (calibrate's names)
    time: np.ndarray
    position: np.ndarray  # measured (noisy, quantised)
    effort: np.ndarray  # measured
    true_position: np.ndarray
    noise: float
    quantum: float
    notes: dict = field(default_factory=dict)

    def csv(self) -> str:
        lines = [f"time,{self.joint},{self.joint}.effort"]
        lines += [f"{t!r},{q!r},{u!r}" for t, q, u in
                  zip(self.time.tolist(), self.position.tolist(), self.effort.tolist(),
                      strict=True)]
        return "\n".join(lines) + "\n"


# -- nominal objects ---------------------------------------------------------------------------
def _box_inertial(extents, mass, center) -> Inertial:
    x, y, z = extents
    inertia = mass / 12.0 * np.diag([y * y + z * z, x * x + z * z, x * x + y * y])
    return Inertial(mass, np.asarray(center, float), inertia)


def nominal_object(kind: str, rng: np.random.Generator) -> tuple[ArticulatedObject, str]:
    frame = Part("frame", inertial=_box_inertial([0.5, 0.5, 0.8], 20.0, [0, 0, 0.4]))
    if kind == "door":
        w, h, t = rng.uniform(0.35, 0.7), rng.uniform(0.5, 1.0), 0.02
        m = rng.uniform(3.0, 10.0)
        panel = Part("door", inertial=_box_inertial([t, w, h], m, [0, w / 2, 0]))
        joint = Joint("hinge", "revolute", "frame", "door",
                      origin=tf.make(None, [0.25, -0.25, 0.4]), axis=[0, 0, 1],
                      limits=Limits(-0.3, 2.6), state=0.0)
    elif kind == "lid":
        w, length, t = rng.uniform(0.3, 0.6), rng.uniform(0.25, 0.5), 0.015
        m = rng.uniform(0.8, 3.0)
        panel = Part("lid", inertial=_box_inertial([w, t, length], m, [0, 0, -length / 2]))
        joint = Joint("hinge", "revolute", "frame", "lid",
                      origin=tf.make(None, [0.0, 0.26, 0.8]), axis=[1, 0, 0],
                      limits=Limits(-2.0, 2.0), state=0.0)
    else:
        m = rng.uniform(2.0, 8.0)
        panel = Part("drawer", inertial=_box_inertial([0.4, 0.4, 0.15], m, [0, 0, 0]))
        joint = Joint("slide", "prismatic", "frame", "drawer",
                      origin=tf.make(None, [0.1, 0.0, 0.5]), axis=[1, 0, 0],
                      limits=Limits(-0.2, 0.8), state=0.0)
    obj = ArticulatedObject(f"synthetic_{kind}", [frame, panel], [joint])
    return obj, joint.name


# -- the joint's own equation of motion (independent of MuJoCo) ---------------------------------
@dataclass
class JointPhysics:
    """1-DoF rigid body about/along one axis, with the hidden effects."""

    inertia: float  # kg m^2 or kg about/along the axis (nominal)
    mass: float
    com: np.ndarray  # in the joint frame
    axis: np.ndarray
    rotation0: np.ndarray  # joint frame orientation in the world
    angular: bool
    scale: float = 1.0  # inertia effect: mass and inertia x scale
    moment_scale: float = 1.0  # mass distribution: the first moment (gravity) alone x this
    rotational_scale: float = 1.0  # mass distribution: the inertia about the axis alone x this
    armature: float = 0.0
    damping_pos: float = 0.0
    damping_neg: float = 0.0
    friction_pos: float = 0.0
    friction_neg: float = 0.0
    stiffness: float = 0.0
    spring_ref: float = 0.0
    offset: float = 0.0
    stop: float | None = None
    stop_side: int = 1  # +1: the stop is an upper bound, -1 a lower bound
    stop_stiffness: float = 0.0
    stop_damping: float = 0.0

    @property
    def total_inertia(self) -> float:
        return self.scale * self.rotational_scale * self.inertia + self.armature

    def __post_init__(self) -> None:
        # gravity's generalized force as g_cos * cos(q) + g_sin * sin(q) (hinge) or a
        # constant (slide): the centre of mass turns about the axis by Rodrigues' formula.
        weight = self.mass * np.array([0.0, 0.0, -GRAVITY])
        axis_world = self.rotation0 @ self.axis
        if not self.angular:
            self._g = (float(weight @ axis_world), 0.0)
            return
        c_perp = self.com - self.axis * float(self.axis @ self.com)
        u_cos = self.rotation0 @ c_perp
        u_sin = self.rotation0 @ np.cross(self.axis, self.com)
        self._g = (float(np.cross(u_cos, weight) @ axis_world),
                   float(np.cross(u_sin, weight) @ axis_world))

    def gravity(self, q: float) -> float:
        s = self.scale * self.moment_scale
        if not self.angular:
            return s * self._g[0]
        return s * (self._g[0] * math.cos(q) + self._g[1] * math.sin(q))

    def passive_except_friction(self, q: float, v: float) -> float:
        f = -self.stiffness * (q - self.spring_ref) + self.offset
        b = self.damping_pos if v > 0 else self.damping_neg
        f -= b * v
        if self.stop is not None:
            pen = (q - self.stop) * self.stop_side
            if pen > 0:
                push = self.stop_stiffness * pen + self.stop_damping * v * self.stop_side
                f -= self.stop_side * max(push, 0.0)
        return f


def _inertia_about_axis(inertial: Inertial, axis: np.ndarray) -> float:
    c = inertial.com
    parallel = inertial.mass * (float(c @ c) * np.eye(3) - np.outer(c, c))
    return float(axis @ (inertial.inertia + parallel) @ axis)


def physics_for(obj: ArticulatedObject, joint: str) -> JointPhysics:
    j = obj.joint(joint)
    part = obj.part(j.child)
    angular = j.type.angular
    inertia = _inertia_about_axis(part.inertial, j.axis) if angular else part.inertial.mass
    return JointPhysics(inertia=inertia, mass=part.inertial.mass, com=part.inertial.com,
                        axis=np.asarray(j.axis, float), rotation0=j.origin[:3, :3],
                        angular=angular)


def integrate(p: JointPhysics, effort, t_end: float, q0: float, v0: float,
              times: np.ndarray) -> np.ndarray:
    """Positions at ``times`` (from t = 0 in state q0, v0): slip phases by solve_ivp, stick
    phases held until the other forces break away (exact Coulomb stick-slip)."""
    out = np.full(len(times), np.nan)
    advance(p, effort, 0.0, t_end, q0, v0, times, out)
    return out


def advance(p: JointPhysics, effort, t: float, t_end: float, q: float, v: float,
            times: np.ndarray, out: np.ndarray) -> tuple[float, float]:
    """Integrate from state (q, v) at ``t`` to ``t_end``; positions at the ``times`` inside
    go into ``out``; returns the state at ``t_end``."""
    has_friction = p.friction_pos > 0 or p.friction_neg > 0
    stick_tol = 1e-9

    def others(tt, qq, vv):
        return effort(tt) + p.gravity(qq) + p.passive_except_friction(qq, vv)

    while t < t_end - 1e-12:
        direction = np.sign(v)
        if has_friction and direction == 0:
            f = others(t, q, 0.0)
            if -p.friction_neg - stick_tol <= f <= p.friction_pos + stick_tol:
                # stick: q held until the other forces exceed the breakaway friction
                def leave_pos(tt, y, q=q):
                    return others(tt, q, 0.0) - p.friction_pos

                def leave_neg(tt, y, q=q):
                    return others(tt, q, 0.0) + p.friction_neg

                leave_pos.terminal = leave_neg.terminal = True
                sol = solve_ivp(lambda tt, y: [0.0], (t, t_end), [0.0],
                                events=[leave_pos, leave_neg], max_step=5e-3, rtol=1e-10,
                                atol=1e-12)
                t_next = sol.t[-1]
                mask = (times >= t - 1e-12) & (times <= t_next + 1e-12)
                out[mask] = q
                t = t_next
                if t >= t_end - 1e-12:
                    break
                direction = 1.0 if others(t, q, 0.0) > 0 else -1.0
            else:
                direction = 1.0 if f > 0 else -1.0

        # within a slip phase the friction force keeps its direction (the phase ends at v = 0)
        fric = 0.0
        if has_friction:
            fric = -(p.friction_pos if direction > 0 else p.friction_neg) * direction

        def rhs(tt, y, fric=fric):
            qq, vv = y
            return [vv, (others(tt, qq, vv) + fric) / p.total_inertia]

        def stopped(tt, y, direction=direction, t0=t):
            return y[1] if tt > t0 + 1e-9 else direction

        stopped.terminal = True
        stopped.direction = -direction if direction != 0 else 0
        sol = solve_ivp(rhs, (t, t_end), [q, v], dense_output=True,
                        events=stopped if has_friction else None, max_step=0.05,
                        rtol=1e-9, atol=1e-11, method="DOP853")
        t_next = sol.t[-1]
        mask = (times >= t - 1e-12) & (times <= t_next + 1e-12)
        if mask.any():
            out[mask] = sol.sol(times[mask])[0]
        q, v = sol.y[0, -1], sol.y[1, -1]
        t = t_next
        if has_friction and sol.status == 1:
            v = 0.0
    return q, v


# -- effort: smooth pushes (a person or a test rig), measured -----------------------------------
def push_profile(rng: np.random.Generator, amplitude: float, t_end: float):
    n = int(rng.integers(3, 5))
    starts = np.sort(rng.uniform(0.05, t_end * 0.7, n))
    widths = rng.uniform(0.15, 0.4, n)
    signs = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    amps = amplitude * rng.uniform(0.6, 1.0, n) * signs

    def effort(t: float) -> float:
        f = 0.0
        for s, w, a in zip(starts, widths, amps, strict=True):
            if s <= t <= s + w:
                f += a * 0.5 * (1 - math.cos(2 * math.pi * (t - s) / w))
        return f

    return effort


# -- cases --------------------------------------------------------------------------------------
def _draw_effects(rng: np.random.Generator, kind: str, n_effects: int) -> list[str]:
    pool = list(EFFECTS)
    while True:
        chosen = sorted(rng.choice(pool, size=n_effects, replace=False).tolist())
        s = set(chosen)
        if {"friction", "asymmetric_friction"} <= s or {"damping", "asymmetric_friction"} <= s:
            continue  # asymmetric friction already holds both
        if kind != "lid" and {"inertia", "armature"} <= s:
            continue  # the same extra inertia when gravity has no hold on the joint
        if {"spring", "offset"} <= s:
            continue  # a spring with a free rest position already holds a constant force
        if {"asymmetric_friction", "offset"} <= s or {"asymmetric_friction", "spring"} <= s:
            continue  # unequal Coulomb friction is itself a constant force
        return chosen


def make_case(seed: int, kind: str | None = None, n_effects: int | None = None,
              effects: list[str] | None = None, rate: float | None = None,
              duration: float | None = None) -> Case:
    """A case for ``seed``; redrawn (same seed, next attempt) while the motion would run
    into the nominal model's own joint limits, which the generator does not model."""
    kind = kind or KINDS[seed % 3]
    for attempt in range(20):
        case = _make_case(seed, attempt, kind, n_effects, effects, rate, duration)
        lim = case.obj.joint(case.joint).limits
        span = lim.upper - lim.lower
        if case.true_position.min() > lim.lower + 0.05 * span and \
                case.true_position.max() < lim.upper - 0.05 * span:
            return case
    raise RuntimeError(f"seed {seed}: no case within the nominal limits")


def _make_case(seed: int, attempt: int, kind: str, n_effects: int | None,
               effects: list[str] | None, rate: float | None, duration: float | None) -> Case:
    rng = np.random.default_rng([seed, attempt])
    obj, joint = nominal_object(kind, rng)
    p = physics_for(obj, joint)
    if effects is None:
        n_effects = int(rng.integers(1, 3)) if n_effects is None else n_effects
        effects = _draw_effects(rng, kind, n_effects) if n_effects else []

    inertia = p.inertia
    rate = float(rng.choice([250.0, 500.0])) if rate is None else float(rate)
    t_end = float(rng.uniform(2.5, 3.5)) if duration is None else float(duration)
    if kind == "lid":
        # pendulum-like: ~1 Hz swinging under gravity
        accel = 8.0
        q0 = float(rng.uniform(-0.3, 0.3))
    elif kind == "door":
        accel = 6.0
        q0 = float(rng.uniform(0.4, 0.8))
    else:
        accel = 1.2
        q0 = float(rng.uniform(0.1, 0.25))
    amplitude = accel * inertia
    effort_fn = push_profile(rng, amplitude, t_end)
    truth: dict[str, dict[str, float]] = {}
    scale_force = amplitude

    for e in effects:
        apply_effect(p, e, rng, inertia, scale_force, q0, truth)

    times = np.arange(0.0, t_end, 1.0 / rate)
    if "limit" in effects:
        # a stop inside the motion the joint would otherwise make
        free = integrate(p, effort_fn, t_end, q0, 0.0, times)
        hi, lo = free.max(), free.min()
        side = 1 if hi - q0 >= q0 - lo else -1
        extreme = hi if side > 0 else lo
        stop = q0 + (extreme - q0) * rng.uniform(0.55, 0.8)
        p.stop, p.stop_side = float(stop), side
        # a stiff, well-damped stop (wood or metal with a rubber bumper)
        omega = 2 * math.pi * rng.uniform(40.0, 60.0)
        p.stop_stiffness = p.total_inertia * omega**2
        p.stop_damping = 2 * rng.uniform(1.0, 1.5) * p.total_inertia * omega
        truth["limit"] = {"upper" if side > 0 else "lower": float(stop)}

    notes = {"inertia": inertia, "amplitude": amplitude, "rate": rate, "physics": p}
    return _measure(kind, seed, obj, joint, truth, p, effort_fn, times, q0, rng, notes)


def apply_effect(p: JointPhysics, e: str, rng: np.random.Generator, inertia: float,
                  scale_force: float, q0: float, truth: dict) -> None:
    """Draw effect ``e``'s hidden values into the physics ``p`` and ``truth``."""
    ang = p.angular
    if e == "damping":
        b = inertia / rng.uniform(0.6, 2.0)
        p.damping_pos = p.damping_neg = b
        truth[e] = {"damping": b}
    elif e == "friction":
        c = scale_force * rng.uniform(0.06, 0.15)
        p.friction_pos = p.friction_neg = c
        truth[e] = {"friction": c}
    elif e == "asymmetric_friction":
        c = scale_force * rng.uniform(0.06, 0.12)
        dc = c * rng.uniform(0.4, 0.7) * rng.choice([-1, 1])
        b = inertia / rng.uniform(0.8, 2.0)
        db = b * rng.uniform(0.4, 0.7) * rng.choice([-1, 1])
        p.friction_pos, p.friction_neg = c + dc, c - dc
        p.damping_pos, p.damping_neg = b + db, b - db
        truth[e] = {"friction_pos": c + dc, "friction_neg": c - dc,
                    "damping_pos": b + db, "damping_neg": b - db}
    elif e == "spring":
        period = rng.uniform(0.8, 1.6)
        k = inertia * (2 * math.pi / period) ** 2
        ref = q0 + rng.uniform(-0.3, 0.3) * (1.0 if ang else 0.2)
        p.stiffness, p.spring_ref = k, ref
        truth[e] = {"stiffness": k, "spring_ref": ref}
    elif e == "inertia":
        s = float(rng.choice([rng.uniform(0.6, 0.75), rng.uniform(1.35, 1.7)]))
        p.scale = s
        truth[e] = {"scale": s}
    elif e == "armature":
        a = inertia * rng.uniform(0.3, 0.6)
        p.armature = a
        truth[e] = {"armature": a}
    elif e == "offset":
        c = scale_force * rng.uniform(0.08, 0.15) * rng.choice([-1, 1])
        p.offset = c
        truth[e] = {"offset": c}


def _measure(kind, seed, obj, joint, truth, p, effort_fn, times, q0, rng, notes) -> Case:
    q_true = integrate(p, effort_fn, float(times[-1]) + 1e-9, q0, 0.0, times)
    if kind == "drawer":
        noise, quantum = 1e-4, 5e-5  # a draw-wire sensor
    else:
        noise, quantum = 3e-4, 2 * math.pi / 8192  # a 13-bit absolute encoder
    q_meas = np.round((q_true + rng.normal(0, noise, len(times))) / quantum) * quantum
    u_true = np.array([effort_fn(t) for t in times])
    # a load cell: noise 0.03 % of the peak push
    u_meas = u_true + rng.normal(0, 3e-4 * notes["amplitude"], len(times))
    return Case(kind, seed, obj, joint, truth, times, q_meas, u_meas, q_true, noise, quantum,
                notes={**notes, "u_true": u_true})


def rerun(case: Case, run: int) -> Case:
    """Another measured run of the same object with the same hidden effects: other pushes,
    another starting position (held-out data)."""
    rng = np.random.default_rng([case.seed, 1000 + run])
    p = case.notes["physics"]
    span = 0.1 if p.angular else 0.02
    q0 = float(case.true_position[0] + rng.uniform(-span, span))
    if p.stop is not None:  # start clear of the stop
        q0 = min(q0, p.stop - 0.02) if p.stop_side > 0 else max(q0, p.stop + 0.02)
    effort_fn = push_profile(rng, case.notes["amplitude"], float(case.time[-1]))
    return _measure(case.kind, case.seed, case.obj, case.joint, case.truth, p, effort_fn,
                    case.time, q0, rng, case.notes)
