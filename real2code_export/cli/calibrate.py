"""``calibrate``: measured motion in, the named causes, the extended model and its report."""

from __future__ import annotations

from pathlib import Path

from .options import model_help


def add_parsers(sub) -> None:
    s = sub.add_parser("calibrate", help="fit joint dynamics to measured motion, name the cause")
    s.add_argument("model", help=model_help("the object's model file"))
    s.add_argument("--data", action="append", required=True, metavar="CSV",
                   help="a measured trajectory to fit (repeatable; format in docs/design.md)")
    s.add_argument("--holdout", action="append", metavar="CSV",
                   help="a measured trajectory to test on, not fitted (repeatable)")
    s.add_argument("--out", required=True, help="output folder: report.json, report.md, "
                   "plots, the calibrated object and its exports")
    s.add_argument("--start", type=float, metavar="S", help="use each run from this time "
                   "on (seconds, the files' time; over the experiment file's window)")
    s.add_argument("--end", type=float, metavar="S", help="use each run up to this time")
    s.add_argument("--experiment", metavar="TOML", help="experiment file (units, gravity, "
                   "window, columns, feedback law) for every CSV without its own "
                   "<stem>.experiment.toml")
    s.add_argument("--segment", type=float, metavar="S", help="fit runs as pieces of S "
                   "seconds, each with its own initial state (multiple shooting)")
    s.set_defaults(func=cmd_calibrate)


def cmd_calibrate(args) -> int:
    """Measured motion in: the named causes, the extended model, its exports and the report."""
    from ..calibrate import run_calibrate

    return run_calibrate(Path(args.model), [Path(x) for x in args.data],
                         [Path(x) for x in args.holdout or []], Path(args.out),
                         start=args.start, end=args.end, segment=args.segment,
                         experiment=Path(args.experiment) if args.experiment else None)
