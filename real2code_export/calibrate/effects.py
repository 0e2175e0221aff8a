"""The candidate effects: each a model extension with its parameters (nominal, bounds), a
function writing them into an MjSpec (after ``mujoco.sysid``'s Parameter design), the
generalized force MuJoCo has no joint attribute for, the columns of the inverse-dynamics
regressor used to start the fit, the test that says whether the effect is really there,
and how it is written into the model.

Sign convention for the regressor: the measured effort equals the rigid-body inverse
dynamics minus the passive forces, tau = s * tau_rb + a * ddq + b * dq + c * sgn(dq)
+ k * (q - q_ref) - offset (see :func:`columns`).

Equivalences decide which combinations are offered: direction-dependent Coulomb friction
(c+ for positive velocity, c- for negative) is exactly symmetric friction (c+ + c-) / 2 plus
a constant force -(c+ - c-) / 2, in slip and in stick alike, so ``asymmetric_friction``
excludes ``offset``; a spring with a free rest position holds a constant force too; and on
a joint gravity has no hold on, scaling the moving inertia and adding armature are the
same extra inertia (reported as one cause, ``inertia``, with ``armature`` as its alias);
on one it holds, armature is inertia about the axis alone, the first moment unchanged
(``armature``, with ``inertia`` as its alias, where the joint may hold a rotor).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import warn
from ..model import ArticulatedObject, Dynamics, Limits
from .simulate import SMOOTH_TIMESTEP, AppliedLaw, set_direction_dependent_damping

VOCABULARY = ("damping", "friction", "asymmetric_friction", "spring", "limit", "inertia",
              "armature", "offset", "encoder_offset", "effort_delay")
# causes on the sensor's side, not forces: the reading is the joint position plus a zero
# error (kept in the metadata, applied to every replay's reading)
SENSOR = ("encoder_offset", "effort_delay")
MAX_DELAY = 0.05  # s: the largest lag between the effort's and the position's clocks tried


@dataclass(frozen=True)
class JointContext:
    """What the candidates need to know about one measured joint and its data."""

    joint: str
    angular: bool
    dynamics: Dynamics
    limits: Limits | None
    bodies: tuple[str, ...]  # the parts that move with the joint
    gravity_loaded: bool
    inertia: float  # effective inertia at the joint (kg m^2 or kg), nominal model
    q_low: float  # measured range
    q_high: float
    effort_scale: float  # typical generalized force in the data (N m or N)
    stops: tuple[str, ...] = ()  # sides ('lower', 'upper') where the data show a stop
    timestep: float = 1e-3
    law: AppliedLaw = AppliedLaw()  # the model's own applied-force law (metadata)
    has_effort: bool = True  # some trajectory measures the effort (or closes the loop)
    # a rotor may drive the joint: the model declares one (armature, an effort limit) or
    # the data show the joint driven (a measured effort, a closed loop)
    actuated: bool = True
    sensor_offset: float = 0.0  # the model's encoder zero error (metadata), rad or m
    measured_effort: bool = False  # an effort is measured and replayed open loop
    effort_delay: float = 0.0  # the model's lag of the effort behind the position (s)

    def unit(self, kind: str) -> str:
        a = self.angular
        return {
            "damping": "N m s/rad" if a else "N s/m",
            "force": "N m" if a else "N",
            "stiffness": "N m/rad" if a else "N/m",
            "position": "rad" if a else "m",
            "inertia": "kg m^2" if a else "kg",
            "time": "s",
            "scale": "1",
        }[kind]


@dataclass(frozen=True)
class Param:
    effect: str
    joint: str
    name: str
    unit: str
    nominal: float
    lower: float
    upper: float
    null: float | None = None  # the value at which the effect is absent

    @property
    def key(self) -> str:
        return f"{self.joint}.{self.name}"


@dataclass(frozen=True)
class Effect:
    """One candidate effect on one joint."""

    name: str
    joint: str
    params: tuple[Param, ...]
    aliases: tuple[str, ...] = ()
    ctx: JointContext = field(repr=False, default=None)  # type: ignore[assignment]
    variant: str = ""  # unique within a joint's library ("limit:upper"); default: name
    # why this name rather than its aliases (which the data cannot tell from it)
    choice: str = ""

    def __post_init__(self) -> None:
        if not self.variant:
            object.__setattr__(self, "variant", self.name)

    # -- MjSpec ------------------------------------------------------------------------------
    def write(self, spec, v: dict[str, float]) -> None:
        j = spec.joint(self.joint)
        n = self.name
        if n == "damping":
            j.damping = [v["damping"], 0.0, 0.0]
        elif n == "friction":
            j.frictionloss = v["friction"]
        elif n == "asymmetric_friction":
            j.frictionloss = 0.5 * (v["friction_pos"] + v["friction_neg"])
            set_direction_dependent_damping(spec, self.joint, v["damping_pos"],
                                            v["damping_neg"])
        elif n == "spring":
            j.stiffness = [v["stiffness"], 0.0, 0.0]
            j.springref = v["spring_ref"]
        elif n == "limit":
            import mujoco

            lo, hi = _range(self.ctx)
            j.limited = mujoco.mjtLimited.mjLIMITED_TRUE
            j.range = [v.get("limit_lower", lo), v.get("limit_upper", hi)]
            j.solref_limit = [v["limit_timeconst"], v["limit_dampratio"]]
        elif n == "inertia":
            for name in self.ctx.bodies:
                _scale_body(spec, name, v.get("inertia_scale", 1.0),
                            v.get("rotational_scale", 1.0))
        elif n == "armature":
            j.armature = v["armature"]
        # encoder_offset: nothing in the dynamics (the replay adds it to the reading)

    def sysid_parameter(self):
        """This effect's parameters as one (vector) ``mujoco.sysid.Parameter`` whose
        modifier writes them into an MjSpec."""
        from mujoco import sysid

        names = [p.name for p in self.params]

        def modifier(spec, param) -> None:
            self.write(spec, dict(zip(names, np.atleast_1d(param.value).tolist(), strict=True)))

        return sysid.Parameter(f"{self.joint}.{self.name}", [p.nominal for p in self.params],
                               [p.lower for p in self.params], [p.upper for p in self.params],
                               modifier=modifier)

    def law(self, v: dict[str, float]) -> AppliedLaw:
        if self.name == "offset":
            return AppliedLaw(offset=v["offset"])
        if self.name == "asymmetric_friction":
            return AppliedLaw(friction_asym=0.5 * (v["friction_pos"] - v["friction_neg"]),
                              damping_asym=0.5 * (v["damping_pos"] - v["damping_neg"]))
        return AppliedLaw()

    # -- inverse-dynamics regressor (start values) ------------------------------------------
    def columns(self, q, dq, ddq, tau_rb, sgn, tau_rot=None, tau_dq=None, tau_dt=None
                ) -> tuple[np.ndarray, list[str]] | None:
        """Columns of tau = sum(column * coefficient); coefficients named (linear).
        ``tau_rot``: the part of ``tau_rb`` due to the parts' rotational inertia about
        their centres of mass; ``tau_dq``: the nominal effort's derivative by the position
        (an encoder zero error d reads q for the true q - d: tau(q - d) ~ tau - d tau_dq);
        ``tau_dt``: the measured effort's time derivative (an effort felt d seconds after
        it is recorded: u(t - d) ~ u - d u')."""
        n = self.name
        if n == "effort_delay":
            col = tau_dt if tau_dt is not None else np.zeros_like(q)
            return col[:, None], ["effort_delay"]
        if n == "encoder_offset":
            col = -(tau_dq if tau_dq is not None else np.zeros_like(q))
            return col[:, None], ["encoder_offset"]
        if n == "damping":
            return dq[:, None], ["damping"]
        if n == "friction":
            return sgn[:, None], ["friction"]
        if n == "asymmetric_friction":
            pos, neg = (sgn > 0).astype(float), (sgn < 0).astype(float)
            pos_s, neg_s = np.clip(sgn, 0, None), np.clip(sgn, None, 0)
            return (np.column_stack([pos_s, neg_s, dq * pos, dq * neg]),
                    ["friction_pos", "friction_neg", "damping_pos", "damping_neg"])
        if n == "spring":
            return np.column_stack([q, -np.ones_like(q)]), ["stiffness", "stiffness_x_ref"]
        if n == "inertia":
            rot = tau_rot if tau_rot is not None else np.zeros_like(tau_rb)
            names = [p.name for p in self.params]
            if names == ["inertia_scale"]:
                return tau_rb[:, None], ["inertia_scale"]
            if names == ["rotational_scale"]:  # the rest of tau_rb stays nominal
                return rot[:, None], ["rotational_excess"]
            return np.column_stack([tau_rb - rot, rot]), ["inertia_scale", "scale_x_rotational"]
        if n == "armature":
            return ddq[:, None], ["armature"]
        if n == "offset":
            return -np.ones_like(q)[:, None], ["offset"]
        return None  # limit: not linear in its parameters

    @property
    def coefficient_names(self) -> list[str]:
        """Names of the regressor coefficients (empty: not linear in its parameters)."""
        cols = self.columns(*(np.zeros(1),) * 6)
        return [] if cols is None else cols[1]

    def from_coefficients(self, coef: dict[str, float]) -> dict[str, float]:
        if self.name == "spring":
            k = coef["stiffness"]
            ref = coef["stiffness_x_ref"] / k if k > 1e-12 else self.params[1].nominal
            return {"stiffness": k, "spring_ref": ref}
        if self.name == "inertia" and "scale_x_rotational" in coef:
            s = coef["inertia_scale"]
            r = coef["scale_x_rotational"] / s if s > 1e-12 else 1.0
            return {"inertia_scale": s, "rotational_scale": r}
        if self.name == "inertia" and "rotational_excess" in coef:
            return {"rotational_scale": 1.0 + coef["rotational_excess"]}
        return dict(coef)

    # -- is it there? ------------------------------------------------------------------------
    def strength(self, v: dict[str, float], cov: dict[tuple[str, str], float]) -> tuple[float, float]:
        """(departure from absence, its standard error); the effect is present when the
        departure exceeds its 95 % interval."""
        n = self.name

        def var(a, b=None):
            return cov.get((a, b or a), math.inf)

        if n == "asymmetric_friction":
            # what only this effect explains: the viscous asymmetry (b+ - b-) / 2
            d = 0.5 * (v["damping_pos"] - v["damping_neg"])
            s2 = 0.25 * (var("damping_pos") + var("damping_neg")
                         - 2 * cov.get(("damping_pos", "damping_neg"), 0.0))
            return abs(d), math.sqrt(max(s2, 0.0))
        if n == "limit":
            return math.inf, 0.0  # judged by BIC and by the motion it changes
        if n == "inertia":  # the parameter that departs most from its absence
            best = (0.0, math.inf)
            for x in self.params:
                d, se = abs(v[x.name] - 1.0), math.sqrt(max(var(x.name), 0.0))
                if se == 0 or d / se > best[0] / max(best[1], 1e-300):
                    best = (d, se)
            return best
        p = {"damping": "damping", "friction": "friction", "spring": "stiffness",
             "armature": "armature", "offset": "offset",
             "encoder_offset": "encoder_offset", "effort_delay": "effort_delay"}[n]
        null = next(x.null for x in self.params if x.name == p)
        return abs(v[p] - (null or 0.0)), math.sqrt(max(var(p), 0.0))

    def null_values(self, v: dict[str, float]) -> dict[str, float] | None:
        """Parameter values at which this effect is absent (None: no such continuous
        path, as for an end stop)."""
        n = self.name
        if n == "asymmetric_friction":
            c = 0.5 * (v["friction_pos"] + v["friction_neg"])
            b = 0.5 * (v["damping_pos"] + v["damping_neg"])
            return {"friction_pos": c, "friction_neg": c, "damping_pos": b, "damping_neg": b}
        if n == "limit":
            return None
        return {p.name: p.null for p in self.params if p.null is not None}

    def one_way(self, v: dict[str, float], halfwidth: dict[str, float]) -> bool:
        """Direction-dependent friction that dissipates nothing in one direction: that
        direction's friction and damping both within their 95 % intervals of zero. No
        bearing or slide rubs one way only; such a fit has put a constant force into the
        Coulomb asymmetry (friction one way only is symmetric friction plus a constant
        force) beside whatever else holds the rest position, and names a direction
        dependence the joint does not have."""
        if self.name != "asymmetric_friction":
            return False
        return any(all(v[f"{kind}_{side}"] <= halfwidth.get(f"{kind}_{side}", math.inf)
                       for kind in ("friction", "damping")) for side in ("pos", "neg"))

    # -- the model ---------------------------------------------------------------------------
    def apply_to_model(self, obj: ArticulatedObject, v: dict[str, float],
                       extras: dict[str, dict]) -> None:
        """Write the fitted values into ``obj``; what the model has no field for goes to
        ``extras`` (kept in ``metadata['real2code:dynamics']``)."""
        j = obj.joint(self.joint)
        d = j.dynamics
        n = self.name
        if n == "damping":
            d.damping = v["damping"]
        elif n == "friction":
            d.friction = v["friction"]
        elif n == "asymmetric_friction":
            d.friction = 0.5 * (v["friction_pos"] + v["friction_neg"])
            d.damping = 0.5 * (v["damping_pos"] + v["damping_neg"])
            extras["asymmetric_friction"] = {k: float(v[k]) for k in
                                             ("friction_pos", "friction_neg", "damping_pos",
                                              "damping_neg")}
        elif n == "spring":
            d.stiffness = v["stiffness"]
            d.spring_ref = v["spring_ref"]
        elif n == "limit":
            lo, hi = _range(self.ctx)
            old = j.limits or Limits(lo, hi)
            lower = v.get("limit_lower", old.lower)
            upper = v.get("limit_upper", old.upper)
            j.limits = Limits(lower, upper, old.effort, old.velocity)
            if not lower <= j.state <= upper:
                # the measured stop wins over the observed state (a keyframe): moved to the
                # nearest limit, as the MJCF reader repairs a state outside its range
                state = min(max(j.state, lower), upper)
                warn(f"joint {self.joint!r}: observed state {j.state:.6g} is outside the "
                     f"measured stop's range [{lower:.6g}, {upper:.6g}]; moved to {state:.6g}")
                j.state = state
            extras["limit"] = {"timeconst": float(v["limit_timeconst"]),
                               "dampratio": float(v["limit_dampratio"])}
        elif n == "inertia":
            s, r = v.get("inertia_scale", 1.0), v.get("rotational_scale", 1.0)
            for name in self.ctx.bodies:
                part = obj.part(name)
                if part.inertial is not None:
                    part.inertial.mass *= s
                    part.inertial.inertia = part.inertial.inertia * (s * r)
        elif n == "armature":
            d.armature = v["armature"]
        elif n == "offset":
            extras["offset"] = {"effort": float(v["offset"])}
        elif n == "encoder_offset":
            extras["encoder_offset"] = {"position": float(v["encoder_offset"])}
        elif n == "effort_delay":
            extras["effort_delay"] = {"seconds": float(v["effort_delay"])}


def _range(ctx: JointContext) -> tuple[float, float]:
    if ctx.limits is not None:
        return ctx.limits.lower, ctx.limits.upper
    return -math.pi, math.pi


def _scale_body(spec, name: str, s: float, r: float = 1.0) -> None:
    """Mass x s (its weight and its inertia about the joint with it), rotational inertia
    about the centre of mass x s r."""
    body = spec.body(name)
    if body is None:
        return
    body.mass = body.mass * s
    full = np.asarray(body.fullinertia, float)
    if np.all(np.isfinite(full)):
        body.fullinertia = full * (s * r)
    else:
        body.inertia = np.asarray(body.inertia, float) * (s * r)


# -- the library -----------------------------------------------------------------------------
def library(ctx: JointContext) -> list[Effect]:
    """Every candidate effect for one joint, with bounds wide enough for any real object."""
    d, j = ctx.dynamics, ctx.joint
    inertia = max(ctx.inertia, 1e-9)
    force = max(ctx.effort_scale, 1e-9)
    span = max(ctx.q_high - ctx.q_low, 1e-6)
    u = ctx.unit

    def p(effect, name, kind, nominal, lower, upper, null=None) -> Param:
        return Param(effect, j, name, u(kind), float(nominal), float(lower), float(upper), null)

    # explicit integration at the smooth step must stay stable: damping rate b/I and
    # spring frequency sqrt(k/I) below ~1/step
    b_max = max(2.0 * inertia / SMOOTH_TIMESTEP, 10 * d.damping)
    c_max = max(10 * force, 10 * d.friction)
    k_max = max(inertia / SMOOTH_TIMESTEP**2, 10 * d.stiffness)
    out = [
        Effect("damping", j, (p("damping", "damping", "damping", d.damping, 0, b_max,
                                d.damping),), ctx=ctx),
        Effect("friction", j, (p("friction", "friction", "force", d.friction, 0, c_max,
                                 d.friction),), ctx=ctx),
        Effect("asymmetric_friction", j, (
            p("asymmetric_friction", "friction_pos", "force",
              d.friction + ctx.law.friction_asym, 0, c_max),
            p("asymmetric_friction", "friction_neg", "force",
              max(d.friction - ctx.law.friction_asym, 0.0), 0, c_max),
            p("asymmetric_friction", "damping_pos", "damping",
              d.damping + ctx.law.damping_asym, 0, b_max),
            p("asymmetric_friction", "damping_neg", "damping",
              max(d.damping - ctx.law.damping_asym, 0.0), 0, b_max),
        ), ctx=ctx, aliases=("friction+offset",),
            choice="direction-dependent Coulomb friction is exactly symmetric friction plus a "
                   "constant force (in slip and in stick): named only because the viscous "
                   "part differs with the direction too, which no constant force explains"),
        Effect("spring", j, (
            p("spring", "stiffness", "stiffness", d.stiffness, 0, k_max, d.stiffness),
            p("spring", "spring_ref", "position", d.spring_ref if d.stiffness else
              0.5 * (ctx.q_low + ctx.q_high), ctx.q_low - 10 * span, ctx.q_high + 10 * span),
        ), ctx=ctx),
        Effect("offset", j, (p("offset", "offset", "force", ctx.law.offset, -c_max, c_max,
                                 ctx.law.offset),), ctx=ctx,
               aliases=("encoder_offset",) if _zero_shows(ctx) else (),
               choice="a constant force and a zero error of the encoder both move the rest "
                      "position; the force fits better here"),
    ]
    # Mass off (with its weight), and where gravity makes them differ the rotational
    # inertia about the centres of mass besides. Without a measured effort the scale of
    # every mass is invisible (gravity and inertia scale together): only the rotational
    # part is left, and on a joint gravity has no hold on nothing at all.
    inertia_params = []
    if ctx.has_effort:
        inertia_params.append(p("inertia", "inertia_scale", "scale", 1.0, 0.05, 20.0, 1.0))
    if ctx.gravity_loaded and ctx.angular:
        inertia_params.append(p("inertia", "rotational_scale", "scale", 1.0, 0.05, 20.0, 1.0))
    # Added inertia and a rotor's armature move the joint alike where gravity has no hold
    # on it, and wherever no effort is measured (then only their sum against the weight's
    # moment shows); a rotor is named only on a joint that may have one.
    rotor_alike = not ctx.gravity_loaded or not ctx.has_effort
    rotor_reason = ("gravity has no hold on this joint" if not ctx.gravity_loaded else
                    "no effort is measured")
    if inertia_params:
        out.append(Effect(
            "inertia", j, tuple(inertia_params),
            aliases=("armature",) if rotor_alike else (), ctx=ctx,
            choice=(f"{rotor_reason}: added inertia and a rotor's armature move the joint "
                    "alike; " + ("no actuator is declared or measured, so the mass "
                                 "distribution is named, not a rotor" if not ctx.actuated
                                 else "reported as the parts' inertia")) if rotor_alike
            else ""))
    if ctx.gravity_loaded and ctx.actuated and ctx.has_effort:
        # a rotor's armature adds inertia about the axis alone, as the parts' own inertia
        # about their centres of mass does: the data cannot tell the two apart
        out.append(Effect("armature", j, (p("armature", "armature", "inertia", d.armature, 0,
                                            20 * inertia, d.armature),), ctx=ctx,
                          aliases=("inertia",),
                          choice="a rotor's armature and the parts' inertia about their own "
                                 "centres of mass both add inertia about the axis alone (the "
                                 "first moment unchanged); the joint may hold a rotor (an actuator "
                                 "declared, or the joint driven), so the rotor is named"))
    if _zero_shows(ctx):
        # where the position has an absolute meaning (gravity or a spring pulls toward a
        # place) a zero error of the encoder shows, and must not pass for a force
        out.append(Effect("encoder_offset", j, (
            p("encoder_offset", "encoder_offset", "position", ctx.sensor_offset,
              ctx.sensor_offset - 0.5 * span - 0.1, ctx.sensor_offset + 0.5 * span + 0.1,
              ctx.sensor_offset),), ctx=ctx, aliases=("offset",),
            choice="a constant force and a zero error of the encoder both move the rest "
                   "position; the zero error fits better here (a sensor's cause, not a "
                   "force)"))
    if ctx.measured_effort:
        # the effort and the position sampled by two clocks: the joint feels the effort
        # recorded d seconds earlier (a sensor's cause, not a force)
        out.append(Effect("effort_delay", j, (
            p("effort_delay", "effort_delay", "time", ctx.effort_delay, -MAX_DELAY,
              MAX_DELAY, ctx.effort_delay),), ctx=ctx))
    for sides in _limit_sides(ctx):
        params = []
        variant = "limit:" + "+".join(sides)
        for side in sides:
            edge = ctx.q_high if side == "upper" else ctx.q_low
            outward = 0.05 * span if side == "upper" else -0.05 * span
            lo, hi = sorted((edge - 0.5 * outward, edge + 2 * outward))
            params.append(p("limit", f"limit_{side}", "position", edge, lo, hi))
        # the stop's softness: MuJoCo's solreflimit (time constant, damping ratio)
        params.append(p("limit", "limit_timeconst", "time", 0.01, 2 * ctx.timestep, 0.1))
        params.append(p("limit", "limit_dampratio", "scale", 1.0, 0.05, 3.0))
        out.append(Effect("limit", j, tuple(params), ctx=ctx, variant=variant))
    return out


def readings(e: Effect, beside: set[str]) -> tuple[tuple[str, ...], str]:
    """What the data cannot tell effect ``e`` from, given the names of the effects chosen
    beside it on its joint, and why this name was chosen: ``e``'s aliases, and a constant
    force named beside symmetric friction, which together are direction-dependent Coulomb
    friction (c+ = c - f, c- = c + f, in slip and in stick alike: no data tell them
    apart)."""
    if e.name == "offset" and "friction" in beside and "asymmetric_friction" not in beside:
        return (*e.aliases, "asymmetric_friction"), (
            (e.choice + "; " if e.choice else "") +
            "symmetric friction and a constant force are exactly direction-dependent "
            "Coulomb friction; named as symmetric friction and a force because the "
            "viscous part shows no direction dependence (which no constant force "
            "explains), so the reading with fewer parameters is kept")
    return e.aliases, e.choice


def _zero_shows(ctx: JointContext) -> bool:
    """Whether an encoder's zero error shows in the motion (the dynamics depend on where
    the joint is: gravity, a spring)."""
    return ctx.gravity_loaded or ctx.dynamics.stiffness > 0


def _limit_sides(ctx: JointContext) -> list[tuple[str, ...]]:
    """One stop per side where one may be, and both together when there are two."""
    sides = [(s,) for s in ctx.stops]
    if len(ctx.stops) > 1:
        sides.append(tuple(ctx.stops))
    return sides


# -- which combinations are offered ----------------------------------------------------------
EXCLUSIVE = {
    frozenset({"asymmetric_friction", "friction"}),
    frozenset({"asymmetric_friction", "damping"}),
    frozenset({"asymmetric_friction", "offset"}),
    frozenset({"spring", "offset"}),
    frozenset({"encoder_offset", "offset"}),
}
# (asymmetric friction with a spring is offered: its viscous asymmetry is identifiable,
# while its Coulomb asymmetry and the spring's rest position share one constant force and
# are reported as not identifiable.)
# a move that refines what is already there: the refined effects make way for it
REFINES = {"asymmetric_friction": {"friction", "damping", "offset"}}


def _name(variant: str) -> str:
    return variant.split(":", 1)[0]


def valid(variants: set[str]) -> bool:
    names = [_name(v) for v in variants]
    if len(names) != len(set(names)):  # one variant of each effect
        return False
    return not any(pair <= set(names) for pair in EXCLUSIVE)


def extensions(current: tuple[str, ...], available: list[str]) -> list[tuple[str, ...]]:
    """Candidate structures (effect variants) one step richer than ``current``: add one
    effect, or refine symmetric friction into direction-dependent friction; with an end
    stop available, also each of those plus the stop."""
    out = _extensions(current, available)
    stops = [v for v in available if _name(v) == "limit"]
    if stops and not any(_name(v) == "limit" for v in current):
        for key in list(out):
            if any(_name(v) == "limit" for v in key):
                continue
            for stop in stops:
                paired = tuple(sorted(set(key) | {stop}))
                if paired not in out:
                    out.append(paired)
    return out


def _extensions(current: tuple[str, ...], available: list[str]) -> list[tuple[str, ...]]:
    out = []
    have = set(current)
    have_names = {_name(v) for v in have}
    for variant in available:
        name = _name(variant)
        if variant in have:
            continue
        new = have | {variant}
        if name in REFINES and have_names & {"friction", "damping"}:
            new = {v for v in have if _name(v) not in REFINES[name]} | {variant}
        elif name in REFINES:
            continue  # direction dependence is a refinement of friction already named
        if valid(new):
            key = tuple(sorted(new))
            if key not in out:
                out.append(key)
    return out
