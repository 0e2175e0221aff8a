"""The ``real2code`` command line (contracts in docs/design.md).

One module per command group (``models``: export, check, generate; ``articulate``;
``reconstruct``: demo, render, reconstruct and their evaluations; ``calibrate``;
``simulate``; ``view``; ``batch``; ``server``, with ``handoff`` its caller's side).
Building the parser imports none of the stages: each command imports its stage when it runs,
so ``real2code --help`` is quick. Every command runs inside :mod:`.boundary`.

Exit status: 0 success, 1 a check found a disagreement, 2 bad input (the message names the
file, the element and what is wrong; nothing half-written is left), 3 an internal error (a
short message and the file the traceback was written to).
"""

from __future__ import annotations

import sys

from .boundary import call
from .options import EXIT_DISAGREE, EXIT_ERROR, EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_OK

__all__ = ["EXIT_DISAGREE", "EXIT_ERROR", "EXIT_INTERNAL", "EXIT_INTERRUPTED", "EXIT_OK",
           "build_parser", "main", "run"]


def build_parser():
    """The whole parser (its modules imported here: a command handed to the server,
    handoff.py, needs none of them)."""
    import argparse
    import functools

    from .. import __version__
    from . import articulate, batch, calibrate, models, reconstruct, server, simulate, view

    p = argparse.ArgumentParser(
        prog="real2code",
        description="Articulated objects in, simulation-ready digital twins out "
        "(MJCF, URDF, USD, glTF), proven by loading them back in their own tools.",
    )
    p.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    reconstruct.add_demo_parser(sub)
    models.add_parsers(sub)  # export, check, generate
    articulate.add_parsers(sub)
    reconstruct.add_parsers(sub)  # render, reconstruct
    calibrate.add_parsers(sub)
    simulate.add_parsers(sub)
    view.add_parsers(sub)
    s = sub.add_parser("evaluate", help="accuracy tables (the paper's metrics)")
    evaluate_sub = s.add_subparsers(dest="what", required=True, metavar="WHAT")
    articulate.add_evaluate_parsers(evaluate_sub)  # joints
    reconstruct.add_evaluate_parsers(evaluate_sub)  # completion, reconstruction
    batch.add_parsers(sub)
    # The server's commands are parsed by this same parser: built once in the server, not
    # in each fork (3 to 5 ms of a served command's CPU; what a fork's parse changes stays in
    # the fork). Nothing in it depends on a command's folder or environment.
    server.add_parsers(sub, functools.partial(run, parser=p))
    return p


def run(argv: list[str] | None = None, parser=None) -> int:
    """Parse ``argv`` (with ``parser``, by default a new one: :func:`build_parser`) and run
    its command inside the error boundary; the exit status."""
    args = (parser or build_parser()).parse_args(argv)
    return call(args.func, args)


def main(argv: list[str] | None = None) -> int:
    """The console script: run (in this installation's server where one runs: see
    :mod:`.server`), then end the process (see :func:`_end_process`)."""
    process_defaults()
    if argv is None:
        from .handoff import hand_off

        status = hand_off(sys.argv[1:])
        if status is not None:
            _end_process(status)
    _end_process(run(argv))


def process_defaults() -> None:
    """The environment a command's libraries start with, where the user has not set it
    (before any of them is imported: building the parser imports none).

    - ``MUJOCO_GL=disable``: no command draws with MuJoCo (the renders cast rays with open3d,
      the viewer is a web page), and with it unset ``import mujoco`` loads GLFW, whose loader
      starts a Python subprocess: 0.045 s of CPU on every command that reads an MJCF or
      checks a file.
    - ``OPENBLAS_NUM_THREADS=1``: numpy's products here are tall and thin (a mesh's vertices
      times a 3x3 rotation), where OpenBLAS's threads cost more than they give; on a busy
      machine they spin: a (100000, 3) @ (3, 3) product took 166 ms with two threads, 12 ms
      with one (load average 12), and an export of a robot with large STL meshes 30 % less
      CPU; the files written are byte-identical.
    - The cyclic garbage collector runs after 50,000 new objects rather than 700 (and its
      older generations after 50 of the younger's runs, not 10): a command's first second is
      importing numpy, USD, MuJoCo, ..., whose hundreds of thousands of long-lived objects
      each collection walked again. An export of a PartNet object to USD: 1,394 M -> 1,374 M
      instructions (callgrind; the collector off entirely: 1,371 M). Memory is freed by
      reference counting as before; only cycles wait longer.
    """
    import gc
    import os

    os.environ.setdefault("MUJOCO_GL", "disable")
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    gc.set_threshold(50_000, 50, 50)


def _end_process(status: int) -> None:
    """Exit with ``status`` without the interpreter's teardown when nothing else is running:
    the exit handlers run and the standard streams are flushed as on a normal exit (every
    output file is closed before it is moved into place, atomic.py), but freeing the modules
    (USD's, MuJoCo's, numpy's) is skipped: 0.02 to 0.04 s of CPU, 5 to 10 % of an export.
    With another thread alive, or a profiler or tracer watching (``python -m cProfile -m
    real2code_export.cli`` writes its profile after the program), the ordinary exit."""
    import threading

    if threading.active_count() > 1 or sys.getprofile() or sys.gettrace():
        sys.exit(status)
    import atexit
    import contextlib
    import os

    atexit._run_exitfuncs()  # logging's flush, multiprocessing's and Ray's shutdown, ...
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError):  # a closed pipe: nothing more to say
            stream.flush()
    os._exit(status)


if __name__ == "__main__":
    main()
