"""A disk cache of what is derived from meshes and images: convex collision pieces, mass
properties, the PNG copy MuJoCo reads of a JPEG.

Exporting the same object again (a user iterating on options, a batch rerun, ``check`` after
``export``) would otherwise recompute qhull hulls and mesh integrals, and import trimesh and
scipy for them, which costs more than the rest of a URDF -> USD export together. Entries are
keyed by the content hash of the input meshes, the parameters and the source of the module
that computes them (a change to that code never reads a stale entry), written atomically (concurrent processes never see half a file) and ignored when unreadable. A
computation that gave a repair warning (``Real2CodeWarning``) is not stored, so that its
warnings are never silenced by a rerun.

``$REAL2CODE_CACHE`` moves the cache (default ``~/.cache/real2code_export``);
``REAL2CODE_CACHE=off`` turns it off.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from .atomic import write_bytes
from .errors import Real2CodeWarning
from .model import Mesh

# Bump when what is stored changes shape (the computing code's own changes are in the key).
CACHE_VERSION = 1

Arrays = dict[str, np.ndarray]


def cache_root() -> Path | None:
    """The cache folder (None when the cache is turned off)."""
    env = os.environ.get("REAL2CODE_CACHE")
    if env and env.lower() == "off":
        return None
    return Path(env) if env else Path.home() / ".cache" / "real2code_export"


def key(kind: str, meshes: Sequence[Mesh], params: dict, sources: Sequence[str] = ()) -> str:
    """Content key of ``kind`` computed from ``meshes`` with ``params`` (JSON-able) by the
    code in the files ``sources``."""
    h = hashlib.sha256(json.dumps({"kind": kind, "version": CACHE_VERSION, **params},
                                  sort_keys=True).encode())
    for source in sources:
        h.update(Path(source).read_bytes())
    for mesh in meshes:
        h.update(mesh.digest().encode())
        # the shapes it keeps too: a round shape weighs its exact solid, its bare
        # tessellation (the same triangles) 2 to 3 % less
        for shape in mesh.primitives:
            h.update(shape.kind.value.encode())
            h.update(shape.size.tobytes())
            h.update(shape.pose.tobytes())
    return h.hexdigest()


def cached(kind: str, meshes: Sequence[Mesh], params: dict, compute: Callable[[], object],
           encode: Callable[[object], Arrays], decode: Callable[[Arrays], object], *,
           sources: Sequence[str] = ()):
    """``compute()``, or its stored result for the same meshes, parameters and ``sources``
    (the files of the code ``compute`` runs: pass the caller's ``__file__``)."""
    root = cache_root()
    if root is None:
        return compute()
    path = root / kind / f"{key(kind, meshes, params, sources)}.npz"
    if path.is_file():
        # truncated or foreign: recompute, rewrite
        with contextlib.suppress(Exception), np.load(path, allow_pickle=False) as data:
            return decode({name: data[name] for name in data.files})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = compute()
    for w in caught:  # pass them on as they came
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if not any(issubclass(w.category, Real2CodeWarning) for w in caught):
        buf = io.BytesIO()
        np.savez(buf, **encode(result))
        with contextlib.suppress(OSError):  # a cache that cannot be written is a lost speed-up
            write_bytes(path, buf.getvalue())
    return result


def encode_meshes(meshes: Sequence[Mesh]) -> Arrays:
    arrays = {"count": np.array(len(meshes))}
    for k, m in enumerate(meshes):
        arrays[f"v{k}"], arrays[f"f{k}"] = m.vertices, m.faces
    return arrays


def decode_meshes(arrays: Arrays) -> list[Mesh]:
    meshes = [Mesh(arrays[f"v{k}"], arrays[f"f{k}"]) for k in range(int(arrays["count"]))]
    if any(len(m.faces) and m.faces.max() >= len(m.vertices) for m in meshes):
        raise ValueError("inconsistent cached mesh")
    return meshes


def cached_bytes(kind: str, digest: str, params: dict, compute: Callable[[], bytes], *,
                 sources: Sequence[str] = ()) -> bytes:
    """``compute()``, a file's bytes derived from the content whose hash is ``digest`` (an
    image's PNG copy), or its stored result for the same digest, parameters and ``sources``."""
    root = cache_root()
    if root is None:
        return compute()
    h = hashlib.sha256(json.dumps({"kind": kind, "version": CACHE_VERSION, "digest": digest,
                                   **params}, sort_keys=True).encode())
    for source in sources:
        h.update(Path(source).read_bytes())
    path = root / kind / h.hexdigest()
    if path.is_file():
        with contextlib.suppress(OSError):
            return path.read_bytes()
    result = compute()
    with contextlib.suppress(OSError):  # a cache that cannot be written is a lost speed-up
        write_bytes(path, result)
    return result
