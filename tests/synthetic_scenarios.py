"""The data users have, generated independently of the code under test (the joint's own
equation of motion and scipy's integrator, synthetic_joint_data.py): runs measured the way
real rigs measure them, each with hidden effects drawn at random within its scenario.

Scenarios (``SCENARIOS``):
- ``pushed``: pushes by a load cell from rest, effort measured (the classic rig);
- ``released``: position only, the run starts mid-motion (a door pushed and let go, a lid
  swinging);
- ``released_at_rest``: position only, a lid let go at rest from an angle;
- ``drift``: a position loop drives a slide or a door (no gravity: the plant is an
  integrator) and only the measured effort is written: an open-loop replay drifts;
- ``closed_loop``: the same kind of loop declared in an experiment file (PD on a reference
  column, a velocity estimate over some taps, saturation, a gain, sometimes pulses added);
- ``mass_distribution``: a lid whose centre of mass and inertia about the axis are both off
  (not one scale factor);
- ``sensor_offset``: the encoder's zero is off (a lid: gravity shows where down is);
- ``sensor_delay``: the position is recorded late against the effort;
- ``unmeasured_push``: a push in the middle of a run that no column holds;
- ``stop``: a door or drawer meets a stop short of its nominal range.

Every scenario but those whose point is one effect also comes effect-free. Durations,
sample rates, objects, gains, starting states and effect sizes are drawn per seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from real2code_export.model import ArticulatedObject

from synthetic_joint_data import (
    EFFECTS,
    JointPhysics,
    advance,
    apply_effect,
    integrate,
    nominal_object,
    physics_for,
    push_profile,
)


@dataclass(frozen=True)
class Scenario:
    kinds: tuple[str, ...]
    drive: str  # "pushed" | "released" | "at_rest" | "loop"
    declared_loop: bool = False  # the loop is written in an experiment file
    forced: tuple[str, ...] = ()  # the effect the scenario is about
    clean: bool = True  # also comes effect-free
    duration: tuple[float, float] = (2.5, 4.0)
    rates: tuple[float, ...] = (250.0, 500.0)


SCENARIOS = {
    "pushed": Scenario(("door", "drawer", "lid"), "pushed", duration=(1.5, 5.0),
                       rates=(200.0, 250.0, 500.0, 1000.0)),
    "released": Scenario(("door", "drawer", "lid"), "released", duration=(1.5, 5.0),
                         rates=(100.0, 250.0, 500.0, 1000.0)),
    "released_at_rest": Scenario(("lid",), "at_rest", duration=(2.0, 6.0)),
    "drift": Scenario(("door", "drawer"), "loop", duration=(4.0, 8.0), rates=(250.0, 500.0)),
    "closed_loop": Scenario(("door", "drawer", "lid"), "loop", declared_loop=True,
                            duration=(3.0, 6.0), rates=(250.0, 500.0)),
    "mass_distribution": Scenario(("lid",), "pushed", forced=("mass_distribution",),
                                  clean=False),
    "sensor_offset": Scenario(("lid",), "either", forced=("encoder_offset",), clean=False),
    "sensor_delay": Scenario(("door", "drawer", "lid"), "pushed", forced=("effort_delay",),
                             clean=False, rates=(500.0, 1000.0)),
    "unmeasured_push": Scenario(("door", "drawer", "lid"), "either", duration=(3.0, 5.0)),
    "stop": Scenario(("door", "drawer"), "either", forced=("limit",), clean=False),
}
NAMES = tuple(SCENARIOS)
ACCEL = {"lid": 8.0, "door": 6.0, "drawer": 1.2}  # push amplitude / inertia


@dataclass
class Run:
    time: np.ndarray
    true_position: np.ndarray
    columns: dict[str, np.ndarray]  # the CSV's columns after time
    experiment: dict[str, dict] | None = None  # tables of the experiment file


@dataclass
class ScenarioCase:
    seed: int
    scenario: str
    kind: str
    obj: ArticulatedObject
    joint: str
    truth: dict[str, dict[str, float]]
    physics: JointPhysics
    fit: Run
    held: Run
    notes: dict = field(default_factory=dict)

    def write(self, folder: Path) -> tuple[Path, Path]:
        """The fitted and held-out runs as CSV files, each with its experiment file."""
        return (write_run(self.fit, folder / f"case_{self.seed}_fit.csv"),
                write_run(self.held, folder / f"case_{self.seed}_held.csv"))

    def expected_causes(self) -> set[str]:
        """The truth under the names a physicist would give what the data show: extra
        inertia on a joint gravity has no hold on is inertia, whatever its source, and so
        is a rotor's where no effort shows the joint driven (a passive hinge has none)."""
        driven = f"{self.joint}.effort" in self.fit.columns
        out = set()
        for c in self.truth:
            if c == "mass_distribution" or (c == "armature" and (
                    self.kind != "lid" or not driven)):
                out.add("inertia")
            else:
                out.add(c)
        return out


def write_run(run: Run, path: Path) -> Path:
    lines = [",".join(["time", *run.columns])]
    data = np.column_stack([run.time, *run.columns.values()])
    lines += [",".join(repr(float(v)) for v in row) for row in data]
    path.write_text("\n".join(lines) + "\n")
    if run.experiment:
        path.with_suffix("").with_suffix(".experiment.toml").write_text(
            toml_text(run.experiment))
    return path


def toml_text(tables: dict[str, dict]) -> str:
    def value(v):
        if isinstance(v, str):
            return f'"{v}"'
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(v)

    lines = []
    for name, table in tables.items():
        lines += [f"[{name}]"] + [f"{k} = {value(v)}" for k, v in table.items()] + [""]
    return "\n".join(lines)


# -- which effects a run can show ------------------------------------------------------------
def _pool(scenario: Scenario, kind: str, position_only: bool) -> list[str]:
    pool = [e for e in EFFECTS if e != "limit"]
    if position_only:
        # without effort the scale of the mass is invisible; a joint let go once moves one
        # way only, so direction-dependent friction is not in its data
        pool = [e for e in pool if e != "inertia"]
        if kind != "lid":
            pool = [e for e in pool if e not in ("armature", "asymmetric_friction")]
    if kind != "lid" and "inertia" in pool and "armature" in pool:
        pool.remove("armature")  # the same extra inertia where gravity has no hold
    return pool


def _compatible(chosen: set[str], one_way: bool) -> bool:
    """Whether the data can tell the chosen effects apart. ``one_way``: a joint let go once
    that moves one way only, where dry friction and a constant force act alike."""
    exclusive = [{"friction", "asymmetric_friction"}, {"damping", "asymmetric_friction"},
                 {"spring", "offset"}, {"asymmetric_friction", "offset"},
                 {"asymmetric_friction", "spring"}, {"inertia", "mass_distribution"},
                 {"armature", "mass_distribution"},  # both in the inertia about the axis
                 {"encoder_offset", "offset"}, {"encoder_offset", "spring"},
                 {"inertia", "armature"}]
    if one_way:
        exclusive.append({"friction", "offset"})
    return not any(pair <= chosen for pair in exclusive)


def _draw(rng, pool: list[str], forced: tuple[str, ...], n_extra: int,
          one_way: bool = False) -> list[str]:
    for _ in range(100):
        extra = rng.choice(pool, size=n_extra, replace=False).tolist() if n_extra else []
        chosen = set(forced) | set(extra)
        if len(chosen) == len(forced) + n_extra and _compatible(chosen, one_way):
            return sorted(chosen)
    return sorted(forced)


# -- the drives -------------------------------------------------------------------------------
def _quantum(kind: str) -> tuple[float, float]:
    """Sensor noise and resolution: a draw-wire sensor on a slide, a 13-bit encoder else."""
    return (1e-4, 5e-5) if kind == "drawer" else (3e-4, 2 * math.pi / 8192)


def _measure(q: np.ndarray, kind: str, rng) -> np.ndarray:
    noise, quantum = _quantum(kind)
    return np.round((q + rng.normal(0, noise, len(q))) / quantum) * quantum


def _start(kind: str, rng, moving: bool) -> tuple[float, float]:
    if kind == "lid":
        q0 = float(rng.uniform(-0.4, 0.4))
        v0 = float(rng.uniform(0.8, 2.5) * rng.choice([-1, 1])) if moving else 0.0
    elif kind == "door":
        q0 = float(rng.uniform(0.5, 1.2))
        v0 = float(rng.uniform(0.15, 0.45) * rng.choice([-1, 1])) if moving else 0.0
    else:
        q0 = float(rng.uniform(0.15, 0.35))
        v0 = float(rng.uniform(0.03, 0.08) * rng.choice([-1, 1])) if moving else 0.0
    return q0, v0


def _reference(kind: str, q0: float, times: np.ndarray, rng) -> np.ndarray:
    """Moves between setpoints with smooth (cosine) transitions, as a positioning rig does."""
    lo, hi = {"door": (0.3, 1.6), "drawer": (0.08, 0.5), "lid": (-0.6, 0.6)}[kind]
    r = np.full(len(times), q0)
    t, level, t_end = 0.2, q0, times[-1]
    while t < t_end:
        move = float(rng.uniform(0.3, 0.8))
        target = float(rng.uniform(lo, hi))
        inside = (times >= t) & (times < t + move)
        s = (times[inside] - t) / move
        r[inside] = level + (target - level) * 0.5 * (1 - np.cos(math.pi * s))
        r[times >= t + move] = target
        level = target
        t += move + float(rng.uniform(0.2, 0.8))
    return r


def _loop(p: JointPhysics, kind: str, times: np.ndarray, rng, amplitude: float,
          pulses: bool, push) -> tuple[np.ndarray, np.ndarray, dict, dict]:
    """A PD position loop on the *measured* position, its command held over each sample
    interval (the experiment-file law: u = kp (r - q) - kd v + added, clipped, effort =
    gain u). Returns the true and measured positions, the effort and the declaration."""
    h = float(times[1] - times[0])
    q0, _ = _start(kind, rng, moving=False)
    ref = _reference(kind, q0, times, rng)
    omega, zeta = rng.uniform(12.0, 25.0), rng.uniform(0.6, 1.0)
    gain = float(rng.uniform(1.0, 40.0))
    kp = p.inertia * omega**2 / gain
    kd = 2 * zeta * p.inertia * omega / gain
    taps = int(rng.integers(1, 4))
    limit = float(amplitude * rng.uniform(3.0, 8.0) / gain)  # saturates now and then
    added = np.zeros(len(times))
    if pulses:
        for _ in range(int(rng.integers(2, 5))):
            start = rng.uniform(0.1, times[-1] - 0.3)
            width = rng.uniform(0.05, 0.2)
            added[(times >= start) & (times < start + width)] = \
                rng.uniform(0.2, 0.5) * limit * rng.choice([-1, 1])
    noise, quantum = _quantum(kind)
    q_true = np.empty(len(times))
    q_meas = np.empty(len(times))
    effort = np.empty(len(times))
    q, v = q0, 0.0
    sink = np.empty(0)
    for k in range(len(times)):
        q_true[k] = q
        q_meas[k] = np.round((q + rng.normal(0, noise)) / quantum) * quantum
        back = min(taps, k)
        vel = (q_meas[k] - q_meas[k - back]) / (back * h) if back else 0.0
        u = min(max(kp * (ref[k] - q_meas[k]) - kd * vel + added[k], -limit), limit)
        effort[k] = gain * u
        if k + 1 < len(times):
            q, v = advance(p, lambda t, f=effort[k]: f + push(t), times[k], times[k + 1],
                           q, v, sink, sink)
    feedback = {"reference": "reference", "kp": kp, "kd": kd, "velocity_taps": taps,
                "saturation": [-limit, limit], "gain": gain}
    columns = {"reference": ref}
    if pulses:
        feedback["added"] = "pulse"
        columns["pulse"] = added
    return q_true, q_meas, effort, {"feedback": feedback, "columns": columns}


def _no_push(t: float) -> float:
    return 0.0


def _unmeasured_push(rng, amplitude: float, t_end: float):
    """A hand in the middle of the run: a smooth push no column holds."""
    start = float(rng.uniform(0.35, 0.55) * t_end)
    width = float(rng.uniform(0.1, 0.25))
    amp = float(amplitude * rng.uniform(0.5, 1.0) * rng.choice([-1, 1]))

    def push(t: float) -> float:
        if start <= t <= start + width:
            return amp * 0.5 * (1 - math.cos(2 * math.pi * (t - start) / width))
        return 0.0

    return push, (start, start + width)


def _drive(case: dict, p: JointPhysics, rng, held: bool) -> Run:
    """One measured run of the case's object (the held-out run: other pushes, another start,
    no unmeasured push)."""
    kind, times, joint = case["kind"], case["times"], case["joint"]
    scenario: Scenario = case["scenario"]
    drive, amplitude = case["drive"], case["amplitude"]
    t_end = float(times[-1])
    push, window = _no_push, None
    if case["name"] == "unmeasured_push" and not held:
        push, window = _unmeasured_push(rng, amplitude, t_end)
    delay = case["truth"].get("effort_delay", {}).get("effort_delay", 0.0)
    offset = case["truth"].get("encoder_offset", {}).get("encoder_offset", 0.0)
    columns: dict[str, np.ndarray] = {}
    experiment = None
    if drive == "loop":
        q_true, q_meas, effort, declared = _loop(p, kind, times, rng, amplitude,
                                                 pulses=scenario.declared_loop
                                                 and bool(rng.integers(0, 2)), push=push)
        columns[joint] = q_meas + offset
        columns[f"{joint}.effort"] = effort + rng.normal(0, 3e-4 * amplitude, len(times))
        if scenario.declared_loop:
            columns.update(declared["columns"])
            experiment = {f"joints.{joint}.feedback": declared["feedback"]}
        return Run(times, q_true, columns, experiment)
    moving = drive == "released"
    q0, v0 = _start(kind, rng, moving)
    if drive == "at_rest":
        q0 = float(rng.uniform(0.3, 1.0) * rng.choice([-1, 1]))
    if p.stop is not None:  # start clear of the stop
        q0 = min(q0, p.stop - 0.02) if p.stop_side > 0 else max(q0, p.stop + 0.02)
    sensed = np.maximum(times - delay, 0.0)  # the position recorded late
    if drive == "pushed":
        effort_fn = push_profile(rng, amplitude, t_end)
        q_true = integrate(p, lambda t: effort_fn(t) + push(t), t_end + 1e-9, q0, v0, sensed)
        u = np.array([effort_fn(t) for t in times])
        columns[joint] = _measure(q_true, kind, rng) + offset
        columns[f"{joint}.effort"] = u + rng.normal(0, 3e-4 * amplitude, len(times))
    else:
        q_true = integrate(p, push, t_end + 1e-9, q0, v0, sensed)
        columns[joint] = _measure(q_true, kind, rng) + offset
    run = Run(times, q_true, columns, experiment)
    if window is not None:
        case.setdefault("push_window", window)
    return run


# -- cases ------------------------------------------------------------------------------------
def scenario_for(seed: int) -> tuple[str, bool]:
    """The suite's assignment: scenarios in turn; every third round effect-free where the
    scenario comes so."""
    name = NAMES[seed % len(NAMES)]
    return name, SCENARIOS[name].clean and (seed // len(NAMES)) % 3 == 0


def make(seed: int, name: str | None = None, clean: bool | None = None) -> ScenarioCase:
    """The case for ``seed`` (redrawn while the motion would leave the nominal range, which
    the generator does not model, or while the fitted run never meets the stop the case
    hides: a stop the fitted data do not reach is not in them, and no method names it; so
    with a friction that differs by direction where the fitted run never moves one of the
    two ways: seed 110's pushed drawer moved one way only, and what its friction is the
    other way is in no sample)."""
    if name is None:
        name, default_clean = scenario_for(seed)
        clean = default_clean if clean is None else clean
    for attempt in range(30):
        case = _make(seed, attempt, name, bool(clean))
        p, q_fit = case.physics, case.fit.true_position
        if p.stop is not None and not (q_fit.max() >= p.stop if p.stop_side > 0
                                       else q_fit.min() <= p.stop):
            continue
        if "asymmetric_friction" in case.truth and not _moves_both_ways(q_fit):
            continue
        lim = case.obj.joint(case.joint).limits
        if lim is None:
            return case
        span = lim.upper - lim.lower
        q = np.concatenate([case.fit.true_position, case.held.true_position])
        if q.min() > lim.lower + 0.05 * span and q.max() < lim.upper - 0.05 * span:
            return case
    raise RuntimeError(f"seed {seed} ({name}): no case within the nominal limits")


def _moves_both_ways(q: np.ndarray, share: float = 0.01) -> bool:
    """Whether the true motion ``q`` moves each way at some point faster than ``share`` of
    its top speed (a stroke back, not the rounding of a standstill)."""
    step = np.diff(q)
    top = float(np.abs(step).max(initial=0.0))
    return top > 0 and step.max() > share * top and -step.min() > share * top


def _make(seed: int, attempt: int, name: str, clean: bool) -> ScenarioCase:
    scenario = SCENARIOS[name]
    rng = np.random.default_rng([seed, attempt, 16])
    kind = str(rng.choice(scenario.kinds))
    obj, joint = nominal_object(kind, rng)
    p = physics_for(obj, joint)
    drive = scenario.drive
    if drive == "either":
        drive = "pushed" if rng.integers(0, 2) else ("released" if kind != "lid" or
                                                     rng.integers(0, 2) else "at_rest")
    position_only = drive in ("released", "at_rest")
    rate = float(rng.choice(scenario.rates))
    duration = float(rng.uniform(*scenario.duration))
    times = np.arange(0.0, duration, 1.0 / rate)
    amplitude = ACCEL[kind] * p.inertia
    if clean:
        effects = list(scenario.forced)
    else:
        n_extra = int(rng.integers(0 if scenario.forced else 1, 2 if scenario.forced else 3))
        effects = _draw(rng, _pool(scenario, kind, position_only), scenario.forced, n_extra,
                        one_way=drive == "released" and kind != "lid")
    truth: dict[str, dict[str, float]] = {}
    q_mid = _start(kind, rng, False)[0]
    for e in effects:
        if e == "mass_distribution":
            truth[e] = _mass_distribution(p, obj, joint, rng)
        elif e == "encoder_offset":
            truth[e] = {"encoder_offset": float(rng.uniform(0.02, 0.06) * rng.choice([-1, 1]))}
        elif e == "effort_delay":  # the position recorded late: the effort leads it
            truth[e] = {"effort_delay": float(rng.uniform(0.008, 0.03))}
        elif e != "limit":
            apply_effect(p, e, rng, p.inertia, amplitude, q_mid, truth)
    case = {"kind": kind, "times": times, "joint": joint, "scenario": scenario, "name": name,
            "drive": drive, "amplitude": amplitude, "truth": truth}
    fit_seed, held_seed = (int(x) for x in rng.integers(0, 2**31, 2))
    if "limit" in effects:
        free = _drive(case, p, np.random.default_rng(fit_seed), held=False).true_position
        q0 = free[0]
        hi, lo = free.max(), free.min()
        side = 1 if hi - q0 >= q0 - lo else -1
        extreme = hi if side > 0 else lo
        p.stop, p.stop_side = float(q0 + (extreme - q0) * rng.uniform(0.55, 0.8)), side
        omega = 2 * math.pi * rng.uniform(40.0, 60.0)
        p.stop_stiffness = p.total_inertia * omega**2
        p.stop_damping = 2 * rng.uniform(1.0, 1.5) * p.total_inertia * omega
        truth["limit"] = {"upper" if side > 0 else "lower": p.stop}
    fit = _drive(case, p, np.random.default_rng(fit_seed), held=False)
    held = _drive(case, p, np.random.default_rng(held_seed), held=True)
    notes = {"drive": drive, "rate": rate, "duration": duration, "inertia": p.inertia,
             "push_window": case.get("push_window")}
    return ScenarioCase(seed, name, kind, obj, joint, truth, p, fit, held, notes)


def _mass_distribution(p: JointPhysics, obj: ArticulatedObject, joint: str, rng) -> dict:
    """Mass moved along the panel (its centre of mass by a factor) and its inertia about
    its own centre off besides: the first moment and the inertia about the axis change by
    different factors. Truth in base parameters (inertia about the axis, first moment
    normal to it)."""
    part = obj.part(obj.joint(joint).child)
    c = part.inertial.com - p.axis * float(p.axis @ part.inertial.com)
    arm = float(np.linalg.norm(c))
    m = part.inertial.mass
    moment = float(rng.choice([rng.uniform(0.6, 0.8), rng.uniform(1.25, 1.5)]))
    about_com = p.inertia - m * arm**2
    inertia = m * (arm * moment) ** 2 + about_com * float(rng.uniform(0.8, 1.25))
    p.moment_scale = moment
    p.rotational_scale = inertia / p.inertia
    # the package's current terms too: mass x s (with its weight), rotation about the
    # centre of mass x r; a moved centre of mass is s = moment at the nominal arm
    r = (inertia / moment - m * arm**2) / about_com
    return {"inertia_about_axis": inertia, "first_moment": m * arm * moment,
            "inertia_scale": moment, "rotational_scale": r}
