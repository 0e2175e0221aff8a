"""Where we stand on the public robot corpora, file by file: load, export to all four
formats, check every export against the SOURCE file in its own tools (100 configurations,
1e-6; its dynamics too, ``check --reference``), and list the repairs made. The table in docs/corpora.md comes from it.

    .venv/bin/python bench/corpus_survey.py urdf|mjcf|pybullet|PATH... [--load-only]
        [--markdown FILE] [--xacro-arg NAME:=VALUE]... [--package-path DIR]...

``urdf`` is example-robot-data (PyPI), ``mjcf`` the Menagerie snapshot in ../shared/data,
``pybullet`` the URDF and MJCF files the pybullet wheel ships (as the corpus tests take them,
``tests/conftest.py``); any other argument is a robot file or a folder searched for them
(``*.urdf``, ``*.xacro``, and ``*.xml`` whose root is ``<mujoco>`` or ``<robot>``).
``--xacro-arg`` and ``--package-path`` are ``real2code export``'s (every xacro file is
expanded with the arguments given). A file refused is marked "refused, as its tools" where
the source's own tools refuse it too (MuJoCo; for URDF, MuJoCo and Pinocchio); an exception
that is none of the tool's errors is a "crash" (a bug: the survey goes on).
"""

from __future__ import annotations

import json
import os
import sys
import sysconfig
import tempfile
import time
import warnings
from pathlib import Path

from _data import SHARED_DATA

from real2code_export.check import check_files
from real2code_export.errors import Real2CodeError
from real2code_export.formats import export, is_format, load

REPO = Path(__file__).resolve().parents[1]


def erd_files() -> list[Path]:
    root = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix/share/example-robot-data/robots"
    return sorted(root.rglob("*.urdf"))


def menagerie_files() -> list[Path]:
    root = SHARED_DATA / "mujoco_menagerie"
    return [root / e["model"] for e in json.loads((root / "index.json").read_text())]


def pybullet_files() -> list[Path]:
    sys.path.insert(0, str(REPO / "tests"))
    from conftest import pybullet_data_dir, pybullet_sources  # the corpus tests' own list

    return pybullet_sources(pybullet_data_dir())


def files_under(paths: list[str]) -> list[Path]:
    """Robot description files named, or found under the folders named."""
    out: list[Path] = []
    for p in map(Path, paths):
        found = [p] if p.is_file() else sorted(
            f for f in p.rglob("*") if any(is_format(f, n) for n in ("urdf", "mjcf")))
        out += [f for f in found if is_format(f, "urdf") or _is_mjcf(f)]
    return out


def _is_mjcf(path: Path) -> bool:
    import xml.etree.ElementTree as ET

    try:
        return ET.parse(path).getroot().tag == "mujoco"
    except ET.ParseError:
        return False


def survey(path: Path, load_only: bool) -> tuple[str, str, int]:
    """(status, detail, number of warnings)."""
    with warnings.catch_warnings(record=True) as caught, tempfile.TemporaryDirectory() as tmp:
        warnings.simplefilter("always")
        try:
            obj = load(path)
            if load_only:
                return "loads", f"{len(obj.parts)} parts", len(caught)
            written = export(obj, Path(tmp) / "out")
        except Real2CodeError as e:
            status = "refused" if _its_tools_load(path) else "refused, as its tools"
            return status, str(e).replace(str(path), path.name), len(caught)
        except Exception as e:  # a crash is a finding too: the survey goes on to the next
            return "crash", f"{type(e).__name__}: {e}".splitlines()[0], len(caught)
        try:
            # kinematics and dynamics against the source; the reader's warnings say which
            # differences are its repairs
            report = check_files(list(written.values()), source=path, validate=False,
                                 warned=[str(w.message) for w in caught])
        except Real2CodeError as e:
            return "check error", str(e).replace(str(path), path.name), len(caught)
        except Exception as e:  # a crash is a finding too: the survey goes on to the next
            return "crash", f"{type(e).__name__}: {e}".splitlines()[0], len(caught)
    if not report.ok:
        worst = "; ".join(m.message for m in report.mismatches[:2])
        return "disagrees", worst.replace("|", "/"), len(caught)
    return "agrees", f"{len(obj.parts)} parts, {len(obj.movable_joints)} joints", len(caught)


def _its_tools_load(path: Path) -> bool:
    """Whether the source's own tools load it (MuJoCo for MJCF; MuJoCo or Pinocchio for
    URDF): a file they refuse too is not ours to convert."""
    from real2code_export.probes.source import open_source_probes

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            open_source_probes(path)
        except Real2CodeError:
            return False
    return True


def _take_options(args: list[str], option: str) -> list[str]:
    """The values of every ``option VALUE`` in ``args``, taken out of it."""
    values = []
    while option in args:
        at = args.index(option)
        values.append(args[at + 1])
        del args[at:at + 2]
    return values


def main() -> None:
    from real2code_export.formats.urdf.packages import XACRO_ARGS_VARIABLE

    args = sys.argv[1:]
    if "--markdown" in args:
        del args[args.index("--markdown"):args.index("--markdown") + 2]
    # as real2code export takes them (cli/models.py: the readers and the check's tools
    # read these variables)
    xacro_args = _take_options(args, "--xacro-arg")
    if xacro_args:
        os.environ[XACRO_ARGS_VARIABLE] = "\n".join(xacro_args)
    folders = [str(Path(p).resolve()) for p in _take_options(args, "--package-path")]
    if folders:
        rest = [p for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
        os.environ["ROS_PACKAGE_PATH"] = os.pathsep.join(folders + rest)
    args = [a for a in args if a != "--load-only"]
    load_only = "--load-only" in sys.argv
    named = {"urdf": erd_files, "mjcf": menagerie_files, "pybullet": pybullet_files}
    files = named[args[0]]() if len(args) == 1 and args[0] in named else files_under(args)
    rows, counts = [], {}
    root = Path(os.path.commonpath([f.parent for f in files])) if files else Path()
    for f in files:
        start = time.perf_counter()
        status, detail, n_warn = survey(f, load_only)
        counts[status] = counts.get(status, 0) + 1
        seconds = time.perf_counter() - start
        row = f"| {f.relative_to(root)} | {status} | {n_warn} | {seconds:.1f} | {detail} |"
        print(row, flush=True)
        rows.append(row)
    print(", ".join(f"{n} {s}" for s, n in counts.items()) + f" (of {len(files)})")
    if "--markdown" in sys.argv:
        out = Path(sys.argv[sys.argv.index("--markdown") + 1])
        head = ["| file | status | warnings | seconds | parts, joints / reason |",
                "|---|---|---|---|---|"]
        out.write_text("\n".join(head + rows) + "\n\n" +
                       ", ".join(f"{n} {s}" for s, n in counts.items()) +
                       f" (of {len(files)})\n")


if __name__ == "__main__":
    main()
