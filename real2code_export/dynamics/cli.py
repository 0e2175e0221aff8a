"""The ``real2code simulate`` command (its parser and handler, added by cli.py)."""

from __future__ import annotations

import argparse
import json

EXIT_OK, EXIT_DISAGREE = 0, 1


def _names(choices):
    def parse(text: str) -> list[str]:
        names = [t.strip() for t in text.split(",") if t.strip()]
        bad = [n for n in names if n not in choices]
        if bad or not names:
            raise argparse.ArgumentTypeError(
                f"unknown name(s) {bad or text!r}; choose from {', '.join(choices)}")
        return names
    return parse


def add_parser(sub) -> None:
    from .experiments import EXPERIMENTS
    from .run import ENGINES, TOL_ANGLE, TOL_DISTANCE

    s = sub.add_parser(
        "simulate", help="the same experiments in every engine, each from its native file, "
        "compared with MuJoCo (exit 1 beyond tolerance)")
    s.add_argument("input", help="the object: object.json, .urdf, MJCF .xml, .usd, ...")
    s.add_argument("--engines", type=_names(list(ENGINES)), default=None,
                   help=f"comma-separated (default: all of {','.join(ENGINES)}); "
                   "engines not installed are skipped")
    s.add_argument("--experiments", type=_names(list(EXPERIMENTS)), default=None,
                   help=f"comma-separated (default: {','.join(EXPERIMENTS)})")
    s.add_argument("--json", help="also write the report as JSON to this file")
    s.add_argument("--tol-angle", type=float, default=TOL_ANGLE,
                   help=f"radians (default {TOL_ANGLE:g})")
    s.add_argument("--tol-distance", type=float, default=TOL_DISTANCE,
                   help=f"metres (default {TOL_DISTANCE:g})")
    s.set_defaults(func=cmd_simulate)


def cmd_simulate(args) -> int:
    from .. import atomic
    from .run import format_table, simulate_file

    report = simulate_file(args.input, args.engines, args.experiments, args.tol_angle,
                           args.tol_distance)
    print(format_table(report))
    if args.json:
        atomic.write_text(args.json, json.dumps(report.to_json(), indent=1) + "\n")
    return EXIT_OK if report.ok else EXIT_DISAGREE
