"""The dynamic check: the same experiments in every engine installed here, each from the
file it reads natively, compared with MuJoCo's MJCF (real files, real engines)."""

from __future__ import annotations

import dataclasses
import json
import warnings

import numpy as np
import pytest
from lxml import etree

from pipeline.procedural import generate
from real2code_export.cli import run
from real2code_export.dynamics import Experiment, Trajectory
from real2code_export.dynamics.experiments import EXPERIMENTS
from real2code_export.dynamics.run import ENGINES, REFERENCE, compare, simulate_file, write_formats
from real2code_export.formats import export, load, object_json

from conftest import REPO
from helpers import laptop_with_laws


@pytest.fixture(scope="module")
def laptop(tmp_path_factory):
    return object_json.save(laptop_with_laws(), tmp_path_factory.mktemp("laptop"))


# The engines that agree with MuJoCo in every experiment (docs/engines.md); PhysX and Newton
# run in .venv-engines (scripts/setup_engines.sh) and are skipped with a message without it.
AGREEING = ["mujoco-urdf", "pinocchio", "bullet", "physx", "sapien"]


def test_every_engine_agrees_with_mujoco(laptop):
    report = simulate_file(laptop, AGREEING, list(EXPERIMENTS))
    assert {r.experiment for r in report.runs} == set(EXPERIMENTS)
    by = {(r.experiment, r.engine): r for r in report.runs}
    for r in report.runs:
        assert r.status in ("ok", "reference", "skipped"), (r.experiment, r.engine, r.message)
        if r.status == "skipped":
            warnings.warn(f"{r.engine}: {r.message}", stacklevel=1)
    # Without laws or limits, Pinocchio's integration is MuJoCo's (semi-implicit Euler).
    assert by[("swing", "Pinocchio (URDF)")].max_angle < 1e-9
    assert report.ok


def test_newton_featherstone_swings_and_stops_as_mujoco(tmp_path):
    """Newton's own solver from the USD, its body damping off: rigid-body dynamics alone
    agree; its limit, a spring, told a stiffness and damping from each joint's effective
    inertia, stops a door thrown into it as MuJoCo's does (its default spring left it 1.6 to
    4 rad off). A door without dry friction, which Featherstone does not apply. ~40 s."""
    obj = generate("refrigerator", seed=3)
    for j in obj.movable_joints:
        j.dynamics.friction = 0.0
        j.state = j.limits.lower + 0.3 * (j.limits.upper - j.limits.lower)
    report = simulate_file(object_json.save(obj, tmp_path), ["newton-featherstone"],
                           ["swing", "limit"])
    runs = {r.experiment: r for r in report.runs if r.engine.startswith("Newton")}
    if runs["swing"].status == "skipped":
        pytest.skip(runs["swing"].message)
    assert runs["swing"].status == "ok", runs["swing"].message
    assert runs["swing"].max_angle < 1e-3
    assert runs["limit"].status == "ok", runs["limit"].per_joint
    assert runs["limit"].max_angle < 3e-3


@pytest.mark.parametrize("end", ["lower", "upper"])
def test_a_joint_at_its_limit_pushed_into_it_stays(tmp_path, end):
    """A joint observed at its limit (a reconstruction's range often ends at the observed
    state), pushed into it: the hard stops (Pinocchio here) do not let it move; MuJoCo's
    limit acted only once past it and let it one step (v0 * dt = 1 mrad) in, until our
    files authored its margin (engine_settings.LIMIT_MARGIN)."""
    obj = generate("refrigerator", seed=3)  # a door: gravity along its hinge, no pull
    for j in obj.movable_joints:
        j.state = getattr(j.limits, end)
    report = simulate_file(object_json.save(obj, tmp_path), ["pinocchio", "mujoco-urdf"],
                           ["limit"])
    by = {r.engine: r for r in report.runs}
    assert by["Pinocchio (URDF)"].max_angle < 1e-4, by["Pinocchio (URDF)"].per_joint
    assert by["MuJoCo (URDF)"].max_angle < 1e-9  # the URDF's run told the same margin


def flap(folder):
    """A laptop's screen as a flap: observed at its open stop, where gravity pulls it out;
    thrown into it, it falls through its range onto its other stop at speed, and gravity
    pulls it back out of that one too. No joint laws: the stops alone."""
    obj = generate("laptop", seed=3)
    (j,) = obj.movable_joints
    j.limits.lower, j.limits.upper, j.state = -4.0, 1.2, 1.2
    j.dynamics.damping = j.dynamics.friction = 0.0
    return object_json.save(obj, folder)


def test_mujocos_limit_takes_the_whole_approach_velocity(tmp_path):
    """Our MJCF's limit has the same impedance at contact as deeper in: in the step it acts
    it stops the joint, as Bullet's stop does (both act once a joint is at or past its
    limit), and the two agree through both stops (3.8e-5 rad). With 0.99 at contact (0.999
    deeper) MuJoCo let 1 % of the approach through each step: 9.3e-2 rad from Bullet.
    Pinocchio's stop acts in the step that would cross the limit: off MuJoCo's at 1 ms and
    off the converged motion too (the flap grazes its stop and the kinds part: no step
    agrees), so it disagrees. That motion is uncertain by more than the tolerance here (its
    run at 1/16 step ends elsewhere): it decides nothing, MuJoCo at the step stays the
    reference, and Bullet agrees."""
    report = simulate_file(flap(tmp_path), ["bullet", "pinocchio"], ["limit"])
    by = {r.engine: r for r in report.runs}
    assert by["Pinocchio (URDF)"].status == "disagree"
    assert by["Pinocchio (URDF)"].converged[0] > 0.01
    assert "judged by the converged motion" not in by["MuJoCo (MJCF)"].message
    run = by["Bullet (URDF)"]
    if run.status == "skipped":
        pytest.skip(run.message)
    assert run.max_angle < 1e-3 and run.status == "ok", (run.per_joint, run.status)


def test_a_stop_hit_at_speed_is_judged_against_the_converged_motion(tmp_path):
    """A flap thrown into its open stop falls onto its closed one at speed, gravity pulling
    it out of both: MuJoCo's stop (it acts once the joint is at or past it) lets it a part
    of a step in, Pinocchio's stops it in the step that would cross, and at 1 ms the two are
    1.3e-2 rad apart. MuJoCo at 1 ms has not converged there (1.3e-2 rad from MuJoCo at 1/64
    step, the motion the file describes), so that motion is the joint's one reference:
    Pinocchio, 7.8e-3 rad from it, agrees; MuJoCo from the URDF, the same as MuJoCo at the
    step to 1e-11, does not (an engine is not passed by being near either of two motions
    1.3e-2 apart)."""
    obj = generate("laptop", seed=3)
    (j,) = obj.movable_joints
    j.limits.lower, j.limits.upper, j.state = -1.2, 1.2, 1.2
    j.dynamics.damping = j.dynamics.friction = 0.0
    report = simulate_file(object_json.save(obj, tmp_path), ["pinocchio", "mujoco-urdf"],
                           ["limit"])
    reference, run, urdf = report.runs
    assert run.max_angle > 0.01 and run.converged[0] < 0.009, (run.max_angle, run.converged)
    assert run.status == "ok" and "converged" in run.message
    assert reference.converged[0] > 0.01 and j.name in reference.message
    assert urdf.max_angle < 1e-9 and urdf.status == "disagree", (urdf.max_angle, urdf.status)
    assert report.to_json()["runs"][1]["against_converged"]["angle"] == run.converged[0]


def test_mujocos_limit_is_as_stiff_as_a_shorter_step_allows(tmp_path):
    """Our MJCF's limit time constant is raised to two steps at whatever step a user runs:
    a door thrown into its stop at 0.5 ms steps stops as near Pinocchio's hard stop as at
    1 ms. A fixed 2 ms (four such steps) let it sink further in: 2.9e-3 rad, now 1.2e-3."""
    obj = generate("refrigerator", seed=3)  # gravity along the hinge: the stop alone
    for j in obj.movable_joints:
        j.dynamics.friction = 0.0
        j.state = j.limits.lower + 0.5 * (j.limits.upper - j.limits.lower)
    variant, experiment = EXPERIMENTS["limit"](obj)
    experiment = dataclasses.replace(experiment, dt=5e-4, sample_every=20)
    files = write_formats(variant, tmp_path, ["mjcf", "urdf"])
    reference = REFERENCE.simulate(files["mjcf"], experiment)
    _, angle, _ = compare(experiment, reference,
                          ENGINES["pinocchio"].simulate(files["urdf"], experiment))
    assert angle < 2e-3


def test_springs_and_armature_from_the_urdf(tmp_path):
    """URDF has no place for springs or armature: engines that run it read ours from the
    real2code: attributes (urdf_laws), and agree with MuJoCo's MJCF, which holds them."""
    obj = generate("laptop", seed=3)
    for j in obj.movable_joints:
        j.dynamics.damping, j.dynamics.friction = 0.05, 0.02
        j.dynamics.stiffness, j.dynamics.spring_ref, j.dynamics.armature = 0.8, 0.6, 0.003
    report = simulate_file(object_json.save(obj, tmp_path), ["pinocchio"], ["laws"])
    run = next(r for r in report.runs if r.engine == "Pinocchio (URDF)")
    assert run.status == "ok" and run.max_angle < 1e-3, (run.status, run.max_angle)


def test_report_json_and_exit_status(laptop, tmp_path, capsys):
    out = tmp_path / "report.json"
    assert run(["simulate", str(laptop), "--engines", "pinocchio", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["ok"] and {r["engine"] for r in data["runs"]} == {"MuJoCo (MJCF)",
                                                                 "Pinocchio (URDF)"}
    # Beyond tolerance: exit 1 (friction and limits differ by ~1e-4 rad, not by 1e-12).
    assert run(["simulate", str(laptop), "--engines", "pinocchio", "--experiments", "laws",
                "--tol-angle", "1e-12"]) == 1
    assert "disagree" in capsys.readouterr().out


def test_compare_names_the_worst_joint():
    exp = Experiment("t", ("a", "b"), (True, False), (0.0, 0.0), (0.0, 0.0))
    times = np.array([0.0, 0.01])
    ref = Trajectory(["a", "b"], times, np.zeros((2, 2)))
    other = Trajectory(["a", "b"], times, np.array([[0.0, 0.0], [0.002, 0.003]]))
    per_joint, angle, distance = compare(exp, ref, other)
    assert per_joint == pytest.approx({"a": 0.002, "b": 0.003})
    assert (angle, distance) == pytest.approx((0.002, 0.003))


def test_experiments_start_at_the_observed_state():
    obj = generate("storage_furniture", seed=7)
    _, exp = EXPERIMENTS["limit"](obj)
    for j, q0, v0 in zip(obj.movable_joints, exp.q0, exp.v0, strict=True):
        assert q0 == pytest.approx(min(max(j.state, j.limits.lower), j.limits.upper))
        # thrown toward the nearer limit, fast enough to reach it within about 0.25 s
        near_upper = j.limits.upper - q0 <= q0 - j.limits.lower
        assert (v0 > 0) == near_upper
    variant, _ = EXPERIMENTS["swing"](obj)
    assert all(j.dynamics.damping == 0 and j.dynamics.friction == 0
               for j in variant.movable_joints)


def test_mjcf_metadata_survives_an_xml_rewrite(tmp_path):
    """Any XML tool turns CDATA into text content, which MuJoCo refuses; our metadata is an
    attribute, so the rewritten file still loads with it."""
    import mujoco

    obj = generate("box", seed=1)
    path = export(obj, tmp_path / "out", ["mjcf"])["mjcf"]
    assert "CDATA" not in path.read_text()
    tree = etree.parse(str(path))
    rewritten = tmp_path / "out" / "rewritten.xml"
    rewritten.write_bytes(etree.tostring(tree))
    mujoco.MjModel.from_xml_path(str(rewritten))
    assert load(rewritten).metadata == obj.metadata


def test_mjcf_old_cdata_metadata_still_read(tmp_path):
    obj = generate("box", seed=1)
    path = export(obj, tmp_path / "out", ["mjcf"])["mjcf"]
    root = etree.parse(str(path)).getroot()
    text = root.find("custom/text[@name='real2code:metadata']")
    text.text = etree.CDATA(text.attrib.pop("data"))
    old = tmp_path / "out" / "old.xml"
    old.write_bytes(etree.tostring(root))
    assert "CDATA" in old.read_text()
    assert load(old).metadata == obj.metadata


def test_engines_registry_names_formats_we_export():
    from real2code_export.formats import FORMATS

    assert all(e.format in FORMATS and FORMATS[e.format].exported for e in ENGINES.values())


def test_overlapping_collision_pieces_are_reported(tmp_path):
    """Two parts' pieces overlapping at q = 0 are named with their depth, parent and child
    included (URDF excludes no pair); the shipped cabinet has none."""
    from real2code_export.dynamics.overlap import overlaps

    cabinet = load(REPO / "pipeline" / "samples" / "cabinet" / "object.json")
    assert overlaps(export(cabinet, tmp_path / "cabinet", ["mjcf"])["mjcf"]) == []
    obj = generate("box", seed=1)
    lid = next(p for p in obj.parts if p is not obj.root)
    joint = next(j for j in obj.joints if j.child == lid.name)
    # the lid's pieces moved 2 cm into its parent, in the lid's frame
    down = np.linalg.inv(joint.origin[:3, :3]) @ np.array([0.0, 0.0, -0.02])
    lid.collision = [m.transformed(np.block([[np.eye(3), down[:, None]], [0, 0, 0, 1]]))
                     for m in lid.collision]
    found = overlaps(export(obj, tmp_path / "box", ["mjcf"])["mjcf"])
    assert any({o.part_a, o.part_b} == {obj.root.name, lid.name} and o.depth > 0.005
               for o in found)
    # simulate fails on it (exit status 1) and names the joint along whose range they meet
    object_json.save(obj, tmp_path / "sunk")
    report = simulate_file(tmp_path / "sunk" / "object.json", ["mujoco"], ["swing"])
    assert not report.ok and report.overlaps
    assert [o.joint for o in report.range_overlaps] == [joint.name]
    data = report.to_json()
    assert data["ok"] is False and data["overlaps_along_ranges"][0]["joint"] == joint.name


def test_a_free_body_is_measured_where_the_file_puts_it(tmp_path):
    """At q = 0 a free body stands where its file puts it (MuJoCo's qpos0), not at the
    world's origin, where this cube would sink 10 cm into the block it rests above; moved
    down into the block, it overlaps."""
    from real2code_export.dynamics.overlap import overlaps

    source = tmp_path / "free.xml"
    body = """<mujoco model="free"><worldbody>
      <geom type="box" size="0.1 0.1 0.05"/>
      <body name="cube" pos="0 0 {z}" euler="0 0 30"><freejoint name="cube_free"/>
        <geom type="box" size="0.05 0.05 0.05" mass="0.1"/></body>
    </worldbody></mujoco>"""
    source.write_text(body.format(z=0.5))
    assert overlaps(source) == []
    assert overlaps(export(load(source), tmp_path / "out", ["mjcf"])["mjcf"]) == []
    source.write_text(body.format(z=0.09))
    assert [(o.part_a, o.part_b, round(o.depth, 6)) for o in overlaps(source)] == \
        [("cube", "world", 0.01)]


def test_an_unknown_engine_is_bad_input(capsys):
    from real2code_export.cli import EXIT_ERROR, run

    cabinet = REPO / "pipeline" / "samples" / "cabinet" / "object.json"
    assert run(["simulate", str(cabinet), "--engines", "mujoco,nonesuch"]) == EXIT_ERROR
    assert "--engines: unknown name(s) ['nonesuch']" in capsys.readouterr().err
