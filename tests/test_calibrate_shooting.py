"""Multiple shooting: a long run of a plant that integrates its input (a drawer pushed with
a measured force, no restoring force) is fitted as pieces, each with its own initial state,
so the open-loop replay's drift cannot take the fit with it."""

from __future__ import annotations

from real2code_export.calibrate import calibrate
from real2code_export.calibrate.problem import build_problem
from real2code_export.calibrate.trajectory import read_csv
from real2code_export.calibrate.validate import _folds
from real2code_export.calibrate.windows import segments
from real2code_export.cli import run as cli_run
from real2code_export.formats import object_json

from synthetic_joint_data import make_case


def test_long_open_loop_run_is_fitted_in_pieces(tmp_path):
    case = make_case(4, kind="drawer", effects=["damping"], duration=11.0)
    csv = tmp_path / "long.csv"
    csv.write_text(case.csv())
    result = calibrate(case.obj, [csv])
    report = result.report
    assert report["shooting_segment"] == 5.0
    assert len(report["data"]) == 2 and all(str(csv) in d for d in report["data"])
    assert result.problem.links == [(0, 1)]  # the pieces are joined by continuity
    assert report["causes"] == ["damping"], report["selection_log"]
    p = report["parameters"][f"{case.joint}.damping"]
    assert abs(p["value"] - case.truth["damping"]["damping"]) <= p["halfwidth95"], p


def test_segment_must_be_positive(tmp_path):
    case = make_case(4, kind="drawer", effects=[])
    csv = tmp_path / "run.csv"
    csv.write_text(case.csv())
    model = object_json.save(case.obj, tmp_path / "model")
    out = tmp_path / "out"
    assert cli_run(["calibrate", str(model), "--data", str(csv), "--segment", "0",
                    "--out", str(out)]) == 2
    assert not out.exists()


def test_left_out_piece_is_no_gap_the_continuity_bridges(tmp_path):
    """Cross-validation leaves out one piece of a run fitted in pieces: the pieces either
    side of it do not meet, so no continuity joins them (the one before would be held to
    end where the one after starts)."""
    case = make_case(4, kind="drawer", effects=[], duration=4.0)
    csv = tmp_path / "run.csv"
    csv.write_text(case.csv())
    pieces = segments(read_csv(csv, case.obj), 1.0)
    assert len(pieces) == 4
    kind, folds = _folds(pieces)
    assert kind == "runs" and [left for _, left in folds] == pieces
    for rest, _ in folds:
        links = build_problem(case.obj, rest, inverse=False).links
        meet = [(a, a + 1) for a in range(len(rest) - 1)
                if rest[a].time[-1] == rest[a + 1].time[0]]
        assert links == meet
