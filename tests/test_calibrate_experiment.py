"""The experiment file (docs/calibration_contract.md): units, gravity, window, columns and
a declared feedback law, read with the CSV; bad files refused naming the file and the key,
exit status 2, nothing written; a closed loop replayed through the declared law.

The closed-loop data are made here, independently of the package: a drawer (mass m, hidden
viscous damping b) under a PD law held over each sample interval, integrated exactly (the
linear ODE's closed form per interval).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from real2code_export.calibrate import calibrate, read_csv
from real2code_export.calibrate.experiment import beside, read_experiment
from real2code_export.cli import run as cli_run
from real2code_export.errors import FormatError
from real2code_export.formats import object_json

from synthetic_joint_data import make_case, nominal_object, physics_for


@pytest.fixture(scope="module")
def lid():
    return make_case(2, kind="lid", effects=["damping"])


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def test_units_columns_window_gravity(lid, tmp_path):
    j = lid.joint
    lines = ["time,angle_deg,torque"]
    lines += [f"{1000 * t!r},{math.degrees(q)!r},{u!r}" for t, q, u in
              zip(lid.time.tolist(), lid.position.tolist(), lid.effort.tolist(), strict=True)]
    csv = _write(tmp_path / "run.csv", "\n".join(lines) + "\n")
    _write(beside(csv), f"""
[units]
time = "ms"
angle = "deg"
[world]
gravity = [0.0, 0.0, -9.7]
[window]
start = 0.5
end = 2.0
[joints.{j}]
position = "angle_deg"
effort = "torque"
""")
    exp = read_experiment(beside(csv))
    tr = read_csv(csv, lid.obj, exp)
    assert tr.joints == [j]
    np.testing.assert_allclose(tr.time, lid.time, atol=1e-12)
    np.testing.assert_allclose(tr.positions[j], lid.position, atol=1e-12)
    np.testing.assert_allclose(tr.efforts[j], lid.effort)
    assert tr.gravity == (0.0, 0.0, -9.7)
    assert tr.window == (0.5, 2.0)


@pytest.mark.parametrize("text, key, fragment", [
    ("[units]\ntime = 'min'\n", "units.time", "unknown unit 'min'"),
    ("[unit]\ntime = 's'\n", "unit", "unknown key"),
    ("[world]\ngravity = [0, -9.81]\n", "world.gravity", "must be [x, y, z]"),
    ("[window]\nstart = 'a'\n", "window.start", "finite number"),
    ("[window]\nstart = 2.0\nend = 1.0\n", "window.end", "not after"),
    ("[joints.hinge]\nposition = 'nope'\n", "joints.hinge.position",
     "column 'nope' is not in"),
    ("[joints.hinge]\nspeed = 'x'\n", "joints.hinge.speed", "unknown key"),
    ("[joints.hinge.feedback]\nkp = 1.0\n", "joints.hinge.feedback.reference", "missing"),
    ("[joints.hinge.feedback]\nreference = 'hinge'\nadded = 'pulse'\n",
     "joints.hinge.feedback.added", "column 'pulse' is not in"),
    ("[joints.hinge.feedback]\nreference = 'hinge'\nvelocity_taps = 0\n",
     "joints.hinge.feedback.velocity_taps", ">= 1"),
    ("[joints.door]\nposition = 'hinge'\n", "joints.door", "names no movable joint"),
    ("[units\n", None, "not valid TOML"),
])
def test_bad_experiment_refused(lid, tmp_path, text, key, fragment):
    csv = _write(tmp_path / "run.csv", lid.csv())
    toml = _write(beside(csv), text)
    model = object_json.save(lid.obj, tmp_path / "model")
    with pytest.raises(FormatError) as info:
        read_csv(csv, lid.obj, read_experiment(toml))
    err = info.value
    assert err.path == str(toml), str(err)
    assert err.element == key, str(err)
    assert fragment in str(err), str(err)
    out = tmp_path / "out"
    assert cli_run(["calibrate", str(model), "--data", str(csv), "--out", str(out)]) == 2
    assert not out.exists()


def test_given_experiment_applies_where_none_beside(lid, tmp_path):
    csv = _write(tmp_path / "run.csv", lid.csv().replace("time,", "time,", 1))
    toml = _write(tmp_path / "shared.toml", "[joints.hinge]\nposition = 'missing'\n")
    model = object_json.save(lid.obj, tmp_path / "model")
    out = tmp_path / "out"
    assert cli_run(["calibrate", str(model), "--data", str(csv), "--experiment", str(toml),
                    "--out", str(out)]) == 2
    assert not out.exists()


def test_run_too_short_to_fit_its_initial_state(lid, tmp_path):
    csv = _write(tmp_path / "run.csv", lid.csv())
    model = object_json.save(lid.obj, tmp_path / "model")
    out = tmp_path / "out"
    # a window of a few samples: nothing to fit the initial state from
    assert cli_run(["calibrate", str(model), "--data", str(csv), "--start", "1.0",
                    "--end", "1.02", "--out", str(out)]) == 2
    assert not out.exists()
    with pytest.raises(FormatError, match="at least") as info:
        calibrate(lid.obj, [csv], start=1.0, end=1.02)
    assert (info.value.path, info.value.element) == (str(csv), "window"), str(info.value)


# -- a closed loop, declared ------------------------------------------------------------------
def _pd_drawer(seed: int, damping: float, rate: float = 500.0, duration: float = 3.0):
    """Positions and commands of a drawer under a discrete PD law on a step reference,
    integrated exactly: m x'' = gain * u - b x' with u held over each interval."""
    rng = np.random.default_rng(seed)
    obj, joint = nominal_object("drawer", rng)
    m = physics_for(obj, joint).inertia
    h = 1.0 / rate
    t = np.arange(0.0, duration, h)
    ref = 0.2 + 0.1 * (np.floor(t / 0.75) % 2)  # steps between 0.2 and 0.3 m
    kp, kd, gain, taps = 40.0, 8.0, 2.0 * m, 2
    x, v = 0.2, 0.0
    q = np.empty(len(t))
    u_out = np.empty(len(t))
    for k in range(len(t)):
        q[k] = x
        back = min(taps, k)
        vel = (q[k] - q[k - back]) / (back * h) if back else 0.0
        u = kp * (ref[k] - q[k]) - kd * vel
        u_out[k] = gain * u
        f = gain * u
        a = damping / m
        # closed form over [0, h] of x'' = f/m - a x'
        e = math.exp(-a * h)
        vinf = f / damping
        x = x + vinf * h + (v - vinf) * (1 - e) / a
        v = vinf + (v - vinf) * e
    noise = 1e-5
    q_meas = q + rng.normal(0.0, noise, len(t))
    return obj, joint, t, q_meas, ref, u_out, dict(kp=kp, kd=kd, gain=gain, taps=taps)


def _write_loop(tmp_path, joint, t, q, ref, u, law, extra: str = "") -> Path:
    """A PD loop's run as a CSV (position, reference, effort) and its experiment file
    declaring the law (``extra``: more lines of the feedback table)."""
    lines = ["time,pos,ref,force"] + [f"{a!r},{x!r},{r!r},{f!r}" for a, x, r, f in
                                      zip(t.tolist(), q.tolist(), ref.tolist(), u.tolist(),
                                          strict=True)]
    csv = _write(tmp_path / "loop.csv", "\n".join(lines) + "\n")
    _write(beside(csv), f"""
[joints.{joint}]
position = "pos"
effort = "force"
[joints.{joint}.feedback]
reference = "ref"
kp = {law['kp']}
kd = {law['kd']}
velocity_taps = {law['taps']}
gain = {law['gain']}
""" + extra)
    return csv


def test_closed_loop_replayed_through_the_declared_law(tmp_path):
    b = 6.0
    obj, joint, t, q, ref, u, law = _pd_drawer(3, damping=b)
    csv = _write_loop(tmp_path, joint, t, q, ref, u, law)
    result = calibrate(obj, [csv])
    report = result.report
    assert report["causes"] == ["damping"], report["selection_log"]
    p = report["parameters"][f"{joint}.damping"]
    assert abs(p["value"] - b) <= p["halfwidth95"], p
    assert report["rmse_after"] < 0.1 * report["rmse_before"]
    assert result.problem.trajectories[0].law() is not None  # replayed in closed loop


def test_declared_law_is_the_controller(tmp_path):
    """The law computed on the recorded positions gives the recorded effort (saturation
    and an added column included)."""
    from real2code_export.calibrate.feedback import Feedback, controller

    obj, joint, t, q, ref, u, law = _pd_drawer(4, damping=3.0)
    added = 0.01 * np.sin(7 * t)
    fb = Feedback("ref", law["kp"], law["kd"], law["taps"], "pulse", (-1.0, 1.0), law["gain"])
    run = controller({joint: fb}, {"ref": ref, "pulse": added}, float(t[1] - t[0]))
    got = np.array([run(k, {joint: q})[joint] for k in range(len(t))])
    h = float(t[1] - t[0])
    vel = np.zeros(len(t))
    vel[2:] = (q[2:] - q[:-2]) / (2 * h)
    vel[1] = (q[1] - q[0]) / h
    want = law["gain"] * np.clip(law["kp"] * (ref - q) - law["kd"] * vel + added, -1, 1)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


def test_declared_loop_replays_are_the_stepwise_replay(tmp_path):
    """Several models replayed through the declared law in plain floats (the Jacobian's
    batch) give what each replayed alone by the general controller gives."""
    from real2code_export.calibrate.problem import build_problem
    from real2code_export.calibrate.residuals import build_model
    from real2code_export.calibrate.simulate import AppliedLaw, declared_loop, rollout
    from real2code_export.calibrate.trajectory import read_all

    obj, joint, t, q, ref, u, law = _pd_drawer(5, damping=4.0, duration=1.0)
    csv = _write_loop(tmp_path, joint, t, q, ref, u, law, "saturation = [-0.05, 0.05]\n")
    tr, = read_all([csv], obj)
    problem = build_problem(obj, [tr])
    damping = problem.effects[joint]["damping"]
    models = [build_model(problem, (damping,), {f"{joint}.damping": b}) for b in (2.0, 6.0)]
    initials = [{joint: (0.2, 0.0)}, {joint: (0.21, 0.05)}]
    laws = [{joint: AppliedLaw(offset=0.1)}, {}]
    together = declared_loop(models, tr, initials, laws)
    for m, x0, lw, got in zip(models, initials, laws, together, strict=True):
        alone = rollout(m, tr, x0, lw)
        np.testing.assert_allclose(got.positions, alone.positions, rtol=0, atol=1e-12)
        np.testing.assert_allclose(got.efforts, alone.efforts, rtol=0, atol=1e-12)
    assert np.ptp(together[0].positions - together[1].positions) > 1e-3  # they differ


def test_a_noisy_loops_replay_applies_its_clipped_commands_mean(tmp_path):
    """A loop on a noisy encoder clips a noisy command: the replay applies the clipped
    command's mean under the command's noise (the encoder's through the law), the same in
    the batch of plain floats as in the general controller; far from the limits, the law."""
    from real2code_export.calibrate.feedback import clipped_mean
    from real2code_export.calibrate.problem import build_problem
    from real2code_export.calibrate.residuals import build_model
    from real2code_export.calibrate.simulate import declared_loop, rollout
    from real2code_export.calibrate.trajectory import read_all

    rng = np.random.default_rng(3)
    u = np.array([-1.3, -1.02, -0.97, 0.0, 0.95, 1.0, 1.1])
    draws = np.clip(u[:, None] + rng.normal(0.0, 0.1, (len(u), 200_000)), -1.0, 1.0)
    np.testing.assert_allclose(clipped_mean(u, -1.0, 1.0, 0.1), draws.mean(axis=1),
                               atol=1e-3)
    assert clipped_mean(0.0, -1.0, 1.0, 0.1) == pytest.approx(0.0, abs=1e-12)
    assert clipped_mean(0.99, -1.0, 1.0, 0.1) < 0.96  # the clipped noise pulls it in

    obj, joint, t, q, ref, u, law = _pd_drawer(5, damping=4.0, duration=1.0)
    csv = _write_loop(tmp_path, joint, t, q, ref, u, law, "saturation = [-0.05, 0.05]\n")
    plain, = read_all([csv], obj)
    noisy = plain.with_encoder_noise()
    fb = noisy.feedback[joint]
    assert fb.encoder_noise > 0 and fb.command_noise(noisy.sample_period) > 0
    assert plain.feedback[joint].encoder_noise == 0.0
    runs = {}
    for name, tr in (("plain", plain), ("noisy", noisy)):
        problem = build_problem(obj, [tr])
        model = build_model(problem, (), {})
        x0 = {joint: (0.2, 0.0)}
        got, = declared_loop([model], tr, [x0], [{}])
        alone = rollout(model, tr, x0, {})
        np.testing.assert_allclose(got.positions, alone.positions, rtol=0, atol=1e-12)
        np.testing.assert_allclose(got.efforts, alone.efforts, rtol=0, atol=1e-12)
        runs[name] = got
    # where the command is clipped the noisy loop applies less
    sat = np.abs(runs["plain"].efforts[:, 0]) >= 0.05 * law["gain"] * (1 - 1e-9)
    assert sat.any()
    assert np.all(np.abs(runs["noisy"].efforts[sat, 0]) <= 0.05 * law["gain"])


def test_a_loop_reading_a_draw_of_its_noise_applies_the_law_to_it(tmp_path):
    """``Feedback.reading``: the law applied to the position plus a noise column (what
    the loop did on the rig; uncertainty.loop_noise_cov's draws), clipped as it is, the
    same in the batch of plain floats as in the general controller."""
    import dataclasses

    from real2code_export.calibrate.problem import build_problem
    from real2code_export.calibrate.residuals import build_model
    from real2code_export.calibrate.simulate import declared_loop, rollout
    from real2code_export.calibrate.trajectory import read_all

    obj, joint, t, q, ref, u, law = _pd_drawer(5, damping=4.0, duration=1.0)
    csv = _write_loop(tmp_path, joint, t, q, ref, u, law, "saturation = [-0.05, 0.05]\n")
    plain, = read_all([csv], obj)
    noise = np.random.default_rng(7).normal(0.0, 1e-4, plain.n)
    fb = dataclasses.replace(plain.with_encoder_noise().feedback[joint], reading="draw",
                             encoder_noise=0.0)
    tr = dataclasses.replace(plain, feedback={joint: fb},
                             columns={**plain.columns, "draw": noise})
    model = build_model(build_problem(obj, [tr]), (), {})
    x0 = {joint: (0.2, 0.0)}
    got, = declared_loop([model], tr, [x0], [{}])
    alone = rollout(model, tr, x0, {})
    np.testing.assert_allclose(got.positions, alone.positions, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got.efforts, alone.efforts, rtol=0, atol=1e-12)
    read = got.positions[:, 0] + noise
    h, taps = tr.sample_period, fb.velocity_taps
    k = np.arange(taps, tr.n)
    want = fb.kp * (tr.columns[fb.reference][k] - read[k]) - \
        fb.kd * (read[k] - read[k - taps]) / (taps * h)
    np.testing.assert_allclose(got.efforts[k, 0], fb.gain * np.clip(want, -0.05, 0.05),
                               rtol=1e-9, atol=1e-12)
    quiet, = declared_loop([model], plain, [x0], [{}])
    assert np.max(np.abs(got.positions - quiet.positions)) > 0  # the draw drives the joint


def test_a_loop_that_forgets_its_start_ends_on_its_base(tmp_path):
    """A Jacobian's initial-state column: the same model replayed from a moved start. The
    loop forgets the move within its time constants; from there the replay is its base's
    (a base whose last efforts are marked shows that they were taken), and the whole is
    what replaying to the end gives."""
    import dataclasses

    from real2code_export.calibrate.problem import build_problem
    from real2code_export.calibrate.residuals import build_model
    from real2code_export.calibrate.simulate import declared_loop
    from real2code_export.calibrate.trajectory import read_all

    obj, joint, t, q, ref, u, law = _pd_drawer(5, damping=4.0, duration=5.0)
    tr, = read_all([_write_loop(tmp_path, joint, t, q, ref, u, law)], obj)
    problem = build_problem(obj, [tr])
    damping = problem.effects[joint]["damping"]
    m = build_model(problem, (damping,), {f"{joint}.damping": 4.0})
    base, = declared_loop([m], tr, [{joint: (0.2, 0.0)}], [{}])
    moved = {joint: (0.2 + 1e-7, 1e-6)}
    whole, = declared_loop([m], tr, [moved], [{}])
    marked = dataclasses.replace(base, efforts=base.efforts.copy())
    marked.efforts[-5:] = 123.0
    ended, = declared_loop([m], tr, [moved], [{}], bases=[marked])
    assert np.all(ended.efforts[-5:] == 123.0)  # the tail is the base's
    np.testing.assert_allclose(ended.positions, whole.positions, rtol=0, atol=1e-15)
    np.testing.assert_allclose(ended.efforts[:-5], whole.efforts[:-5], rtol=0, atol=1e-12)
    assert np.abs(whole.positions[:50] - base.positions[:50]).max() > 1e-8  # it moved
    assert np.abs(whole.positions - base.positions)[-100:].max() == 0.0  # and came back
    # a start the loop does not forget (a different model: no base) is replayed to the end
    other = build_model(problem, (damping,), {f"{joint}.damping": 6.0})
    kept, = declared_loop([other], tr, [moved], [{}], bases=[marked])
    assert np.all(kept.efforts[-5:] != 123.0)
def test_irregular_samples_replay_in_batch_as_stepped(tmp_path):
    """A measured effort on irregular time stamps (a logger's jitter, a dropped sample)
    replayed by ``mujoco.rollout`` gives what stepping sample by sample in Python gives."""
    from real2code_export.calibrate.problem import build_problem
    from real2code_export.calibrate.residuals import build_model
    from real2code_export.calibrate.simulate import AppliedLaw, BatchRunner, rollout
    from real2code_export.calibrate.trajectory import read_all

    obj, joint = nominal_object("door", np.random.default_rng(3))
    rng = np.random.default_rng(4)
    t = np.cumsum(np.concatenate([[0.0], 2e-3 * (1 + 0.004 * rng.random(299))]))
    t[150:] += 0.011  # a gap of several samples
    u = 0.5 * np.sin(4 * t)
    csv = tmp_path / "run.csv"
    csv.write_text(f"time,{joint},{joint}.effort\n" + "".join(
        f"{a!r},{0.3 + 0.1 * a!r},{b!r}\n" for a, b in zip(t.tolist(), u.tolist(), strict=True)))
    tr, = read_all([csv], obj)
    problem = build_problem(obj, [tr])
    damping = problem.effects[joint]["damping"]
    models = [build_model(problem, (damping,), {f"{joint}.damping": b}) for b in (0.5, 3.0)]
    initials = [{joint: (0.3, 0.1)}, {joint: (0.31, -0.2)}]
    laws = [{joint: AppliedLaw(offset=0.2)}, {}]
    together = BatchRunner(tr, [joint]).run(models, initials, laws, True)
    for m, x0, lw, got in zip(models, initials, laws, together, strict=True):
        alone = rollout(m, tr, x0, lw)
        np.testing.assert_allclose(got.positions, alone.positions, rtol=0, atol=1e-12)
    assert np.ptp(together[0].positions - together[1].positions) > 1e-3  # they differ
