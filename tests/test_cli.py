"""The command line as users meet it: exit status, messages, nothing half-written."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import trimesh

from real2code_export.cli import EXIT_DISAGREE, EXIT_ERROR, EXIT_OK, run

FIXTURES = Path(__file__).parent / "fixtures" / "urdf"
BAD_INPUTS = [
    ("malformed_xml.urdf", "malformed"),
    ("missing_mesh.urdf", "mesh file not found"),
    ("joint_cycle.urdf", "cycle"),
    ("two_roots.urdf", "root"),
    ("nan_origin.urdf", "not finite"),
    ("zero_axis.urdf", "zero"),
    ("not_collada_mesh.urdf", "not a collada file"),
    ("unknown_joint_type.urdf", "unknown joint type"),
]


@pytest.mark.parametrize("fixture, needle", BAD_INPUTS)
def test_bad_input_is_refused_cleanly(tmp_path, capsys, fixture, needle):
    out = tmp_path / "out"
    status = run(["export", str(FIXTURES / fixture), "--to", "mjcf,urdf", "--out", str(out)])
    err = capsys.readouterr().err
    assert status == EXIT_ERROR
    assert fixture in err and needle in err.lower(), err
    assert "<joint" in err or "<link" in err or "<robot" in err or "malformed" in err.lower(), err
    assert not out.exists(), "nothing may be left in the output folder"


def test_missing_input_path(tmp_path, capsys):
    out = tmp_path / "out"
    status = run(["export", str(tmp_path / "nope.urdf"), "--out", str(out)])
    assert status == EXIT_ERROR
    assert "nope.urdf" in capsys.readouterr().err
    assert not out.exists()


def test_generate_export_check(tmp_path, capsys):
    gen = tmp_path / "gen"
    assert run(["generate", "--category", "storage_furniture", "--parts", "4", "--seed", "3",
                "--out", str(gen)]) == EXIT_OK
    out = tmp_path / "out"
    assert run(["export", str(gen / "object.json"), "--to", "mjcf,urdf", "--out", str(out)]) == 0
    files = sorted(p.name for p in out.iterdir())
    assert files == ["meshes", "storage_furniture_3.urdf", "storage_furniture_3.xml"]
    report = tmp_path / "report.json"
    status = run(["check", str(gen / "object.json"), str(out / "storage_furniture_3.xml"),
                  str(out / "storage_furniture_3.urdf"), "--json", str(report)])
    assert status == EXIT_OK
    data = json.loads(report.read_text())
    assert data["ok"] is True and len(data["probes"]) == 4
    assert "AGREE" in capsys.readouterr().out


def test_check_exit_status_on_disagreement(tmp_path):
    gen = tmp_path / "gen"
    run(["generate", "--category", "laptop", "--seed", "1", "--out", str(gen)])
    run(["export", str(gen / "object.json"), "--to", "urdf", "--out", str(tmp_path / "out")])
    urdf = next((tmp_path / "out").glob("*.urdf"))
    text = urdf.read_text()
    # shift the hinge by 1 mm: the check must notice
    marker = '<origin xyz="'
    i = text.index(marker, text.index("<joint")) + len(marker)
    x_end = text.index(" ", i)
    shifted = text[:i] + repr(float(text[i:x_end]) + 1e-3) + text[x_end:]
    urdf.write_text(shifted)
    assert run(["check", str(gen / "object.json"), str(urdf)]) == EXIT_DISAGREE


# (``real2code demo`` on the shipped sample: tests/test_reconstruct.py, through this CLI.)


def _ajar_parts(tmp_path):
    from pipeline.procedural import generate
    from real2code_export.kinematics import world_part_meshes

    obj = generate("storage_furniture", 4, 21)
    return obj, world_part_meshes(obj)


def test_articulate_a_folder_of_meshes(tmp_path, capsys):
    from real2code_export.meshfiles import obj_bytes

    obj, meshes = _ajar_parts(tmp_path)
    parts = tmp_path / "parts"
    parts.mkdir()
    for name, mesh in meshes.items():
        (parts / f"{name}.obj").write_bytes(obj_bytes(mesh))
    out = tmp_path / "out"
    status = run(["articulate", str(parts), "--out", str(out), "--to", "mjcf,urdf"])
    assert status == EXIT_OK, capsys.readouterr()
    assert (out / "object.json").is_file() and (out / "parts.xml").is_file()
    assert (out / "articulation" / "joints.py").read_text().startswith("root_geom = ")
    from real2code_export.formats import load

    result = load(out / "object.json")
    assert len(result.movable_joints) == len(obj.movable_joints)


def test_articulate_with_aligned_boxes(tmp_path, capsys):
    """--align-boxes on exact parts: the same joints as the parts' own boxes give."""
    from real2code_export.formats import load
    from real2code_export.meshfiles import obj_bytes

    _, meshes = _ajar_parts(tmp_path)
    parts = tmp_path / "parts"
    parts.mkdir()
    for name, mesh in meshes.items():
        (parts / f"{name}.obj").write_bytes(obj_bytes(mesh))
    results = []
    for flags in ([], ["--align-boxes"]):
        out = tmp_path / f"out{len(flags)}"
        status = run(["articulate", str(parts), "--out", str(out), "--to", "mjcf", *flags])
        assert status == EXIT_OK, capsys.readouterr()
        results.append({j.child: j for j in load(out / "object.json").movable_joints})
    own, aligned = results
    assert own.keys() == aligned.keys()
    for child, joint in own.items():
        assert aligned[child].type is joint.type
        assert abs(abs(float(np.dot(aligned[child].axis, joint.axis))) - 1) < 1e-6


def test_articulate_a_glb(tmp_path, capsys):
    from pipeline.parts_io import Y_UP_TO_Z_UP

    obj, meshes = _ajar_parts(tmp_path)
    scene = trimesh.Scene()
    to_y_up = np.linalg.inv(Y_UP_TO_Z_UP)
    for name, mesh in meshes.items():
        scene.add_geometry(mesh.transformed(to_y_up).to_trimesh(), node_name=name, geom_name=name)
    # a scan's points beside the parts: not a part, and said
    scene.add_geometry(trimesh.PointCloud(np.random.default_rng(0).random((50, 3))),
                       node_name="scan_points", geom_name="scan_points")
    glb = tmp_path / "parts.glb"
    glb.write_bytes(scene.export(file_type="glb"))
    out = tmp_path / "out"
    assert run(["articulate", str(glb), "--out", str(out), "--to", "mjcf"]) == EXIT_OK
    assert re.search(r"scan_points hold no triangles.*not read as parts", capsys.readouterr().err)
    from real2code_export.formats import load

    result = load(out / "object.json")
    assert sorted(p.name for p in result.parts) == sorted(meshes)


def test_articulate_refuses_a_single_part(tmp_path, capsys):
    parts = tmp_path / "one"
    parts.mkdir()
    trimesh.creation.box().export(parts / "only.obj")
    out = tmp_path / "out"
    assert run(["articulate", str(parts), "--out", str(out)]) == EXIT_ERROR
    assert "need at least two" in capsys.readouterr().err
    assert not out.exists()


def test_json_reports_are_strict_json(tmp_path, capsys):
    """A figure with no value (an empty bucket's mean) is written as null: Python's json would
    write a bare NaN, which strict readers (JavaScript, jq) refuse."""
    import argparse

    from real2code_export.cli.options import write_evaluation

    out = tmp_path / "figures.json"
    args = argparse.Namespace(json=out, markdown=None)
    write_evaluation(args, "table", {"bucket": {"axis_error_deg": float("nan"), "n": 0,
                                                "type_accuracy": np.float64(1.0)}})
    text = out.read_text()
    assert "NaN" not in text
    assert json.loads(text) == {"bucket": {"axis_error_deg": None, "n": 0, "type_accuracy": 1.0}}


def test_model_arguments_name_the_registry_s_suffixes(capsys):
    from real2code_export.formats import suffixes

    with pytest.raises(SystemExit):
        run(["check", "--help"])
    text = capsys.readouterr().out
    assert all(s in text for s in suffixes())
