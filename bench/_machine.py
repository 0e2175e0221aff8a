"""The machine a benchmark ran on, printed with its figures."""

from __future__ import annotations

import os
import platform


def describe() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem = ""
    try:
        with open("/proc/meminfo") as f:
            kb = int(f.readline().split()[1])
            mem = f", {kb / 1024 / 1024:.0f} GiB"
    except (OSError, ValueError, IndexError):
        pass
    return f"{cpu}, {os.cpu_count()} cores{mem}, Python {platform.python_version()}"


def timeit(fn, repeat: int) -> list[float]:
    import time

    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return times


def load_average() -> str:
    """The 1, 5 and 15 minute load averages (how busy the shared machine was)."""
    try:
        return " ".join(f"{x:.1f}" for x in os.getloadavg())
    except OSError:
        return "unknown"


def byte_compile(*folders) -> None:
    """Compile the packages' modules to ``__pycache__`` once, as ``pip install`` does: when
    PYTHONDONTWRITEBYTECODE is set (it is on the shared development machines) a checkout's
    modules are otherwise compiled from source by every command (0.05 to 0.15 s a command),
    which no installed copy does, while the tools we are compared with are installed ones."""
    import compileall

    for folder in folders:
        compileall.compile_dir(str(folder), quiet=1)


def converters_bin():
    """The bin folder of the converters' venv (bench/setup_converters.sh): ``.venv-converters``
    in the repository, or the venv ``REAL2CODE_CONVERTERS`` names (a worktree whose
    ``.venv-converters`` is a link to another checkout's, not made yet)."""
    from pathlib import Path

    venv = os.environ.get("REAL2CODE_CONVERTERS")
    return Path(venv or Path(__file__).resolve().parents[1] / ".venv-converters") / "bin"
