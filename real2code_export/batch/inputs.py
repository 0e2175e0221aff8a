"""The command line's INPUTS (files, folders, glob patterns) expanded into the objects of a
batch: one task per object, each with a stable id that names its output folder.

What makes a folder an object depends on the task:

- ``export``: a model file (``object.json``, ``.urdf``, MJCF ``.xml``, ``.usd*``, ``.glb``,
  ``.gltf``); a folder holding ``object.json`` is that one object, otherwise every model file
  in it is one (a PartNet-Mobility folder: its ``mobility.urdf``).
- ``check``: a folder holding model files is one object, all of them compared with each
  other (an export's output folder); a file given alone is checked alone.
- ``calibrate``: a folder holding trajectory CSVs (``*holdout*`` ones held out) and one
  model file.
- ``reconstruct``: a capture folder (with ``transforms.json``).

A folder that is not an object is searched, subfolder by subfolder (hidden ones and the
batch's own output folder skipped), so a whole dataset tree is one INPUT. Ids are the
objects' paths relative to the folder all of them share (``cabinet_7`` for
``dataset/cabinet_7/``), the same on every rerun of the same command.
"""

from __future__ import annotations

import glob
import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

from ..errors import Real2CodeError
from ..formats import suffixes

MODEL_JSON = "object.json"  # the one .json file that is a model (others are reports)
CAPTURE_FILE = "transforms.json"
KINDS = ("export", "check", "calibrate", "reconstruct")


class BatchInputError(Real2CodeError):
    """The INPUTS of a batch name nothing usable (a missing path, a pattern matching nothing)."""


@dataclass(frozen=True)
class BatchObject:
    """One object of a batch: what its task reads."""

    id: str  # its output folder is DIR/<id>; unique in the batch
    folder: Path  # the object's folder (relative paths in its fingerprint start here)
    files: tuple[Path, ...]  # the model (export, calibrate), the files to compare (check),
    # the capture's transforms.json (reconstruct)
    data: tuple[Path, ...] = ()  # calibrate: trajectories to fit
    holdout: tuple[Path, ...] = ()  # calibrate: trajectories held out
    whole_folder: bool = False  # its input is the whole folder (captures), not named files
    problem: str | None = None  # why it cannot run (recorded as failed, the batch goes on)

    @property
    def source(self) -> Path:
        """What the manifest names as the input: the model file, or the folder."""
        single = len(self.files) == 1 and not (self.whole_folder or self.data)
        return self.files[0] if single else self.folder


@dataclass(frozen=True)
class _Found:
    anchor: Path  # the path the id is made from: the folder, or folder/stem
    folder: Path
    files: tuple[Path, ...]
    data: tuple[Path, ...] = ()
    holdout: tuple[Path, ...] = ()
    whole_folder: bool = False
    problem: str | None = None


def expand_inputs(inputs: Sequence[str | Path], kind: str,
                  exclude: Sequence[Path] = ()) -> list[BatchObject]:
    """The objects the INPUTS name for task ``kind``, in a stable order (sorted by id)."""
    if kind not in KINDS:
        raise BatchInputError(f"unknown batch task {kind!r}; choose from {', '.join(KINDS)}")
    excluded = {Path(p).resolve() for p in exclude}
    found: dict[tuple, _Found] = {}
    for text in inputs:
        for path in _matches(str(text)):
            for f in _objects_at(path.resolve(), kind, excluded):
                found.setdefault((f.anchor, f.files), f)  # the same object named twice
    if not found:
        raise BatchInputError(f"no {kind} inputs found in {', '.join(map(str, inputs))}")
    items = list(found.values())
    root = Path(os.path.commonpath([str(f.anchor.parent) for f in items]))
    objects = [BatchObject(f.anchor.relative_to(root).as_posix(), f.folder, f.files, f.data,
                           f.holdout, f.whole_folder, f.problem) for f in items]
    seen: dict[str, BatchObject] = {}
    for o in objects:
        if o.id in seen:
            raise BatchInputError(f"two inputs would share the output folder {o.id!r}: "
                                  f"{seen[o.id].source} and {o.source}")
        seen[o.id] = o
    return sorted(objects, key=lambda o: o.id)


def _matches(text: str) -> list[Path]:
    if glob.has_magic(text):
        hits = sorted(glob.glob(text, recursive=True))
        if not hits:
            raise BatchInputError(f"{text}: the pattern matches nothing")
        return [Path(h) for h in hits]
    path = Path(text)
    if not path.exists():
        raise BatchInputError(f"{text}: no such file or folder")
    return [path]


def _objects_at(path: Path, kind: str, excluded: set[Path]) -> Iterator[_Found]:
    if path in excluded:
        return
    if path.is_file():
        yield from _file_object(path, kind)
        return
    here = list(_folder_objects(path, kind))
    if here:
        yield from here
        return
    for sub in sorted(p for p in path.iterdir() if p.is_dir() and not p.name.startswith(".")):
        yield from _objects_at(sub, kind, excluded)


def _model_files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.is_file() and is_model_file(p))


def is_model_file(path: Path) -> bool:
    return path.name == MODEL_JSON or path.suffix.lower() in suffixes(exported_only=True)


def _file_object(path: Path, kind: str) -> Iterator[_Found]:
    if kind in ("calibrate", "reconstruct"):  # a file inside the object's folder names it
        yield from _folder_objects(path.parent, kind)
        return
    if not is_model_file(path):
        raise BatchInputError(f"{path}: not a model file (object.json, "
                              f"{', '.join(suffixes(exported_only=True))})")
    alone = _model_files(path.parent) == [path]
    yield _Found(path.parent if alone else path.with_suffix(""), path.parent, (path,))


def _folder_objects(folder: Path, kind: str) -> Iterator[_Found]:
    models = _model_files(folder)
    if kind == "export":
        if (folder / MODEL_JSON) in models:
            models = [folder / MODEL_JSON]  # the other files there are its exports
        for m in models:
            yield _Found(folder if len(models) == 1 else m.with_suffix(""), folder, (m,))
    elif kind == "check":
        if models:
            yield _Found(folder, folder, tuple(models))
    elif kind == "calibrate":
        csvs = sorted(p for p in folder.glob("*.csv") if p.is_file())
        if csvs:
            yield _calibrate_object(folder, models, csvs)
    elif (folder / CAPTURE_FILE).is_file():  # reconstruct
        yield _Found(folder, folder, (folder / CAPTURE_FILE,), whole_folder=True)


def _calibrate_object(folder: Path, models: list[Path], csvs: list[Path]) -> _Found:
    holdout = tuple(p for p in csvs if "holdout" in p.name.lower())
    data = tuple(p for p in csvs if p not in holdout)
    if (folder / MODEL_JSON) in models:
        models = [folder / MODEL_JSON]
    problem = None
    if len(models) != 1:
        problem = (f"{folder}: a calibrate folder holds one model file (object.json, .urdf, "
                   f".xml) beside its CSVs; found {len(models)}"
                   + (f": {', '.join(m.name for m in models)}" if models else ""))
    elif not data:
        problem = f"{folder}: every CSV is a holdout; nothing to fit"
    return _Found(folder, folder, tuple(models[:1]), data, holdout, problem=problem)
