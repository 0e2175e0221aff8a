"""``export``, ``check`` and ``generate``: models in and out of the formats, proven by loading
them back in their own tools."""

from __future__ import annotations

import contextlib
import warnings
from pathlib import Path

from ..errors import Real2CodeError, Real2CodeWarning
from .options import EXIT_DISAGREE, EXIT_OK, add_formats_option, chosen_formats, model_help


def add_parsers(sub) -> None:
    s = sub.add_parser("export", help="convert a model to simulator and content formats")
    s.add_argument("input", help=model_help("the model file"))
    add_formats_option(s, "every available one but json")
    s.add_argument("--out", required=True, help="output folder")
    s.add_argument("--check", action="store_true",
                   help="check every export against the input (a URDF or MJCF input loaded in "
                        "its own tools as the reference: kinematics and dynamics); exit 1 on "
                        "disagreement")
    s.add_argument("--configurations", type=int, default=100, help="for --check")
    _add_source_options(s)
    s.set_defaults(func=cmd_export)

    s = sub.add_parser("check", help="load files in their own tools and compare kinematics "
                       "(and dynamics with --reference)")
    s.add_argument("files", nargs="+", help=model_help("model files to compare"))
    s.add_argument("--json", help="also write the report as JSON to this file")
    s.add_argument("--configurations", type=int, default=100, help="random configurations")
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--tol-position", type=float, default=1e-6, help="metres (default 1e-6)")
    s.add_argument("--tol-rotation", type=float, default=1e-6, help="radians (default 1e-6)")
    s.add_argument("--reference", metavar="FILE",
                   help="the URDF, MJCF or USD file the files were made from, loaded in "
                        "its own tools (MuJoCo; and Pinocchio for URDF; Newton for USD) as "
                        "the reference; the exports' "
                        "masses, inertias and joint dynamics and limits are compared with it "
                        "too")
    s.add_argument("--tol-dynamics", type=float, default=1e-6,
                   help="with --reference: absolute and relative (default 1e-6)")
    _add_source_options(s)
    s.set_defaults(func=cmd_check)

    s = sub.add_parser("generate", help="a procedural articulated object")
    s.add_argument("--category", required=True,
                   help="storage_furniture, table, refrigerator, laptop, box, or a household "
                        "one (oven, dishwasher, microwave, trash_can, door)")
    s.add_argument("--parts", type=int, default=None, help="number of rigid parts")
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--out", required=True, help="output folder (object.json and meshes)")
    s.set_defaults(func=cmd_generate)


def _add_source_options(parser) -> None:
    parser.add_argument("--package-path", action="append", default=[], metavar="DIR",
                        help="a folder holding ROS packages, for package:// and model:// mesh "
                             "URIs and xacro's $(find) (repeatable; searched before "
                             "ROS_PACKAGE_PATH)")
    parser.add_argument("--xacro-arg", action="append", default=[], metavar="NAME:=VALUE",
                        help="an argument of a .xacro input, as the xacro command takes it "
                             "(repeatable)")


def _use_package_path(args) -> None:
    """The source options, where the readers (and the check's tools, in processes forked
    from this one) look for them: ROS_PACKAGE_PATH, and the xacro arguments' variable."""
    import os

    from ..formats.urdf.packages import XACRO_ARGS_VARIABLE

    if args.package_path:
        folders = [str(Path(p).resolve()) for p in args.package_path]
        rest = [p for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
        os.environ["ROS_PACKAGE_PATH"] = os.pathsep.join(folders + rest)
    if args.xacro_arg:
        os.environ[XACRO_ARGS_VARIABLE] = "\n".join(args.xacro_arg)


def cmd_export(args) -> int:
    from .. import forked
    from ..formats import FORMATS, export, format_for_path, hulls_collision, imported

    _use_package_path(args)
    # The input is read in a forked copy while the writers' libraries import (which also
    # tells which of the default formats work here): the reader's own imports first, once.
    # Its option is the formats' (USD and glTF alone: no hulls); should the formats that
    # work here want the other, it is read again here.
    # In the server's fork (cli/server_loop.py) they are imported already: nothing to overlap.
    named = args.to or [f.name for f in FORMATS.values() if f.exported]
    _import_reader(args.input)
    if all(imported(name) for name in named):
        formats = chosen_formats(args)
        obj, said = _read(args.input, hulls_collision(formats))
    else:
        with forked.start(_read, args.input, hulls_collision(named)) as reading:
            formats = chosen_formats(args)
            obj, said = reading.result() if hulls_collision(formats) == hulls_collision(named) \
                else _read(args.input, hulls_collision(formats))
    for w in said:  # on to the command's boundary, which prints them
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    written = export(obj, args.out, formats)
    for name, path in written.items():
        print(f"{name:5s} {path}")
    if not args.check:
        return EXIT_OK
    # --check: every export against the input file, loaded in its own tools when it has them
    # (a URDF or MJCF source; a USD source in Newton where the engines venv is installed and
    # Newton loads it, else warned; other inputs are compared through the exports alone).
    from ..check import check_files, format_table

    try:
        kind = format_for_path(args.input).name
    except Real2CodeError:  # a folder holding object.json
        kind = None
    source = Path(args.input) if kind in ("urdf", "mjcf", "usd") else None
    report = check_files(list(written.values()), source=source, source_required=kind != "usd",
                         n_configurations=args.configurations,
                         warned=[str(w.message) for w in said])
    print(format_table(report))
    return EXIT_OK if report.ok else EXIT_DISAGREE


def _import_reader(path: str) -> None:
    """Import the reader of ``path``'s format (and so numpy and the model), where it has one
    that imports, before a forked copy reads it: imported once, for both processes. What
    fails here fails again, with its message, when the file is read."""
    from ..formats import format_for_path

    with contextlib.suppress(Real2CodeError):
        format_for_path(path).load_module()


def _read(path: str, hulls_collision: bool):
    """The model in file ``path`` and the warnings reading it gave (its repairs), to be
    given again by the command (and kept for --check: a repaired mass or limit differs from
    the source's). USD (and glTF) consumers hull each collision mesh themselves: an export
    to those alone computes no hulls (docs/formats.md, "Collision")."""
    from ..formats import load

    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always", Real2CodeWarning)
        obj = load(path, hull_collision=not hulls_collision)
    return obj, [warnings.WarningMessage(str(w.message), w.category, w.filename, w.lineno)
                 for w in said]


def cmd_check(args) -> int:
    from ..check import check_files, format_table

    _use_package_path(args)
    report = check_files(
        [Path(p) for p in args.files],
        source=args.reference,
        n_configurations=args.configurations,
        seed=args.seed,
        tol_position=args.tol_position,
        tol_rotation=args.tol_rotation,
        tol_dynamics=args.tol_dynamics,
    )
    print(format_table(report))
    if args.json:
        from .. import atomic, jsonsafe

        atomic.write_text(args.json, jsonsafe.dumps(report.to_json()) + "\n")
    return EXIT_OK if report.ok else EXIT_DISAGREE


def cmd_generate(args) -> int:
    from pipeline.procedural import generate

    from .. import atomic
    from ..formats import object_json

    obj = generate(args.category, args.parts, args.seed)
    with atomic.staged_output(args.out) as staging:
        object_json.save(obj, staging)
    print(f"{obj.name}: {len(obj.parts)} parts, {len(obj.movable_joints)} movable joints -> "
          f"{Path(args.out) / object_json.FILENAME}")
    return EXIT_OK
