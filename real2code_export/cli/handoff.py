"""A command handed to this installation's running server (``real2code server start``), which
runs it in a fresh fork of itself, its libraries already imported: the command's arguments,
folder, environment, umask and its very standard streams (the file descriptors, passed over
the socket) go to the fork, which writes to the terminal or pipe itself; its exit status
comes back and is this process's. Ctrl-C and other signals sent here are passed on.

Where no server runs, or one runs for other code or another environment, the command runs
here as always (None from :func:`hand_off`).
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import sys

from . import serving
from .options import EXIT_INTERNAL

# Passed on to the command while it runs in the server; it answers them as it would here.
FORWARDED = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGQUIT)


def hand_off(argv: list[str]) -> int | None:
    """``argv``'s exit status, run by the server; None where it must run here."""
    if os.environ.get(serving.ENV_SWITCH) == "off" or not argv or argv[0] == "server" \
            or not sys.platform.startswith("linux"):
        return None
    installation = serving.Installation()
    path = installation.socket_path()
    if not path.exists() or serving.private(path.parent):
        return None
    try:
        for fd in (0, 1, 2):
            os.fstat(fd)  # a closed standard stream cannot be passed: run here
    except OSError:
        return None
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        sock.connect(str(path))
    except OSError:  # left by a server that was killed: `server start` replaces it
        sock.close()
        return None
    with sock:
        try:
            cwd = os.getcwd()
        except OSError:  # a folder since removed: as Python itself would say, here
            return None
        umask = os.umask(0)
        os.umask(umask)
        request = {
            "op": "run", "argv": argv, "argv0": sys.argv[0], "cwd": cwd,
            "environment": dict(os.environ), "umask": umask, "path": sys.path,
            "streams": [[s.encoding, s.errors] if s is not None else None
                        for s in (sys.stdin, sys.stdout, sys.stderr)],
            "identity": serving.identity(installation),
        }
        try:
            socket.send_fds(sock, [serving.pack(request)], [0, 1, 2])
            reader = sock.makefile("r", encoding="utf-8")
            first = reader.readline().split(" ", 1)
        except OSError:
            return None
        if first[0] != "run":  # refused: another environment, or stale code (it stops)
            return None
        return _wait(sock, reader)


def _wait(sock: socket.socket, reader) -> int:
    """The command's exit status, passing this process's signals on while it runs."""
    def pass_on(signum, frame):
        with contextlib.suppress(OSError):
            sock.sendall(f"signal {signum}\n".encode())

    before = {s: signal.signal(s, pass_on) for s in FORWARDED}
    try:
        line = reader.readline().split()
    finally:
        for s, handler in before.items():
            signal.signal(s, handler)
    if len(line) == 2 and line[0] == "exit":
        return int(line[1])
    if len(line) == 2 and line[0] == "killed":  # by a signal: end the same way
        signum = int(line[1])
        sys.stdout.flush()
        signal.signal(signum, signal.SIG_DFL)
        os.kill(os.getpid(), signum)
        return 128 + signum
    print("error: the real2code server stopped while it ran this command (its log: "
          f"{serving.Installation().log_path()})", file=sys.stderr)
    return EXIT_INTERNAL
