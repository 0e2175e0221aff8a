"""The sealed error boundary every command runs inside: the project's errors are exit 2 with
their message, and so is a library the command needs that cannot be imported here (not
installed, or installed and broken: named, with its error); anything else is exit 3 with a
short message and the file the traceback was written to; never a bare traceback. Repair
warnings are printed once each."""

from __future__ import annotations

import re
import sys
import warnings

from ..errors import Real2CodeError, Real2CodeWarning
from .options import EXIT_ERROR, EXIT_INTERNAL, EXIT_INTERRUPTED


def call(func, args) -> int:
    """``func(args)``'s exit status, with every failure turned into a message and a status."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", Real2CodeWarning)
        try:
            status = func(args)
        except Real2CodeError as e:
            return _fail(caught, f"error: {e}", EXIT_ERROR)
        except OSError as e:  # the input or output path: missing, unreadable, disk full
            where = e.filename if e.filename is not None else ""
            text = e.strerror or str(e)
            return _fail(caught, f"error: {where}: {text}" if where else f"error: {text}",
                         EXIT_ERROR)
        except KeyboardInterrupt:
            return _fail(caught, "interrupted", EXIT_INTERRUPTED)
        except Exception as e:  # noqa: BLE001 - the boundary: a bug, reported, never raw
            # A library that cannot be imported, raised as such or while a library handled
            # it (trimesh takes scipy's absence for a degenerate input and fails on that).
            failed = _failed_import(e)
            library = _library(failed) if failed is not None else None
            if library is None:  # none, or one of our own modules: a bug
                return _internal(caught, e)
            return _fail(caught, f"error: this command needs {library}, which cannot be "
                         f"imported here ({type(failed).__name__}: {failed})", EXIT_ERROR)
    _print_warnings(caught)
    return status


OURS = ("real2code_export", "pipeline", "blender_addon")


def _failed_import(e: BaseException) -> ImportError | None:
    """``e`` if it is an ImportError, else the first one it was raised from or while
    handling, or None."""
    seen = set()
    while e is not None and id(e) not in seen:
        if isinstance(e, ImportError):
            return e
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return None


def _library(e: ImportError) -> str | None:
    """The third-party package whose import failed (its top-level name), or None when the
    import that failed is one of ours or cannot be told."""
    name = e.name
    if name is None:  # re-raised by a library from its arguments (trimesh): the message
        said = re.match(r"No module named '([^']+)'", str(e))
        name = said.group(1) if said else None
    if name is None:  # raised by hand inside a package's import: the innermost package
        tb, names = e.__traceback__, []
        while tb is not None:
            names.append(tb.tb_frame.f_globals.get("__name__") or "")
            tb = tb.tb_next
        outside = [n for n in names if n.split(".")[0] not in (*OURS, "importlib", "__main__")]
        name = outside[0] if outside else None
    if not name or name.split(".")[0] in OURS:
        return None
    return name.split(".")[0]


def _internal(caught, e: BaseException) -> int:
    path = _write_traceback()
    return _fail(caught, f"internal error: {type(e).__name__}: {e}\n"
                 f"(a bug; the traceback is in {path})", EXIT_INTERNAL)


def _fail(caught, message: str, status: int) -> int:
    _print_warnings(caught)
    print(message, file=sys.stderr)
    return status


def _write_traceback() -> str:
    import tempfile  # only on a bug: not on every command's start
    import traceback

    with tempfile.NamedTemporaryFile("w", prefix="real2code-traceback-", suffix=".txt",
                                     delete=False) as f:
        f.write(f"real2code {' '.join(sys.argv[1:])}\n\n")
        f.write(traceback.format_exc())
    return f.name


def _print_warnings(caught) -> None:
    seen = set()
    for w in caught:
        if issubclass(w.category, Real2CodeWarning) and str(w.message) not in seen:
            seen.add(str(w.message))
            print(f"warning: {w.message}", file=sys.stderr)
