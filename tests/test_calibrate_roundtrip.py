"""An object calibrated once is calibrated in every simulator: the fitted dynamics are in
every export, the calibrated MJCF replays what the fit saw, and the calibrated URDF
simulated with Pinocchio (its forward dynamics, ``pinocchio.aba``, plus the same damping
and dry-friction laws in our own integrator) reproduces MuJoCo's trajectory of the
calibrated MJCF."""

from __future__ import annotations

import importlib.util
import json

import numpy as np
import pytest

from real2code_export.calibrate import calibrate, replay
from real2code_export.calibrate.trajectory import read_csv
from real2code_export.cli import run as cli_run
from real2code_export.formats import load

from synthetic_joint_data import make_case


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """A lid with hidden viscous damping and dry friction, calibrated; every export."""
    tmp = tmp_path_factory.mktemp("roundtrip")
    case = make_case(5, kind="lid", effects=["damping", "friction"])
    csv = tmp / "lid.csv"
    csv.write_text(case.csv())
    result = calibrate(case.obj, [csv], [], tmp / "out")
    return case, result, tmp / "out", csv


def test_report_and_files(calibrated):
    case, result, out, _ = calibrated
    report = json.loads((out / "report.json").read_text())
    for key in ("causes", "parameters", "rmse_before", "rmse_after", "holdout_rmse_before",
                "holdout_rmse_after", "candidates", "unexplained"):
        assert key in report
    assert set(report["causes"]) == {"damping", "friction"}
    assert report["rmse_after"] < 0.05 * report["rmse_before"]
    assert report["holdout_rmse_before"] is None
    assert not report["unexplained"]
    for p in report["parameters"].values():
        assert p["unit"] and p["ci95"][0] <= p["value"] <= p["ci95"][1]
    assert any(c["selected"] for c in report["candidates"])
    md = (out / "report.md").read_text()
    for name in ("plots/fit_0.png", "plots/candidates.png"):
        assert f"({name})" in md and (out / name).stat().st_size > 1000
    assert (out / "object.json").is_file()


def test_every_export_carries_the_fit(calibrated):
    case, result, out, _ = calibrated
    fitted = {k.split(".", 1)[1]: p["value"] for k, p in result.report["parameters"].items()}
    for suffix in (".json", ".xml", ".urdf", ".usda"):
        path = out / "object.json" if suffix == ".json" else out / f"{case.obj.name}{suffix}"
        if not path.exists():
            pytest.skip(f"{suffix} exporter not available")
        d = load(path).joint(case.joint).dynamics
        assert d.damping == pytest.approx(fitted["damping"], rel=1e-6), suffix
        assert d.friction == pytest.approx(fitted["friction"], rel=1e-6), suffix


def test_calibrated_mjcf_replays_the_fit(calibrated):
    """The MJCF file as written, loaded back and replayed, gives the reported RMSE."""
    case, result, out, csv = calibrated
    obj = load(out / f"{case.obj.name}.xml")
    fit = replay(obj, [read_csv(csv, obj)])
    rmse = float(np.sqrt(np.mean((fit.simulated[0].positions[:, 0] - case.position) ** 2)))
    assert rmse == pytest.approx(result.report["rmse_after"], rel=0.02)


def _pinocchio_free_swing(urdf, joint: str, q0: float, t_end: float, h: float) -> np.ndarray:
    """Free swing in Pinocchio: aba for the rigid body, viscous damping and Coulomb
    friction from the URDF (model.damping / model.friction), semi-implicit Euler with an
    exact stick test (friction can hold the joint still)."""
    import pinocchio as pin

    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    idx = model.getJointId(joint)
    v_idx = model.joints[idx].idx_v
    damping, friction = model.damping.copy(), model.friction.copy()
    q = pin.neutral(model)
    q[model.joints[idx].idx_q] = q0
    v = np.zeros(model.nv)
    out = []
    for _ in range(int(round(t_end / h)) + 1):
        out.append(float(q[model.joints[idx].idx_q]))
        tau = -damping * v
        a_free = pin.aba(model, data, q, v, tau)
        v_free = v + h * a_free
        inv_mass = 1.0 / pin.crba(model, data, q)[v_idx, v_idx]
        # friction impulse over the step, limited by what would stop the joint
        stop = h * friction[v_idx] * inv_mass
        if abs(v_free[v_idx]) <= stop:
            v_free[v_idx] = 0.0
        else:
            v_free[v_idx] -= np.sign(v_free[v_idx]) * stop
        v = v_free
        q = pin.integrate(model, q, v * h)
    return np.array(out)


def _mujoco_free_swing(xml, joint: str, q0: float, t_end: float, h: float) -> np.ndarray:
    import mujoco

    from real2code_export.calibrate.extras import joint_extras

    m = mujoco.MjModel.from_xml_path(str(xml))
    obj = load(xml)
    friction = joint_extras(obj, joint).get("friction")
    jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, joint)
    if friction:  # the friction softness the calibration used, from the model's metadata
        m.dof_solref[m.jnt_dofadr[jid]] = [friction["timeconst"], friction["dampratio"]]
    m.opt.timestep = h
    d = mujoco.MjData(m)
    d.qpos[m.jnt_qposadr[jid]] = q0
    mujoco.mj_forward(m, d)
    out = []
    for _ in range(int(round(t_end / h)) + 1):
        out.append(float(d.qpos[m.jnt_qposadr[jid]]))
        mujoco.mj_step(m, d)
    return np.array(out)


def test_pinocchio_reproduces_mujoco(calibrated):
    if importlib.util.find_spec("pinocchio") is None:
        pytest.skip("pinocchio (pin) is not installed")
    case, result, out, _ = calibrated
    urdf, xml = out / f"{case.obj.name}.urdf", out / f"{case.obj.name}.xml"
    if not urdf.exists():
        pytest.skip("the URDF exporter (formats/urdf) is not available")
    h, t_end, q0 = 2.5e-4, 3.0, 0.9
    q_mj = _mujoco_free_swing(xml, case.joint, q0, t_end, h)
    q_pin = _pinocchio_free_swing(urdf, case.joint, q0, t_end, h)
    # the calibrated dynamics act: the swing decays and settles
    assert np.ptp(q_mj[-int(0.5 / h):]) < 0.5 * np.ptp(q_mj[: int(0.5 / h)])
    err = np.abs(q_mj - q_pin)
    assert err.max() < 0.01 * np.ptp(q_mj), (err.max(), np.ptp(q_mj))


def test_cli_calibrate_with_holdout_is_deterministic(tmp_path):
    """`real2code calibrate MODEL --data CSV --holdout CSV --out DIR`: exit 0, the gain on
    held-out data, and the same bytes when run again."""
    from real2code_export.formats import object_json

    from synthetic_joint_data import rerun

    case = make_case(2, kind="lid", effects=["damping"])
    held = rerun(case, 1)
    model = object_json.save(case.obj, tmp_path / "model")
    (tmp_path / "fit.csv").write_text(case.csv())
    (tmp_path / "held.csv").write_text(held.csv())
    outs = []
    for k in range(2):
        out = tmp_path / f"out{k}"
        status = cli_run(["calibrate", str(model), "--data", str(tmp_path / "fit.csv"),
                          "--holdout", str(tmp_path / "held.csv"), "--out", str(out)])
        assert status == 0
        outs.append(out)
    report = json.loads((outs[0] / "report.json").read_text())
    assert report["causes"] == ["damping"]
    assert report["holdout_rmse_after"] < 0.05 * report["holdout_rmse_before"]
    files = sorted(p.relative_to(outs[0]) for p in outs[0].rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(outs[1]) for p in outs[1].rglob("*") if p.is_file())
    for rel in files:
        assert (outs[0] / rel).read_bytes() == (outs[1] / rel).read_bytes(), rel
