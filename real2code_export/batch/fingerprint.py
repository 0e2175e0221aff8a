"""What an object's task reads, and a content hash of it, so a rerun can tell an object whose
inputs did not change from one that must be redone.

An object's input is its whole folder for captures; otherwise its named files plus every file
they reference, followed through text formats: mesh and include paths in URDF / MJCF /
object.json / glTF JSON / USDA, ``mtllib`` in OBJ, texture maps in MTL. Over-inclusion only
costs a redo; a missed reference would let a changed mesh go unnoticed, so any token that
names an existing file counts.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
from collections.abc import Iterable
from pathlib import Path

from .inputs import BatchObject

# A text file's tokens may name files; binary ones (meshes, images, USD crate files) are
# leaves. Told by content, not by suffix: a USD layer may be text or crate under the same
# suffix, and any format a description refers to is covered without a list to keep.
_SNIFF = 8192
_TOKEN = re.compile(rb"[^\s\"'<>=@,;()\[\]{}]+")
_MJCF_DIRS = re.compile(rb"(?:meshdir|texturedir|assetdir)\s*=\s*[\"']([^\"']*)[\"']")
_NUMBER = re.compile(rb"[-+0-9.eE]+")  # numbers are never file names; skip the stat
_MTL_MAPS = (b"map_", b"bump", b"disp", b"decal", b"norm", b"refl")
_CHUNK = 1 << 20


def input_files(obj: BatchObject) -> list[Path]:
    """Every file the object's task reads (sorted, each once)."""
    if obj.whole_folder:
        return sorted(p for p in obj.folder.rglob("*")
                      if p.is_file() and not any(s.startswith(".") for s in
                                                 p.relative_to(obj.folder).parts))
    seen: set[Path] = set()
    todo = [p.resolve() for p in (*obj.files, *obj.data, *obj.holdout)]
    while todo:
        path = todo.pop()
        if path in seen or not path.is_file():
            continue
        seen.add(path)
        with path.open("rb") as f:
            text = b"\0" not in f.read(_SNIFF)
        if text:
            todo.extend(_references(path, path.read_bytes()))
    return sorted(seen)


def input_size(obj: BatchObject) -> int:
    """Bytes of the object's named files (its folder for captures): a cheap guess of its cost,
    to start the biggest objects first so none is left running alone at the end."""
    paths = obj.folder.rglob("*") if obj.whole_folder else (*obj.files, *obj.data)
    return sum(p.stat().st_size for p in paths if p.is_file())


def inputs_hash(obj: BatchObject) -> str:
    """SHA-256 over the object's input files: each one's path relative to the object's folder
    and its content (so a moved dataset keeps its hashes)."""
    h = hashlib.sha256()
    base = obj.folder.resolve()
    for path in input_files(obj):
        h.update(os.path.relpath(path, base).encode() + b"\0")
        h.update(_file_digest(path).encode() + b"\n")
    return h.hexdigest()


def task_key(kind: str, options: dict, version: str, input_hash: str) -> str:
    """What must match for an earlier result to stand: the task, its options, the package
    version and the inputs' content."""
    text = json.dumps({"task": kind, "options": options, "version": version,
                       "inputs": input_hash}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def _file_digest(path: Path) -> str:
    with path.open("rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def _references(path: Path, data: bytes) -> Iterable[Path]:
    suffix = path.suffix.lower()
    if suffix == ".obj":
        tokens = [t for line in data.splitlines() if line.startswith(b"mtllib")
                  for t in line.split()[1:]]
    elif suffix == ".mtl":
        tokens = [line.split()[-1] for line in data.splitlines()
                  if line.strip().startswith(_MTL_MAPS) and len(line.split()) > 1]
    else:
        tokens = [t for t in _TOKEN.findall(data)
                  if (b"." in t or b"/" in t) and not _NUMBER.fullmatch(t)]
    bases = [path.parent] + [path.parent / d.decode(errors="replace")
                             for d in _MJCF_DIRS.findall(data)]
    for raw in tokens:
        token = raw.decode(errors="replace")
        if token.startswith("package://"):
            found = _package_path(path, token)
            if found is not None:
                yield found
            continue
        token = token.removeprefix("file://")
        for base in bases:
            try:
                candidate = (base / token).resolve()
                if candidate.is_file():
                    yield candidate
                    break
            except (OSError, ValueError):  # not a path after all (too long, NUL, ...)
                break


def _package_path(path: Path, token: str) -> Path | None:
    """``package://`` resolved the way the URDF reader resolves it."""
    from ..errors import FormatError
    from ..formats.urdf.context import Context
    from ..formats.urdf.geometry import resolve_filename

    try:
        return resolve_filename(Context(path), token, None, None).resolve()
    except FormatError:
        return None
