"""``real2code batch export|check|calibrate|reconstruct INPUTS... --out DIR``.

The main CLI wires it with ``add_parsers(subparsers)``; ``python -m real2code_export.batch``
runs it alone. Exit status: 0 every object done, 1 some object failed (the manifest says
why), 2 bad input (nothing ran), 3 an internal error, 130 interrupted (rerun the same command
to continue).
"""

from __future__ import annotations

import argparse
import sys

from .options import EXIT_DISAGREE as EXIT_FAILED
from .options import EXIT_ERROR, EXIT_INTERRUPTED, EXIT_OK, formats_arg

KINDS = ("export", "check", "calibrate", "reconstruct")  # batch.tasks.TASKS (a test holds it)
__all__ = ["EXIT_ERROR", "EXIT_FAILED", "EXIT_INTERRUPTED", "EXIT_OK", "add_parsers", "main"]


def add_parsers(subparsers) -> argparse.ArgumentParser:
    """Add the ``batch`` command to a CLI's subparsers."""
    s = subparsers.add_parser(
        "batch", help="export, check, calibrate or reconstruct many objects (process pool or Ray)",
        description="Run one task per object over files, folders or glob patterns (a whole "
        "dataset tree); DIR/manifest.jsonl records every object; rerunning the same command "
        "skips objects already done whose inputs did not change.")
    s.add_argument("task", choices=KINDS, help="what to do with each object")
    s.add_argument("inputs", nargs="+", metavar="INPUT",
                   help="files, folders or glob patterns (quote patterns: 'data/*/mobility.urdf')")
    s.add_argument("--out", required=True, help="output folder: DIR/<object id>/ per object")
    s.add_argument("--engine", choices=["local", "ray"], default="local",
                   help="local: a process pool on this machine (default); ray: Ray tasks")
    s.add_argument("--workers", type=int, default=None,
                   help="worker processes (default: the CPU count; with --address, the cluster's)")
    s.add_argument("--address", help="join this Ray cluster (default: start an embedded one)")
    s.add_argument("--transfer", choices=["shared", "object-store"], default="shared",
                   help="ray: how workers get files: a shared file system (default) or Ray's "
                   "object store (nodes without one)")
    s.add_argument("--retries", type=int, default=2,
                   help="runs again of an object whose worker process died (default 2)")
    s.add_argument("--force", action="store_true", help="redo every object")
    s.add_argument("--cache", help="collision-decomposition cache shared by the workers "
                   "(default: DIR/.cache)")
    s.add_argument("--json", nargs="?", const="-", metavar="FILE",
                   help="the summary as JSON, on stdout (the table then goes to stderr) or to FILE")
    s.add_argument("--quiet", action="store_true", help="no progress bar")
    t = s.add_argument_group("task options")
    t.add_argument("--to", type=formats_arg, default=None,
                   help="export/calibrate: comma-separated formats "
                   "(default: json and every available one of mjcf,urdf,usd,gltf)")
    t.add_argument("--check", action=argparse.BooleanOptionalAction, default=True,
                   help="check the files each object gets against each other (default: on)")
    t.add_argument("--configurations", type=int, default=100, help="check: configurations")
    t.add_argument("--seed", type=int, default=0, help="check: random configurations' seed")
    t.add_argument("--tol-position", type=float, default=1e-6, help="check: metres")
    t.add_argument("--tol-rotation", type=float, default=1e-6, help="check: radians")
    s.set_defaults(func=cmd_batch)
    return s


def cmd_batch(args) -> int:
    from .. import atomic, jsonsafe
    from ..batch.progress import format_summary
    from ..batch.run import run_batch
    from ..batch.tasks import TaskOptions
    from ..formats import FORMATS

    for name in args.to or ():  # a format that cannot be written here: refused before any object
        FORMATS[name].load_module(writing=True)
    options = TaskOptions(formats=tuple(args.to or ()), check=args.check,
                          configurations=args.configurations, seed=args.seed,
                          tol_position=args.tol_position, tol_rotation=args.tol_rotation)
    summary = run_batch(args.task, args.inputs, args.out, options=options, engine=args.engine,
                        workers=args.workers, retries=args.retries, address=args.address,
                        transfer=args.transfer, cache_dir=args.cache, force=args.force, progress=not args.quiet)
    table = format_summary(summary)
    if args.json == "-":
        print(table, file=sys.stderr)
        print(jsonsafe.dumps(summary.to_json()))
    else:
        print(table)
        if args.json:
            atomic.write_text(args.json, jsonsafe.dumps(summary.to_json()) + "\n")
    if summary.interrupted:
        print("interrupted: rerun the same command to continue", file=sys.stderr)
        return EXIT_INTERRUPTED
    return EXIT_FAILED if summary.counts["failed"] else EXIT_OK


def main(argv: list[str] | None = None) -> int:
    """``python -m real2code_export.batch ...`` (the same as ``real2code batch ...``)."""
    parser = argparse.ArgumentParser(prog="python -m real2code_export.batch")
    add_parsers(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(["batch", *(sys.argv[1:] if argv is None else argv)])
    return run_parsed(args)


def run_parsed(args) -> int:
    """Run parsed arguments inside the main CLI's error boundary."""
    from .boundary import call

    return call(args.func, args)
