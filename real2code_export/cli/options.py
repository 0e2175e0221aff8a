"""What every command shares: the exit statuses and the ``--to`` option (the registry's
formats). Imports nothing heavy: the parser is built from this on every run."""

from __future__ import annotations

# docs/design.md, "Exit status"
EXIT_OK = 0  # success
EXIT_DISAGREE = 1  # the check found a disagreement (batch: some object failed)
EXIT_ERROR = 2  # bad input: the message names the file, the element and what is wrong
EXIT_INTERNAL = 3  # a bug: a short message and the file the traceback was written to
EXIT_INTERRUPTED = 130  # Ctrl-C (batch: rerun the same command to continue)


def formats_arg(text: str) -> list[str]:
    """``--to mjcf,urdf``: names the registry knows (whether they work here is asked when the
    command runs, so building the parser imports no format)."""
    import argparse

    from ..errors import FormatError
    from ..formats import parse_names

    try:
        return parse_names(text)
    except FormatError as e:
        raise argparse.ArgumentTypeError(e.message) from e


def model_help(what: str) -> str:
    """A model argument's help: what it is, and the suffixes the format registry reads."""
    from ..formats import suffixes

    return f"{what} ({', '.join(suffixes())})"


def add_formats_option(parser, default_help: str = "every available one") -> None:
    from ..formats import FORMATS

    parser.add_argument("--to", type=formats_arg, default=None, metavar="FORMATS",
                        help=f"comma-separated formats of {','.join(FORMATS)} "
                        f"(default: {default_help})")


def chosen_formats(args) -> list[str]:
    """``--to`` as given, or every exported format that works here; a named format that
    cannot work here is an UnavailableError (exit 2) saying why."""
    from ..formats import FORMATS, export_formats

    if not args.to:
        return export_formats()
    for name in args.to:
        FORMATS[name].load_module(writing=True)  # raises, naming what fails to import
    return list(args.to)


def write_evaluation(args, table: str, figures: dict) -> None:
    """The tail of every ``evaluate`` command: the tables printed, and written as JSON
    (``--json``) and markdown (``--markdown``) where asked."""
    from .. import atomic, jsonsafe

    print(table)
    if args.json:  # a figure with no value (no joint of a kind, say) is null, never NaN
        atomic.write_text(args.json, jsonsafe.dumps(figures) + "\n")
    if args.markdown:
        atomic.write_text(args.markdown, table + "\n")
