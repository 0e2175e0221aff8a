"""``--transfer object-store``: for Ray clusters whose nodes do not share a file system.

The driver reads each object's input files (the model and everything it references, as the
fingerprint finds them) and sends them with the task; the worker rebuilds the object's folder
in a temporary one on its node, runs the task there, and sends the output files back through
Ray's object store; the driver moves them into DIR. Paths in the record are the driver's, and
the inputs' hash is the same, so resuming works as with shared files. Inputs must lie inside
the object's folder (a ``../`` reference has nowhere to go on the other node).
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import replace
from pathlib import Path

from .fingerprint import input_files
from .tasks import BatchTaskError, replace_text
from .worker import WorkItem, install, run_one, staging_folder


def pack_inputs(item: WorkItem) -> dict[str, bytes]:
    """The object's input files by path relative to its folder (read on the driver)."""
    base = item.obj.folder.resolve()
    packed = {}
    for path in input_files(item.obj):
        rel = os.path.relpath(path, base)
        if rel.startswith(".."):
            raise BatchTaskError(f"{path}: lies outside the object's folder {base}; "
                                 "--transfer object-store sends only what is inside it")
        packed[rel] = path.read_bytes()
    return packed


def run_shipped(item: WorkItem, inputs: dict[str, bytes]) -> tuple[dict, dict[str, bytes]]:
    """On any node: the object rebuilt from ``inputs``, its task run; the record (with the
    driver's paths) and the output files (relative to DIR)."""
    obj = item.obj
    with tempfile.TemporaryDirectory(prefix="real2code-batch-") as tmp:
        folder = Path(tmp) / "object"
        for rel, data in inputs.items():
            (folder / rel).parent.mkdir(parents=True, exist_ok=True)
            (folder / rel).write_bytes(data)

        def here(p: Path) -> Path:
            return folder / os.path.relpath(p, obj.folder)

        local = replace(obj, folder=folder, files=tuple(map(here, obj.files)),
                        data=tuple(map(here, obj.data)), holdout=tuple(map(here, obj.holdout)))
        out = Path(tmp) / "out"
        record = run_one(replace(item, obj=local, out_dir=out, cache_dir=None))
        outputs = {rel: (out / rel).read_bytes() for rel in record["outputs"]}
    return replace_text(record, str(folder), str(obj.folder)), outputs


def unpack_outputs(item: WorkItem, outputs: dict[str, bytes]) -> None:
    """On the driver: the files a worker sent back, moved into DIR/<id> (atomically)."""
    if not outputs:
        return
    staging = staging_folder(item.out_dir, item.obj.id)
    prefix = item.obj.id + "/"
    for rel, data in outputs.items():
        if not rel.startswith(prefix):
            raise BatchTaskError(f"{rel}: an output outside the object's folder {item.obj.id}")
        path = staging / rel.removeprefix(prefix)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
    install(staging, item.out_dir / item.obj.id)
