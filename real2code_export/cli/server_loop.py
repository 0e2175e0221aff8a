"""The command server's process (``real2code server run``, which ``start`` detaches): it
imports the file commands' libraries once (numpy, MuJoCo, USD, Pinocchio, ...: 0.4 s of
every ``export`` and ``check`` on this machine, docs/benchmarks.md) and runs each later
command in a fork of itself, as Android's zygote starts apps and ``dmypy`` serves mypy.
:mod:`.handoff` is the other side, :mod:`.server` the commands that start and stop it.

What a fork of a server gives a command is what starting afresh gives it: its arguments,
folder, environment, umask, ``sys.path`` and standard streams (the caller's own file
descriptors) are the caller's, signals reach it through the caller, its exit status is the
caller's, the random generators are reseeded. What it does not: modules already imported stay
as the server imported them, so the server runs only commands of its own code (a change to
the package's sources stops it: the next command runs on its own) and of its own
interpreter, flags and import-time environment (:data:`serving.IMPORT_TIME_PREFIXES`; other
commands run on their own, the server stays). The server itself stays on one thread: a fork
inherits no thread but every lock one held (USD's registries are loaded with USD held to one
thread, its limit given back in each fork).
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import struct
import sys
import time

from . import serving
from .options import EXIT_INTERNAL

# Imported inside the readers', writers' and probes' functions, so importing their modules
# does not import them (a missing one is imported by the command, slower, never wrong).
TOOLS = ("numpy", "mujoco", "pinocchio", "trimesh", "pygltflib", "lxml.etree", "collada",
         "PIL.Image", "scipy.spatial.transform", "tinyobjloader", "pxr.UsdValidation",
         "real2code_export.collada_mesh", "real2code_export.formats.gltf.validator")


class Server:
    """The listening loop: one thread, one selector over the socket, each running command's
    process (a pidfd) and its caller's connection."""

    def __init__(self, installation: serving.Installation, idle_minutes: float, runner):
        self.installation, self.runner = installation, runner
        self.idle_s = idle_minutes * 60.0
        self.started = time.time()
        self.served = 0
        self.children: dict[int, _Command] = {}  # by pid
        self.stopping = False

    def serve(self) -> None:
        import selectors
        import signal

        self.warm_s, self.modules, self.usd_limit = warm()
        self.identity = serving.identity(self.installation)
        self.selector = selectors.DefaultSelector()
        self.listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.listener.bind(str(self.installation.socket_path()))
        self.listener.listen(64)
        self.selector.register(self.listener, selectors.EVENT_READ, ("accept", None))
        # Signals wake the loop through a socket, never interrupt it halfway.
        self.wake_r, self.wake_w = socket.socketpair()
        self.wake_w.setblocking(False)
        signal.set_wakeup_fd(self.wake_w.fileno())
        for s in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
            signal.signal(s, lambda *_: None)
        self.selector.register(self.wake_r, selectors.EVENT_READ, ("signal", None))
        _log(f"serving on {self.installation.socket_path()} (pid {os.getpid()}; "
             f"{self.modules} modules imported in {self.warm_s:.2f} s)")
        idle_since = time.monotonic()
        try:
            while not (self.stopping and not self.children):
                timeout = None
                if self.idle_s and not self.children and not self.stopping:
                    timeout = idle_since + self.idle_s - time.monotonic()
                    if timeout <= 0:
                        _log(f"idle for {self.idle_s / 60:g} min: stopping")
                        break
                for key, _ in self.selector.select(timeout):
                    kind, command = key.data
                    if kind in ("accept", "exited"):  # idle from the last request or end
                        idle_since = time.monotonic()
                    if kind == "accept":
                        self._accept()
                    elif kind == "signal":
                        self.wake_r.recv(64)
                        _log("signalled: stopping once running commands end")
                        self._stop_listening()
                    elif kind == "exited":
                        self._reap(command)
                    elif kind == "caller":
                        self._from_caller(command)
        finally:
            self._stop_listening()
        _log(f"stopped after {self.served} commands")

    def _stop_listening(self) -> None:
        self.stopping = True
        if self.listener.fileno() >= 0:
            self.selector.unregister(self.listener)
            self.listener.close()
            with contextlib.suppress(FileNotFoundError):
                self.installation.socket_path().unlink()

    def _accept(self) -> None:
        conn, _ = self.listener.accept()
        fds: list[int] = []
        try:
            conn.settimeout(10.0)  # a caller sends its request at once
            pid, uid, gid = struct.unpack("3i", conn.getsockopt(
                socket.SOL_SOCKET, socket.SO_PEERCRED, struct.calcsize("3i")))
            if uid != os.getuid():
                raise OSError(f"a caller of another user (uid {uid})")
            request, fds = _receive(conn)
            op = request.get("op")
            if op == "run":
                self._run(conn, request, fds)  # (empties fds once the fork has them)
                return
            status = self._status(request)
            if op == "stop":
                _log("asked to stop")
                self._stop_listening()
            conn.sendall(f"{op} {json.dumps(status)}\n".encode())
            conn.close()
        except (OSError, ValueError, KeyError) as e:
            _log(f"a request dropped: {e}")
            conn.close()
        finally:
            for fd in fds:
                os.close(fd)

    def _status(self, request: dict) -> dict:
        theirs = request.get("identity", {})
        return {"pid": os.getpid(), "up_s": time.time() - self.started,
                "served": self.served, "running": len(self.children),
                "warm_s": self.warm_s, "modules": self.modules,
                "idle_timeout_min": self.idle_s / 60.0,
                "code_differs": serving.mismatch(self.identity, theirs, "code"),
                "runtime_differs": serving.mismatch(self.identity, theirs, "runtime")}

    def _run(self, conn: socket.socket, request: dict, fds: list[int]) -> None:
        import selectors

        stale = serving.mismatch(self.identity, request["identity"], "code")
        other = serving.mismatch(self.identity, request["identity"], "runtime")
        refusal = ("stale" if stale else "other" if other else
                   "stopping" if self.stopping else "streams" if len(fds) != 3 else None)
        if refusal:
            _log(f"refused {' '.join(request['argv'][:1])}: {stale or other or refusal}")
            conn.sendall(f"refused {refusal}\n".encode())
            conn.close()
            if stale:  # every later command would be refused too
                _log("its code changed on disk: stopping")
                self._stop_listening()
            return
        inherited = [self.selector, self.listener, self.wake_r, self.wake_w, conn,
                     *(c.conn for c in self.children.values()),
                     *(c.pidfd for c in self.children.values())]
        pid = os.fork()
        if pid == 0:
            run_command(self.runner, request, fds, inherited, self.usd_limit)  # never returns
        for fd in fds:
            os.close(fd)
        fds.clear()
        command = _Command(pid, os.pidfd_open(pid), conn, request["argv"], time.monotonic())
        self.children[pid] = command
        self.served += 1
        conn.settimeout(None)
        self.selector.register(command.pidfd, selectors.EVENT_READ, ("exited", command))
        self.selector.register(conn, selectors.EVENT_READ, ("caller", command))
        with contextlib.suppress(OSError):  # a caller gone already: its end is seen next
            conn.sendall(f"run {pid}\n".encode())

    def _from_caller(self, command: _Command) -> None:
        import signal

        try:
            data = command.conn.recv(256)
        except OSError:
            data = b""
        if not data:  # the caller is gone (killed): so is its command's terminal or pipe
            self.selector.unregister(command.conn)
            command.caller_gone = True
            with contextlib.suppress(ProcessLookupError):
                os.kill(command.pid, signal.SIGHUP)
            return
        for line in data.decode(errors="replace").splitlines():
            word, _, number = line.partition(" ")
            if word == "signal" and number.isdigit():
                with contextlib.suppress(ProcessLookupError):
                    os.kill(command.pid, int(number))

    def _reap(self, command: _Command) -> None:
        _, status, usage = os.wait4(command.pid, 0)
        self.selector.unregister(command.pidfd)
        os.close(command.pidfd)
        if not command.caller_gone:
            self.selector.unregister(command.conn)
        code = os.waitstatus_to_exitcode(status)
        reply = f"exit {code}\n" if code >= 0 else f"killed {-code}\n"
        with contextlib.suppress(OSError):
            command.conn.sendall(reply.encode())
        command.conn.close()
        del self.children[command.pid]
        _log(f"{' '.join(command.argv[:2])} (pid {command.pid}): {reply.strip()} in "
             f"{time.monotonic() - command.started:.2f} s, "
             f"{usage.ru_utime + usage.ru_stime:.2f} s CPU, {usage.ru_minflt} page faults")


class _Command:
    def __init__(self, pid: int, pidfd: int, conn: socket.socket, argv: list[str],
                 started: float):
        self.pid, self.pidfd, self.conn, self.argv = pid, pidfd, conn, argv
        self.started = started
        self.caller_gone = False


def _receive(conn: socket.socket) -> tuple[dict, list[int]]:
    """A request and the file descriptors sent with it (with its first bytes)."""
    data, fds, _, _ = socket.recv_fds(conn, 1 << 16, 3)
    fds = list(fds)
    try:
        while len(data) < serving.HEADER_SIZE:
            data += _more(conn)
        size = serving.unpack_length(data[:serving.HEADER_SIZE])
        while len(data) < serving.HEADER_SIZE + size:
            data += _more(conn)
        return json.loads(data[serving.HEADER_SIZE:]), fds
    except BaseException:
        for fd in fds:
            os.close(fd)
        raise


def _more(conn: socket.socket) -> bytes:
    chunk = conn.recv(1 << 16)
    if not chunk:
        raise ValueError("the request ended early")
    return chunk


def warm() -> tuple[float, int, int | None]:
    """Import what the file commands import (every format's reader and writer and its probes,
    as the format registry names them, and :data:`TOOLS`; every command's module is imported
    already: ``server run`` was parsed), load USD's registries
    (:func:`_usd_registries`), set the allocator for the forks
    (:func:`_allocator_for_commands`), then set it all aside from the garbage collector
    (``gc.freeze``: the forks neither walk nor copy it). Seconds taken, modules imported and
    USD's concurrency limit for the forks; what fails to import is left to the command,
    which says why. A process with a second thread here must not fork: an error.

    Not more: a rehearsal (a small robot exported to every format and checked here) measured
    no gain beyond the registries' on the exports that followed (iiwa14, dynamixel_2r,
    centauro, talos_reduced: within the runs' spread); the registries alone saved 0.01-0.03 s
    of CPU an export (ur5_robot, iiwa14, dynamixel_2r, six runs each)."""
    import gc
    import importlib

    start = time.perf_counter()
    from .. import check  # noqa: F401 - imported for the forks
    from ..formats import FORMATS, unavailable_reason

    for name, fmt in FORMATS.items():
        unavailable_reason(name)
        for module in (*fmt.probes, fmt.validator.partition(":")[0] if fmt.validator else None):
            if module:
                with contextlib.suppress(Exception):
                    importlib.import_module(module)
    for module in TOOLS:
        with contextlib.suppress(Exception):
            importlib.import_module(module)
    usd_limit = _usd_registries()
    _allocator_for_commands()
    from .. import forked

    if forked._threads() != 1:
        raise RuntimeError(f"{forked._threads()} threads after the imports: a fork would "
                           "inherit their locks")
    gc.collect()
    gc.freeze()
    return time.perf_counter() - start, len(sys.modules), usd_limit


# glibc's mallopt options (malloc.h)
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD, _M_ARENA_MAX = -1, -3, -8


def _allocator_for_commands() -> None:
    """glibc's allocator set for the short processes the forks are (they inherit it): what a
    command frees is kept for its later allocations, not given back to the system (no
    trimming of the heap, no mapping of its own for each large array), and its threads (the
    STL reads, the creased normals, MuJoCo's compile) share one arena. A fork faults in every
    page it touches first; so set, a robot corpus's exports to USD touched a fifth fewer
    (docs/benchmarks.md, session 32). Nothing where the C library has no mallopt."""
    import ctypes

    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return
    for option, value in ((_M_TRIM_THRESHOLD, 1 << 30), (_M_MMAP_THRESHOLD, 1 << 30),
                          (_M_ARENA_MAX, 1)):
        mallopt(option, value)


def _usd_registries() -> int | None:
    """USD's plugin and schema registries, its layer file formats and the Newton schema
    (:func:`~..formats.usd.conventions.open_stage`) loaded, what a command's first layer or
    stage pays (0.02-0.03 s), USD held to one thread meanwhile (a fork must
    inherit none). USD's concurrency limit before, for each fork to restore
    (:func:`run_command`); None where USD does not import here or the environment fixes its
    limit (``PXR_WORK_THREAD_LIMIT``), and then nothing is loaded."""
    try:
        from pxr import Sdf, Usd, Work
    except ImportError:
        return None
    from ..formats import FORMATS

    limit = Work.GetConcurrencyLimit()
    Work.SetConcurrencyLimit(1)
    if Work.GetConcurrencyLimit() != 1:
        return None
    for suffix in FORMATS["usd"].suffixes:
        Sdf.Layer.CreateAnonymous(f"warm{suffix}")
    Usd.SchemaRegistry()
    Usd.Stage.CreateInMemory()
    with contextlib.suppress(ImportError):  # our schema, as open_stage registers it
        import newton_usd_schemas  # noqa: F401
    return limit


def run_command(runner, request: dict, fds: list[int], inherited: list,
                usd_limit: int | None = None) -> None:
    """In the fork: become the caller's command, run it (``runner(argv)``), exit with its
    status."""
    import signal

    status = EXIT_INTERNAL
    try:
        for thing in inherited:  # the server's: the command must not hold them open
            thing.close()
        signal.set_wakeup_fd(-1)
        signal.signal(signal.SIGINT, signal.default_int_handler)
        for s in (signal.SIGTERM, signal.SIGHUP):
            signal.signal(s, signal.SIG_DFL)
        for target, fd in enumerate(fds):
            os.dup2(fd, target)
        for fd in fds:
            if fd > 2:
                os.close(fd)
        os.chdir(request["cwd"])
        os.umask(request["umask"])
        os.environ.clear()
        os.environ.update(request["environment"])
        if usd_limit is not None:  # USD's own, given back (warm held it to one thread)
            from pxr import Work

            Work.SetConcurrencyLimit(usd_limit)
        sys.path[:] = request["path"]
        sys.argv = [request["argv0"], *request["argv"]]
        _open_streams(request["streams"])
        _reseed()
        status = runner(request["argv"])
    except SystemExit as e:  # argparse's --help, --version and usage errors
        status = e.code if isinstance(e.code, int) else (0 if e.code is None else 2)
        if not isinstance(e.code, int) and e.code is not None:
            print(e.code, file=sys.stderr)
    except BaseException:  # noqa: BLE001 - the fork must end here, whatever happened
        import traceback

        traceback.print_exc()
    finally:
        _end(status)


def _open_streams(streams: list) -> None:
    """``sys.stdin``, ``stdout`` and ``stderr`` on the caller's descriptors, as Python opens
    them: the caller's encoding and error handler, stdout line-buffered on a terminal and
    block-buffered otherwise, stderr line-buffered."""
    for fd, name, mode in ((0, "stdin", "r"), (1, "stdout", "w"), (2, "stderr", "w")):
        encoding, errors = streams[fd] or (None, None)
        stream = open(fd, mode, encoding=encoding, errors=errors, closefd=False,  # noqa: SIM115
                      buffering=1 if name == "stderr" else -1)
        setattr(sys, name, stream)
        setattr(sys, f"__{name}__", stream)


def _reseed() -> None:
    """A fresh process draws fresh seeds; a fork would repeat its server's."""
    import random

    random.seed()
    numpy = sys.modules.get("numpy")
    if numpy is not None:
        numpy.random.seed()


def _end(status: int) -> None:
    """End the fork as a command ends (threads it started joined, exit handlers run, streams
    flushed), never returning into the server's loop."""
    import atexit
    import threading

    try:
        for t in threading.enumerate():
            if t is not threading.main_thread() and not t.daemon:
                t.join()
        atexit._run_exitfuncs()
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                stream.flush()
    finally:
        os._exit(status if isinstance(status, int) else EXIT_INTERNAL)


def _log(text: str) -> None:
    print(f"{time.strftime('%Y-%m-%dT%H:%M:%S')} {text}", file=sys.stderr, flush=True)
