"""Where a training run keeps the data it generated (rendered views, sampled objects)
between runs, named by what made it.

A cache named by its sizes and seed alone is reused after the generator changed (a new part
kind, another renderer, a fixed sensor model), and the network silently trains on data the
code no longer makes. So the name also holds a hash of the source the data come from: every
Python file of this package and of ``real2code_export`` (the model, meshes and kinematics
the generator uses). Any change there makes a new file; over-inclusion only costs a
regeneration, a miss would cost a wrong network."""

from __future__ import annotations

import hashlib
from functools import cache
from pathlib import Path


def source_hash(roots: list[Path]) -> str:
    """A short hash of every ``.py`` file under ``roots``, names and contents."""
    h = hashlib.sha256()
    for root in roots:
        for path in sorted(root.rglob("*.py")):
            h.update(f"{root.name}/{path.relative_to(root).as_posix()}".encode())
            h.update(path.read_bytes())
    return h.hexdigest()[:12]


@cache
def code_version() -> str:
    """The hash of the source the training data depend on (this package and the core)."""
    import real2code_export

    return source_hash([Path(__file__).resolve().parent,
                        Path(real2code_export.__file__).resolve().parent])


def cache_file(cache_dir: Path | None, name: str) -> Path | None:
    """``cache_dir/<name>_<code version>.pkl``; None without a cache folder."""
    return None if cache_dir is None else cache_dir / f"{name}_{code_version()}.pkl"
