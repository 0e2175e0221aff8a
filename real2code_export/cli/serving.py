"""What the command server (:mod:`.server`) and the command line handing it a command
(:mod:`.handoff`) agree on: where the server listens, what it must share with a command to
run it, and the messages between them. Standard library only: it is imported on every
command.

One server per installation (interpreter and package folder) and user: its socket lives in a
folder only the user can enter (``$XDG_RUNTIME_DIR/real2code``, else
``/tmp/real2code-<uid>``), named by a checksum of the installation.
"""

from __future__ import annotations

import json
import os
import stat
import struct
import sys
import zlib
from pathlib import Path

# Set to "off" to run every command here, never in a server.
ENV_SWITCH = "REAL2CODE_SERVER"

# Variables read when the libraries a server imports are imported (so a command may only
# run in a server that has the same): the interpreter's, MuJoCo's, USD's, the thread pools'
# and the loader's. Every other variable is the command's own and travels with it.
IMPORT_TIME_PREFIXES = ("PYTHON", "MUJOCO_", "PXR_", "OMP_", "OPENBLAS_", "MKL_", "TBB_",
                        "LD_")

_HEADER = struct.Struct("!I")


class Installation:
    """This interpreter and this copy of the package: what a server must share with a
    command to run it."""

    def __init__(self) -> None:
        self.package = Path(__file__).resolve().parents[1]  # real2code_export/
        # (zlib's checksum names it: hashlib would load OpenSSL, 2 ms of every command)
        self.key = f"{zlib.crc32(f'{sys.executable}|{self.package}'.encode()):08x}"

    def folder(self) -> Path:
        """The user's folder of servers (made by the server, 0700: a command only looks)."""
        runtime = os.environ.get("XDG_RUNTIME_DIR")
        return Path(runtime) / "real2code" if runtime else Path(f"/tmp/real2code-{os.getuid()}")

    def make_folder(self) -> Path:
        folder = self.folder()
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
        return folder

    def socket_path(self) -> Path:
        return self.folder() / f"server-{self.key}.sock"

    def log_path(self) -> Path:
        return self.folder() / f"server-{self.key}.log"


def private(folder: Path) -> str | None:
    """Why ``folder`` is not safe to hold the socket (another user's, or open to others),
    or None."""
    st = folder.stat()
    if st.st_uid != os.getuid():
        return f"{folder} belongs to another user"
    if stat.S_IMODE(st.st_mode) & 0o077:
        return f"{folder} is open to other users (mode {stat.S_IMODE(st.st_mode):o})"
    return None


def code_stamp(package: Path) -> list[int]:
    """The package's Python sources as they are now (how many, their newest change, their
    total size): a server that imported older ones is stale. Walks ~140 files, 2 ms."""
    count = newest = size = 0
    stack = [str(package)]
    while stack:
        with os.scandir(stack.pop()) as entries:
            for e in entries:
                if e.is_dir(follow_symlinks=False):
                    if e.name != "__pycache__" and not e.name.startswith("."):
                        stack.append(e.path)
                elif e.name.endswith(".py"):
                    st = e.stat()
                    count, size = count + 1, size + st.st_size
                    newest = max(newest, st.st_mtime_ns)
    return [count, newest, size]


def identity(installation: Installation) -> dict:
    """What a command and the server must share, in two kinds: ``code`` (this package as it
    is on disk: a server with other code is stale and stops) and ``runtime`` (the
    interpreter, its flags and the import-time environment: a command started otherwise runs
    on its own, the server stays)."""
    from .. import __version__

    return {
        "code": {"version": __version__, "package": str(installation.package),
                 "stamp": code_stamp(installation.package)},
        "runtime": {"executable": sys.executable, "python": sys.version,
                    "flags": list(sys.flags), "warnoptions": list(sys.warnoptions),
                    "xoptions": {k: str(v) for k, v in sys._xoptions.items()},
                    "environment": {k: v for k, v in sorted(os.environ.items())
                                    if k.startswith(IMPORT_TIME_PREFIXES)}},
    }


def mismatch(mine: dict, theirs: dict, kind: str) -> str | None:
    """The first entry of ``kind`` (``code`` or ``runtime``) in which two identities differ,
    said for a person, or None."""
    a, b = mine.get(kind, {}), theirs.get(kind, {})
    for key in sorted(set(a) | set(b)):
        if a.get(key) != b.get(key):
            if key == "environment":
                names = sorted(k for k in set(a[key]) | set(b[key])
                               if a[key].get(k) != b[key].get(k))
                return f"environment variable(s) {', '.join(names)} differ"
            return {"stamp": "the package's sources changed since the server started"}.get(
                key, f"{key} differs")
    return None


def pack(message: dict) -> bytes:
    """A request on the wire: its length, then its JSON."""
    body = json.dumps(message).encode()
    return _HEADER.pack(len(body)) + body


def unpack_length(head: bytes) -> int:
    return _HEADER.unpack(head)[0]


HEADER_SIZE = _HEADER.size
