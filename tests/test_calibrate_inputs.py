"""Calibration input checks: every bad trajectory file is refused with a FormatError naming
the file, the column and the line, the command exits non-zero and nothing is written."""

from __future__ import annotations

from pathlib import Path

import pytest

from real2code_export.calibrate import calibrate, read_csv
from real2code_export.cli import run as cli_run
from real2code_export.errors import FormatError
from real2code_export.formats import object_json

from synthetic_joint_data import make_case


@pytest.fixture(scope="module")
def case():
    return make_case(2, kind="lid", effects=["damping"])


@pytest.fixture
def model_file(case, tmp_path) -> Path:
    return object_json.save(case.obj, tmp_path / "model")


def _good_lines(case) -> list[str]:
    return case.csv().splitlines()


def _write(tmp_path: Path, name: str, lines: list[str]) -> Path:
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def _refused(case, model_file: Path, csv: Path, tmp_path: Path, *fragments: str,
             line: int | None = None) -> None:
    with pytest.raises(FormatError) as info:
        read_csv(csv, case.obj)
    err = info.value
    assert err.path == str(csv)
    for fragment in fragments:
        assert fragment in str(err), str(err)
    if line is not None:
        assert err.line == line, str(err)
    out = tmp_path / "out"
    status = cli_run(["calibrate", str(model_file), "--data", str(csv), "--out", str(out)])
    assert status == 2
    assert not out.exists()


def test_good_file_reads(case, tmp_path):
    csv = _write(tmp_path, "good.csv", ["# a comment", *_good_lines(case)])
    traj = read_csv(csv, case.obj)
    assert traj.joints == [case.joint]
    assert traj.n == len(case.time)
    assert case.joint in traj.efforts


def test_no_time_column(case, model_file, tmp_path):
    lines = _good_lines(case)
    lines[0] = lines[0].replace("time", "t")
    csv = _write(tmp_path, "no_time.csv", lines)
    _refused(case, model_file, csv, tmp_path, "no 'time' column", "header", line=1)


def test_column_names_no_joint(case, model_file, tmp_path):
    lines = _good_lines(case)
    lines[0] = lines[0].replace(f",{case.joint},", ",lid_hinge_typo,")
    csv = _write(tmp_path, "typo.csv", lines)
    _refused(case, model_file, csv, tmp_path, "column 'lid_hinge_typo'", "names no joint",
             "hinge", line=1)


def test_model_without_that_joint(case, tmp_path):
    drawer = make_case(1, kind="drawer", effects=[])
    model_file = object_json.save(drawer.obj, tmp_path / "drawer_model")
    csv = _write(tmp_path, "lid.csv", _good_lines(case))
    with pytest.raises(FormatError, match=r"names no joint of model 'synthetic_drawer'"):
        read_csv(csv, drawer.obj)
    out = tmp_path / "out"
    assert cli_run(["calibrate", str(model_file), "--data", str(csv), "--out", str(out)]) == 2
    assert not out.exists()


def test_time_not_increasing(case, model_file, tmp_path):
    lines = _good_lines(case)
    t, rest = lines[10].split(",", 1)
    lines[10] = f"{float(lines[9].split(',')[0])!r},{rest}"
    csv = _write(tmp_path, "time.csv", lines)
    _refused(case, model_file, csv, tmp_path, "time does not increase", "column 'time'",
             line=11)


def test_nan_row(case, model_file, tmp_path):
    lines = _good_lines(case)
    t, q, u = lines[20].split(",")
    lines[20] = f"{t},nan,{u}"
    csv = _write(tmp_path, "nan.csv", lines)
    _refused(case, model_file, csv, tmp_path, f"column '{case.joint}'", "NaN", line=21)


def test_not_a_number(case, model_file, tmp_path):
    lines = _good_lines(case)
    t, q, u = lines[5].split(",")
    lines[5] = f"{t},{q},abc"
    csv = _write(tmp_path, "text.csv", lines)
    _refused(case, model_file, csv, tmp_path, f"column '{case.joint}.effort'",
             "not a number: 'abc'", line=6)


def test_too_few_samples(case, model_file, tmp_path):
    csv = _write(tmp_path, "short.csv", _good_lines(case)[:8])
    _refused(case, model_file, csv, tmp_path, "only 7 samples")


def test_effort_without_position(case, model_file, tmp_path):
    lines = [",".join(c for i, c in enumerate(line.split(",")) if i != 1)
             for line in _good_lines(case)]
    csv = _write(tmp_path, "effort_only.csv", lines)
    _refused(case, model_file, csv, tmp_path, "effort without a position column", line=1)


def test_bad_holdout_writes_nothing(case, model_file, tmp_path):
    good = _write(tmp_path, "good.csv", _good_lines(case))
    lines = _good_lines(case)
    lines[0] = lines[0].replace("time", "seconds")
    bad = _write(tmp_path, "bad_holdout.csv", lines)
    with pytest.raises(FormatError, match="bad_holdout.csv"):
        calibrate(case.obj, [good], [bad], tmp_path / "out")
    out = tmp_path / "out2"
    assert cli_run(["calibrate", str(model_file), "--data", str(good), "--holdout", str(bad),
                    "--out", str(out)]) == 2
    assert not out.exists()


def test_window_end_before_start(case, model_file, tmp_path):
    csv = _write(tmp_path, "good.csv", _good_lines(case))
    with pytest.raises(FormatError, match="--end"):
        calibrate(case.obj, [csv], start=2.0, end=1.0)
    out = tmp_path / "out"
    assert cli_run(["calibrate", str(model_file), "--data", str(csv), "--start", "2",
                    "--end", "1", "--out", str(out)]) == 2
    assert not out.exists()


def test_runs_declaring_different_gravity(case, model_file, tmp_path):
    a = _write(tmp_path, "a.csv", _good_lines(case))
    b = _write(tmp_path, "b.csv", _good_lines(case))
    (tmp_path / "b.experiment.toml").write_text("[world]\ngravity = [0.0, 0.0, -1.62]\n")
    out = tmp_path / "out"
    assert cli_run(["calibrate", str(model_file), "--data", str(a), "--data", str(b),
                    "--out", str(out)]) == 2
    assert not out.exists()
    with pytest.raises(FormatError, match="gravity"):
        calibrate(case.obj, [a, b])
