"""``real2code server start|stop|status|run``: this installation's command server
(:mod:`.server_loop`), started detached, asked what it is doing, stopped; :mod:`.handoff` hands
it each later command.
"""

from __future__ import annotations

import contextlib
import json
import socket
import sys
import time

from . import serving
from .options import EXIT_INTERNAL, EXIT_OK


def add_parsers(sub, runner) -> None:
    """The ``server`` commands; ``runner(argv) -> status`` runs a command (``cli.run``)."""
    s = sub.add_parser("server", help="keep the libraries imported: later commands run in a "
                       "fork of a server started once (start, stop, status)")
    actions = s.add_subparsers(dest="action", required=True, metavar="ACTION")
    a = actions.add_parser("start", help="start this installation's server, detached")
    _idle_option(a)
    a.set_defaults(func=cmd_start)
    actions.add_parser("stop", help="stop it (running commands finish first)").set_defaults(
        func=cmd_stop)
    actions.add_parser("status", help="whether it runs, what it has served, and whether "
                       "commands from here run in it").set_defaults(func=cmd_status)
    a = actions.add_parser("run", help="serve in the foreground (what start runs)")
    _idle_option(a)
    a.set_defaults(func=cmd_run, runner=runner)


def _idle_option(parser) -> None:
    parser.add_argument("--idle-timeout", type=_minutes, default=60.0, metavar="MINUTES",
                        help="stop after this long without a command (default 60; 0: never)")


def _minutes(text: str) -> float:
    import argparse
    import math

    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not (value >= 0.0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of minutes (0 or more)")
    return value


# -- the commands ---------------------------------------------------------------------------------

def cmd_start(args) -> int:
    import subprocess

    installation = _installation()
    status = ask(installation, "status")
    if status is not None and status["code_differs"] is None:
        print(f"the real2code server already runs (pid {status['pid']}, "
              f"{installation.socket_path()})")
        return EXIT_OK
    if status is not None:  # older code: it stops itself at the next command; now
        ask(installation, "stop")
        _wait_gone(installation, 30.0)
    log = installation.log_path()
    with open(log, "ab") as out:
        process = subprocess.Popen(
            [sys.executable, "-m", "real2code_export.cli", "server", "run",
             "--idle-timeout", str(args.idle_timeout)],
            stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT,
            # `-m` puts its folder first on the path: started in the caller's folder, a
            # checkout there would be the server's package, not this one (another
            # installation: it would listen on another socket)
            cwd=installation.package.parent,
            start_new_session=True)  # not the terminal's: Ctrl-C here does not stop it
    deadline = time.monotonic() + 60.0
    while time.monotonic() < deadline:
        status = ask(installation, "status")
        if status is not None:
            print(f"real2code server started: pid {status['pid']}, {status['modules']} "
                  f"modules imported in {status['warm_s']:.2f} s; "
                  f"{_idle_said(args.idle_timeout)}; log {log}")
            return EXIT_OK
        if process.poll() is not None:
            print(f"error: the real2code server exited at start (status {process.returncode}); "
                  f"its log: {log}", file=sys.stderr)
            return EXIT_INTERNAL
        time.sleep(0.05)
    process.terminate()
    print(f"error: the real2code server did not answer within 60 s; its log: {log}",
          file=sys.stderr)
    return EXIT_INTERNAL


def cmd_stop(args) -> int:
    installation = _installation()
    answer = ask(installation, "stop")
    if answer is None:
        print("no real2code server runs")
        return EXIT_OK
    if answer["running"]:
        print(f"waiting for {answer['running']} running command(s) ...")
    _wait_gone(installation, None)
    print(f"real2code server stopped (pid {answer['pid']}, {answer['served']} commands served)")
    return EXIT_OK


def cmd_status(args) -> int:
    installation = _installation()
    status = ask(installation, "status")
    if status is None:
        print(f"no real2code server runs (it would listen on {installation.socket_path()})")
        return EXIT_OK
    print(f"real2code server: pid {status['pid']}, up {status['up_s'] / 60:.1f} min, "
          f"{status['served']} commands served, {status['running']} running; "
          f"{status['modules']} modules imported in {status['warm_s']:.2f} s; "
          f"{_idle_said(status['idle_timeout_min'])}")
    print(f"socket {installation.socket_path()}, log {installation.log_path()}")
    reason = status["code_differs"] or status["runtime_differs"]
    print("commands from here run in it" if reason is None
          else f"commands from here run on their own: {reason}")
    return EXIT_OK


def cmd_run(args) -> int:
    from ..errors import InputError

    installation = _installation()
    path = installation.socket_path()
    if ask(installation, "status") is not None:
        raise InputError(f"{path}: a real2code server already listens there "
                         "(`real2code server stop` first)")
    with contextlib.suppress(FileNotFoundError):  # left by a server that was killed
        path.unlink()
    from .server_loop import Server

    Server(installation, args.idle_timeout, args.runner).serve()
    return EXIT_OK


def _installation() -> serving.Installation:
    from ..errors import InputError

    if not sys.platform.startswith("linux"):
        raise InputError("the real2code server runs on Linux only (each command is a fork)")
    installation = serving.Installation()
    problem = serving.private(installation.make_folder())
    if problem:
        raise InputError(f"the real2code server's folder is not private: {problem}")
    return installation


def _idle_said(minutes: float) -> str:
    return "no idle stop" if not minutes else f"stops after {minutes:g} min idle"


def _wait_gone(installation: serving.Installation, timeout: float | None) -> None:
    deadline = None if timeout is None else time.monotonic() + timeout
    while installation.socket_path().exists() and (deadline is None
                                                    or time.monotonic() < deadline):
        time.sleep(0.05)


def ask(installation: serving.Installation, op: str) -> dict | None:
    """The server's answer to ``op`` (``status`` or ``stop``), or None where none listens."""
    path = installation.socket_path()
    if not path.exists():
        return None
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
        try:
            sock.settimeout(10.0)
            sock.connect(str(path))
            sock.sendall(serving.pack({"op": op, "identity": serving.identity(installation)}))
            line = sock.makefile("r", encoding="utf-8").readline()
        except OSError:
            return None
    word, _, rest = line.partition(" ")
    return json.loads(rest) if word == op else None
