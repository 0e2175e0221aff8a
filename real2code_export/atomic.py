"""Atomic file output: a failure leaves no half-written file and never replaces a good one.

Single files go through a temporary file in the same folder and ``os.replace``. A set of
files (an export: the model files and the meshes they reference) is built in a staging
folder inside the output folder and moved into place only when every writer succeeded.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path


def _read_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


# Read once, at import: os.umask can only be read by setting it, which is not thread-safe.
_UMASK = _read_umask()


def write_bytes(path: str | Path, data: bytes) -> Path:
    return write_with(path, lambda tmp: tmp.write_bytes(data))


def write_text(path: str | Path, text: str) -> Path:
    return write_bytes(path, text.encode("utf-8"))


def write_with(path: str | Path, write: Callable[[Path], None]) -> Path:
    """``path`` written by ``write(temporary)``, for a library that saves to a path itself
    (USD's layer export: no text through Python): the temporary file is beside ``path``
    with the same suffix (a library may choose the file format by it), then replaces it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=f".tmp{path.suffix}",
                               dir=path.parent)
    os.close(fd)
    try:
        write(Path(tmp))
        os.chmod(tmp, 0o666 & ~_UMASK)  # (mkstemp's file is private; the library may keep it)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
    return path


@contextlib.contextmanager
def staged_output(out_dir: str | Path) -> Iterator[Path]:
    """Yield a staging folder; on success move its whole tree into ``out_dir``.

    On any exception the staging folder is removed, and so is ``out_dir`` if this call
    created it, so nothing is left behind.
    """
    out_dir = Path(out_dir)
    created = not out_dir.exists()
    out_dir.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=".real2code-staging-", dir=out_dir))
    try:
        yield staging
        for src in sorted(staging.rglob("*")):
            if src.is_dir():
                continue
            dst = out_dir / src.relative_to(staging)
            dst.parent.mkdir(parents=True, exist_ok=True)
            os.replace(src, dst)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        if created:
            shutil.rmtree(out_dir, ignore_errors=True)
        raise
    shutil.rmtree(staging, ignore_errors=True)


def as_moved(value, staging: Path, out_dir: Path):
    """``value`` (JSON data: dicts, lists, strings) with every path inside ``staging`` named
    where :func:`staged_output` moves it, for a report written among the files it describes
    (a check of the staged exports must not name the staging folder, which is gone)."""
    if isinstance(value, dict):
        return {k: as_moved(v, staging, out_dir) for k, v in value.items()}
    if isinstance(value, list):
        return [as_moved(v, staging, out_dir) for v in value]
    if isinstance(value, str) and value:
        path = Path(value)
        for base, to in ((Path(staging), Path(out_dir)),
                         (Path(staging).resolve(), Path(out_dir).resolve())):
            if path.is_relative_to(base):
                return str(to / path.relative_to(base))
    return value
