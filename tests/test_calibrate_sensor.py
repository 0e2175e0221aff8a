"""Sensor-side causes are named as such, not as forces: an encoder's zero error on a joint
gravity acts on (the data: the independent generator's effect-free lid, pushed with a
measured effort or swinging freely, read through an encoder that is off by a constant)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from real2code_export.calibrate import calibrate

from synthetic_joint_data import integrate, make_case, physics_for


@pytest.mark.parametrize("seed, zero, with_effort", [(2, 0.06, True), (5, -0.08, False)])
def test_encoder_zero_error_is_not_a_force(tmp_path, seed, zero, with_effort):
    case = make_case(seed, kind="lid", effects=[])
    text = case.csv()
    if not with_effort:  # a free swing from 0.8 rad, position only
        p = physics_for(case.obj, case.joint)
        q = integrate(p, lambda _t: 0.0, float(case.time[-1]) + 1e-9, 0.8, 0.0, case.time)
        rng = np.random.default_rng(seed)
        case.position = np.round((q + rng.normal(0, case.noise, len(q))) / case.quantum) \
            * case.quantum
        text = f"time,{case.joint}\n" + "\n".join(
            f"{t!r},{x!r}" for t, x in zip(case.time.tolist(), case.position.tolist(),
                                           strict=True)) + "\n"
    text = _shifted(text, zero)
    csv = Path(tmp_path / "run.csv")
    csv.write_text(text)
    result = calibrate(case.obj, [csv])
    report = result.report
    assert report["causes"] == ["encoder_offset"], report["selection_log"]
    assert report["cause_details"][0]["side"] == "sensor"
    p = report["parameters"][f"{case.joint}.encoder_offset"]
    assert abs(p["value"] - zero) <= p["halfwidth95"], p
    # the calibrated model carries the zero error and replays the reading
    extras = result.model.metadata["real2code:dynamics"][case.joint]
    assert extras["encoder_offset"]["position"] == pytest.approx(p["value"])
    assert report["rmse_after"] < 3 * case.noise + case.quantum
    # the encoder's step is reported as the sensor's, not fitted
    (sensor,) = report["sensor"].values()
    assert sensor[case.joint]["quantum"] == pytest.approx(case.quantum, rel=1e-6)


def _shifted(text: str, zero: float) -> str:
    """The CSV as an encoder off by ``zero`` reads it (the position column shifted)."""
    lines = text.splitlines()
    out = [lines[0]]
    for line in lines[1:]:
        cells = line.split(",")
        cells[1] = repr(float(cells[1]) + zero)
        out.append(",".join(cells))
    return "\n".join(out) + "\n"


@pytest.mark.parametrize("seed, kind, lag", [(1, "drawer", 0.02), (0, "door", -0.015)])
def test_effort_lag_is_a_delay_not_a_force(tmp_path, seed, kind, lag):
    """The effort recorded by a clock ``lag`` seconds behind the position's: the joint
    feels at t what the file says at t - lag. Named ``effort_delay``, nothing else."""
    case = make_case(seed, kind=kind, effects=[])
    u_true = case.notes["u_true"]
    rng = np.random.default_rng(seed)
    case.effort = np.interp(case.time + lag, case.time, u_true) + rng.normal(
        0.0, 3e-4 * case.notes["amplitude"], len(u_true))
    csv = Path(tmp_path / "run.csv")
    csv.write_text(case.csv())
    report = calibrate(case.obj, [csv]).report
    assert report["causes"] == ["effort_delay"], report["selection_log"]
    p = report["parameters"][f"{case.joint}.effort_delay"]
    assert abs(p["value"] - lag) <= p["halfwidth95"], p


def test_effort_held_between_samples_is_not_a_delay(tmp_path):
    """A position loop's command, held over each sample interval as a digital controller
    holds it (the suite's effect-free drift case at 250 Hz): its jitter is the loop's
    reaction to the encoder's noise, so the replay holds it too (trajectory.held_efforts)
    and nothing is left to read as a delay: no cause is named, no hold lag is needed
    (session 20 to 24, replayed linear between samples, it needed half a sample's lag,
    reported as the record's hold), and the held-out run is replayed as before."""
    from synthetic_scenarios import make

    case = make(123, "drift", clean=True)
    fit, held = case.write(tmp_path)
    result = calibrate(case.obj, [fit], [held])
    report = result.report
    assert report["causes"] == [], report["selection_log"]
    assert report["effort_hold"] == {}, report["effort_hold"]
    assert all(tr.held == (case.joint,) for tr in result.problem.trajectories)
    assert report["holdout_rmse_after"] <= report["holdout_rmse_before"]


def test_a_loops_reaction_to_encoder_noise_is_not_effort_sensor_noise():
    """A position loop turns the encoder's noise into applied effort: the effort sensor's
    own noise is what the position's jitter does not explain (a PD law on the measured
    position, its velocity over two samples, 1 mN m of sensor noise: the effort's jitter is
    over a hundred times that); an effort no loop computes keeps its plain noise level."""
    from real2code_export.calibrate import features

    rng = np.random.default_rng(3)
    t = np.arange(4000) / 500.0
    q_true = 0.5 + 0.3 * np.sin(1.3 * t)
    q = np.round((q_true + rng.normal(0, 3e-4, t.size)) / 7.7e-4) * 7.7e-4
    vel = np.zeros_like(q)
    vel[2:] = (q[2:] - q[:-2]) / (2 / 500.0)
    effort = 40.0 * (0.55 - q) - 3.0 * vel + rng.normal(0, 1e-3, t.size)
    assert features.noise_level(effort) > 100e-3
    assert features.sensor_noise_level(effort, q) == pytest.approx(1e-3, rel=0.15)
    pushed = np.sin(2.1 * t) + rng.normal(0, 1e-3, t.size)
    assert features.sensor_noise_level(pushed, q) == pytest.approx(
        features.noise_level(pushed), rel=0.05)
