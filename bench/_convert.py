"""What the data-set converters share: where the data live, writing a run as the calibration
CSV (docs/calibration.md: ``time,<joint>,<joint>.effort,...``) beside its experiment file
(``<stem>.experiment.toml``), the nominal model as ``object.json``, and a clear exit on a
file that is not what its data set says it is.

Converters are scripts, never modules of the package: a data set's own file layout is the
data set's business; what reaches ``real2code calibrate`` is the general contract.
"""

from __future__ import annotations

import json
import sys
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from _data import SHARED_DATA  # noqa: E402

from real2code_export import atomic  # noqa: E402
from real2code_export.formats import object_json  # noqa: E402
from real2code_export.model import ArticulatedObject  # noqa: E402

MEASURED = SHARED_DATA / "measured"


class DataError(Exception):
    """A data-set file that is not what its data set says it is (exit status 2)."""

    def __init__(self, path: Path, element: str | None, message: str, line: int | None = None):
        where = f"{path}:{line}" if line is not None else str(path)
        super().__init__(f"{where}: {element}: {message}" if element else f"{where}: {message}")


def main_guard(main) -> int:
    """Run a converter's ``main``: a DataError is printed and exits with status 2."""
    try:
        return main()
    except DataError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2


def csv_text(time: np.ndarray, columns: dict[str, np.ndarray], comments: list[str]) -> str:
    names = ["time", *columns]
    data = np.column_stack([time, *columns.values()])
    lines = [f"# {c}" for c in comments] + [",".join(names)]
    lines += [",".join(repr(float(v)) for v in row) for row in data]
    return "\n".join(lines) + "\n"


def _toml_value(v) -> str:
    if isinstance(v, str):
        return json.dumps(v)  # a TOML basic string is a JSON string for these names
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return repr(v)


def toml_text(tables: dict[str, dict], comments: list[str]) -> str:
    """The experiment file: flat tables of scalars and lists (all the contract has). The
    text is read back with tomllib before it is written, so it is valid TOML."""
    lines = [f"# {c}" for c in comments]
    for name, table in tables.items():
        lines += ["", f"[{name}]"]
        lines += [f"{key} = {_toml_value(value)}" for key, value in table.items()]
    text = "\n".join(lines) + "\n"
    tomllib.loads(text)
    return text


def write_run(out: Path, stem: str, time: np.ndarray, columns: dict[str, np.ndarray],
              comments: list[str], experiment: dict[str, dict] | None = None) -> Path:
    """``out/<stem>.csv`` and, when there is one, ``out/<stem>.experiment.toml``."""
    csv = out / f"{stem}.csv"
    atomic.write_text(csv, csv_text(time, columns, comments))
    if experiment:
        atomic.write_text(out / f"{stem}.experiment.toml", toml_text(experiment, comments))
    return csv


def write_model(out: Path, obj: ArticulatedObject) -> Path:
    path = out / "object.json"
    atomic.write_text(path, object_json.dumps(obj))
    return path


def source_folder(arg: str | None, name: str) -> Path:
    folder = Path(arg) if arg else MEASURED / name
    if not folder.is_dir():
        raise DataError(folder, None, "no such folder (give the data set's folder, or set "
                        "REAL2CODE_SHARED_DATA)")
    return folder
