"""``simulate``: the same experiments in every engine, each from its native file, compared
with MuJoCo at the step or, at a stop where that has not converged, with the converged
motion (the dynamic check)."""

from __future__ import annotations

from .options import EXIT_DISAGREE, EXIT_OK, model_help

# The parser names no engine or experiment: listing them would import the dynamics package
# (numpy, the formats) and slow every `real2code --help`; names are checked when it runs.


def _names(text: str | None) -> list[str] | None:
    if text is None:
        return None
    return [t.strip() for t in text.split(",") if t.strip()]


def add_parsers(sub) -> None:
    s = sub.add_parser(
        "simulate", help="the same experiments in every engine, each from its native file, "
        "compared with MuJoCo at the step or, at a stop where that has not converged, with "
        "the converged motion (exit 1 beyond tolerance)")
    s.add_argument("input", help=model_help("the object's model file"))
    s.add_argument("--engines", help="comma-separated engines (default: all; those not "
                   "installed are skipped; the list: docs/engines.md)")
    s.add_argument("--experiments", help="comma-separated (default: swing,laws,limit,drop,"
                   "shut; drop and shut collide the parts, in MuJoCo, PhysX and Newton)")
    s.add_argument("--json", help="also write the report as JSON to this file")
    s.add_argument("--tol-angle", type=float, default=None, help="radians (default 0.01)")
    s.add_argument("--tol-distance", type=float, default=None, help="metres (default 0.001)")
    s.add_argument("--faithful-collision", action="store_true",
                   help="a URDF's collision made from its visual meshes keeps hollow parts' "
                   "insides and is cut apart where parts overlap (as exported: "
                   "docs/engines.md)")
    s.set_defaults(func=cmd_simulate)


def _checked(names: list[str] | None, choices, option: str) -> list[str] | None:
    from ..errors import InputError

    if names is None:
        return None
    bad = [n for n in names if n not in choices]
    if bad or not names:
        raise InputError(f"{option}: unknown name(s) {bad or names!r}; choose from "
                         f"{', '.join(choices)}")
    return names


def cmd_simulate(args) -> int:
    from .. import atomic, jsonsafe
    from ..dynamics.contacts import CONTACT_EXPERIMENTS
    from ..dynamics.experiments import EXPERIMENTS
    from ..dynamics.run import ENGINES, TOL_ANGLE, TOL_DISTANCE, format_table, simulate_file

    engines = _checked(_names(args.engines), list(ENGINES), "--engines")
    experiments = _checked(_names(args.experiments), [*EXPERIMENTS, *CONTACT_EXPERIMENTS],
                           "--experiments")
    report = simulate_file(args.input, engines, experiments,
                           TOL_ANGLE if args.tol_angle is None else args.tol_angle,
                           TOL_DISTANCE if args.tol_distance is None else args.tol_distance,
                           faithful_collision=args.faithful_collision)
    print(format_table(report))
    if args.json:
        atomic.write_text(args.json, jsonsafe.dumps(report.to_json()) + "\n")
    return EXIT_OK if report.ok else EXIT_DISAGREE
