"""A xacro file (``robot.urdf.xacro``: ROS's macro language for URDF) read as the URDF it
expands to. The expansion is ROS's own ``xacro`` package (PyPI, no ROS needed) with its
``$(find NAME)`` resolved here, as the URDF reader resolves ``package://NAME``: a folder
named NAME (or holding one) among the file's parent folders, then the search path
(``--package-path``, ``ROS_PACKAGE_PATH``): xacro's own ``find`` asks ROS 2's package index,
which a machine without ROS does not have.
"""

from __future__ import annotations

import contextlib
import zlib
from pathlib import Path

from ...errors import FormatError
from .. import XACRO_SUFFIX
from .packages import find_package, package_search_path, xacro_arguments


def is_xacro(path: Path) -> bool:
    return path.suffix.lower() == XACRO_SUFFIX


def document(path: Path) -> bytes:
    """The URDF a file holds: a xacro file's expansion, any other file's bytes."""
    return expand(path) if is_xacro(path) else path.read_bytes()


# (resolved file, arguments, search path) -> (each file read and its stamp, the expansion):
# an export with its check reads the source three or four times (the reader, MuJoCo's and
# Pinocchio's probes), each expansion 20-50 ms; a hit stands while no file it read changed
_EXPANDED: dict[tuple, tuple[tuple[tuple[str, tuple[int, int] | None], ...], bytes]] = {}


def expand(path: Path) -> bytes:
    """The URDF ``path`` (a xacro file) expands to, with the arguments given
    (:func:`.packages.xacro_arguments`) and xacro's defaults for the rest; FormatError
    naming the file (and xacro's message) where it cannot be expanded."""
    try:
        import xacro
        from xacro import substitution_args
    except ImportError as e:
        raise FormatError(path, None, "a xacro file needs the xacro package "
                          "(pip install xacro)") from e
    try:
        arguments = xacro_arguments()
    except ValueError as e:
        raise FormatError(path, None, str(e)) from e
    key = (str(path.resolve()), tuple(sorted(arguments.items())),
           tuple(str(f) for f in package_search_path()))
    hit = _EXPANDED.get(key)
    if hit is not None and all(_stamp(f) == stamp for f, stamp in hit[0]):
        return hit[1]
    included = len(xacro.all_includes)  # (xacro lists every file it reads, never clearing)
    out = _expand(path, arguments, xacro, substitution_args)
    read = [str(path), *xacro.all_includes[included:]]
    _EXPANDED[key] = tuple((f, _stamp(f)) for f in dict.fromkeys(read)), out
    return out


def _stamp(file: str) -> tuple[int, int] | None:
    """A file's size and checksum (its content: a time stamp may not tick between two
    writes), None where it is gone."""
    try:
        data = Path(file).read_bytes()
    except OSError:
        return None
    return len(data), zlib.crc32(data)


def _expand(path: Path, arguments: dict[str, str], xacro, substitution_args) -> bytes:

    def find(name: str) -> str:
        folder = find_package(name, path.resolve().parent)
        if folder is None:
            raise substitution_args.SubstitutionException(
                f"$(find {name}): no folder named {name!r} (or holding one), nor one whose "
                f"package.xml names it, above the file nor on the search path "
                f"{[str(f) for f in package_search_path()]} (--package-path, "
                "ROS_PACKAGE_PATH)")
        return str(folder)

    # xacro has no hook for finding packages: its module function is replaced while this
    # file expands (xacrodoc, a wrapper made for the same use, replaces it for good).
    with _replaced(substitution_args, "_eval_find", find):
        try:
            doc = xacro.process_file(str(path), mappings=arguments)
        except Exception as e:  # xacro raises its own, expat's, NameError, KeyError...
            raise FormatError(path, None, f"xacro cannot expand it: {_message(e)}") from e
    # as the xacro command prints it, so that a line number here is one in its output
    return doc.toprettyxml(indent="  ", encoding="utf-8")


def _message(e: Exception) -> str:
    from xacro.substitution_args import ArgException

    inner = getattr(e, "exc", None)  # xacro wraps the error it met in its own
    if isinstance(inner, Exception):
        e = inner
    text = str(e).strip() or type(e).__name__
    if isinstance(e, ArgException):
        return (f"undefined argument {text} (an argument without a default: give it with "
                f"--xacro-arg {text}:=VALUE)")
    return text if not isinstance(e, (NameError, KeyError)) else f"{type(e).__name__}: {text}"


@contextlib.contextmanager
def _replaced(module, name: str, value):
    old = getattr(module, name)
    setattr(module, name, value)
    try:
        yield
    finally:
        setattr(module, name, old)
