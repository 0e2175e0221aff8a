"""Collision geometry: convex pieces every simulator accepts.

Simulators collide convex shapes (MuJoCo hulls every mesh geom), so a part's collision is a
list of convex meshes. Three ways to get them, picked per case because their costs differ
by orders of magnitude:

- ``"hull"``: one convex hull (milliseconds). Right for convex-ish parts.
- ``"pieces"``: the hull of each source piece (PartNet parts come as many OBJ pieces that
  are mostly boxes and cylinders already): 40 pieces in ~0.2 s, cached on disk
  (``meshcache``) so that exporting the same object again costs nothing.
- ``"boxes"``: a voxel box decomposition of a hollow mesh (``collision_boxes``): walls
  become slabs, so a carcass keeps its openings and a drawer its inside (well under 1 s).
- ``"coacd"``: CoACD approximate convex decomposition of one mesh (a watertight scan).
  Slow: a 10k-face PartNet part took ~80 s at threshold 0.1 on 2 cores, so results are
  cached on disk by mesh hash and parameters.

"pieces" and "boxes" split a hollow piece into boxes and hull a solid one, so no piece's
hull fills an opening of its part.

Every piece returned is convex, closed and has volume (flat or linear input is thickened
first), and the order is deterministic.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from . import meshcache
from .atomic import write_bytes
from .collision_boxes import DEFAULT_RESOLUTION, hollow_pieces
from .errors import InputError, warn
from .meshtopology import used_indices
from .model import Mesh

METHODS = ("auto", "hull", "pieces", "boxes", "coacd")
DEFAULT_MIN_THICKNESS = 1e-3  # 1 mm
# Cache format version: bump when the stored pieces would change for the same key.
_CACHE_VERSION = 1
# A closed mesh whose volume is this close to its hull's counts as convex for "auto".
_CONVEX_VOLUME_RATIO = 0.95
# "pieces": a piece smaller than this fraction of the part (bounding-box diagonal) is merged
# into a neighbour when that barely grows the neighbour's hull (screws, hinge pins, labels).
_TINY_PIECE_FRACTION = 0.02
_TINY_MERGE_GROWTH = 0.10
# "pieces" without source pieces: beyond this many connected components the mesh is a soup
# of loose triangles, not a few solid pieces, and hulling each would take minutes.
_MAX_COMPONENTS = 256


# -- convex hull -------------------------------------------------------------------------------
def convex_hull(mesh: Mesh, *, min_thickness: float = DEFAULT_MIN_THICKNESS) -> Mesh:
    """The convex hull of ``mesh``'s vertices (qhull via trimesh), outward wound.

    Points that are (nearly) coplanar, collinear or a single point are first thickened to
    ``min_thickness`` along their thin principal directions (PCA): a hull of coplanar points
    has no volume, qhull refuses it, and MuJoCo fails to compile such a mesh ("mesh volume
    is too small" / qhull errors). PartNet has many single-sided flat pieces."""
    import trimesh

    points = _used_vertices(mesh)
    if len(points) == 0:
        raise InputError("cannot take the convex hull of an empty mesh")
    # Duplicate points (pieces sharing a face) make qhull's triangulated output leaky.
    points = np.unique(np.round(points, 12), axis=0)
    points = _thickened(points, min_thickness)
    try:
        hull = trimesh.convex.convex_hull(points, qhull_options="QbB Pp Qt")
    except Exception as e:  # qhull raises QhullError; trimesh may raise ValueError
        raise InputError(f"convex hull failed on {len(points)} points: {e}") from e
    if not (hull.is_volume and hull.volume > 0):
        # trimesh merges vertices closer than its tolerance, which tears hulls of small
        # pieces (a few mm); qhull's own triangulation is closed by construction.
        try:
            hull = _qhull_mesh(points)
        except Exception as e:  # QhullError (precision) on nearly degenerate point sets
            raise InputError(f"convex hull failed on {len(points)} points: {e}") from e
    if not (hull.is_volume and hull.volume > 0):
        raise InputError(f"convex hull of {len(points)} points has no volume")
    return Mesh.from_trimesh(hull)


def _qhull_mesh(points: np.ndarray):
    import trimesh
    from scipy.spatial import ConvexHull

    hull = ConvexHull(points, qhull_options="Qt")
    faces = hull.simplices.copy()
    # qhull's facet equations hold the outward normals: wind each triangle to match them
    # (trimesh's fix_normals does the same by graph traversal, 20 times slower)
    corners = points[faces]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    inward = np.einsum("ij,ij->i", normals, hull.equations[:, :3]) < 0
    faces[inward] = faces[inward][:, ::-1]
    used = used_indices(faces)
    remap = np.full(len(points), -1)
    remap[used] = np.arange(len(used))
    return trimesh.Trimesh(points[used], remap[faces], process=False)


def _used_vertices(mesh: Mesh) -> np.ndarray:
    if len(mesh.faces):
        return mesh.vertices[used_indices(mesh.faces)]
    return mesh.vertices


def _thickened(points: np.ndarray, min_thickness: float) -> np.ndarray:
    """Add copies of the points offset by +-min_thickness/2 along every principal direction
    in which they span less than min_thickness."""
    center = points.mean(axis=0)
    if len(points) >= 2:
        _, _, vt = np.linalg.svd(points - center, full_matrices=False)
        axes = vt if len(vt) == 3 else _complete_basis(vt)
    else:
        axes = np.eye(3)
    spans = np.ptp((points - center) @ axes.T, axis=0)
    for axis, span in zip(axes, spans, strict=True):
        if span < min_thickness:
            offset = 0.5 * (min_thickness - span) * axis
            points = np.concatenate([points - offset, points + offset])
    return points


def thickened(mesh: Mesh, *, min_thickness: float = DEFAULT_MIN_THICKNESS) -> Mesh:
    """``mesh`` as a collision mesh left for its consumer to hull (USD's convexHull
    approximation): its used vertices and faces, and where they span less than
    ``min_thickness`` in some direction (a flat panel, a rod), copies shifted +-half the
    missing thickness along it, so that the hull taken has the volume :func:`convex_hull`
    would give it (no qhull: nothing is hulled here)."""
    if len(mesh.faces) == 0:
        return Mesh(mesh.vertices, mesh.faces)
    # np.unique's answer (the used vertices in order, the faces renumbered) from a mask: no
    # sort (a robot's meshes use every vertex they have; a sort of their faces was half of this)
    used = np.zeros(len(mesh.vertices), dtype=bool)
    used[mesh.faces] = True
    faces = (np.cumsum(used) - 1)[mesh.faces]
    points = mesh.vertices[used]
    thick = _thickened(points, min_thickness)
    copies = len(thick) // len(points)
    return Mesh(thick, np.concatenate([faces + k * len(points) for k in range(copies)]))


def _complete_basis(rows: np.ndarray) -> np.ndarray:
    """Extend 1 or 2 orthonormal rows to an orthonormal basis of R^3."""
    basis = list(rows)
    for e in np.eye(3):
        v = e - sum(np.dot(e, b) * b for b in basis)
        if np.linalg.norm(v) > 1e-6:
            basis.append(v / np.linalg.norm(v))
        if len(basis) == 3:
            break
    return np.array(basis)


# -- dispatch ----------------------------------------------------------------------------------
def collision_pieces(
    mesh: Mesh,
    method: str = "auto",
    *,
    source_pieces: Sequence[Mesh] | None = None,
    cache_dir: Path | None = None,
    threshold: float = 0.1,
    max_pieces: int = 32,
    min_thickness: float = DEFAULT_MIN_THICKNESS,
    resolution: int = DEFAULT_RESOLUTION,
    split_hollow: bool = True,
) -> list[Mesh]:
    """Convex collision pieces for one part (``mesh`` in the part frame).

    ``method``: ``"hull"`` (one hull), ``"pieces"`` (a hull per source piece, or per
    connected component of ``mesh`` when ``source_pieces`` is None, a hollow piece split into
    boxes first; duplicates and pieces inside others dropped, tiny ones merged into
    neighbours, at most ``max_pieces``), ``"boxes"`` (``mesh`` as one piece, so split),
    ``"coacd"`` (CoACD at ``threshold``, at most ``max_pieces``; ~80 s for a 10k-face part on
    2 cores, cached in ``cache_dir``, default ``$REAL2CODE_CACHE`` or
    ``~/.cache/real2code_export/coacd``; falls back to one hull with a warning if CoACD
    fails) or ``"auto"`` ("pieces" when ``source_pieces`` is given, else "hull" when the mesh
    is a closed convex mesh, else "boxes", which keeps the hull of a solid).
    ``resolution``: voxels along the part's longest side when splitting hollow pieces;
    ``split_hollow=False`` hulls every piece as it is (for collision shapes an author
    modelled on purpose).

    Every piece is convex with positive volume; pieces are sorted by centroid."""
    if method not in METHODS:
        raise InputError(f"unknown collision method {method!r}; expected one of {METHODS}")
    if max_pieces < 1:
        raise InputError(f"max_pieces must be >= 1, got {max_pieces}")
    if method == "auto":
        method = _auto_method(mesh, source_pieces)
    if method == "hull":
        return [convex_hull(mesh, min_thickness=min_thickness)]
    if method in ("pieces", "boxes"):
        if method == "boxes":
            pieces = [mesh]
        else:
            pieces = list(source_pieces) if source_pieces is not None else _components(mesh)
        if pieces is None:
            warn(f"mesh has more than {_MAX_COMPONENTS} loose components; using one convex hull "
                 "(pass source_pieces, or use method='coacd')")
            return [convex_hull(mesh, min_thickness=min_thickness)]
        def compute() -> list[Mesh]:
            pitch = max(_extent(pieces) / resolution, min_thickness)
            points = _split_hollow(pieces, pitch, min_thickness, max_pieces) if split_hollow \
                else [_used_vertices(p) for p in pieces]
            return _sorted(_piece_hulls(points, max_pieces, min_thickness))

        return meshcache.cached(
            "pieces", pieces, {"max_pieces": max_pieces, "min_thickness": min_thickness,
                               "resolution": resolution, "split_hollow": split_hollow},
            compute, meshcache.encode_meshes, meshcache.decode_meshes,
            sources=(__file__, str(Path(__file__).with_name("collision_boxes.py"))))
    return _coacd_cached(mesh, threshold, max_pieces, min_thickness, cache_dir)


def _auto_method(mesh: Mesh, source_pieces: Sequence[Mesh] | None) -> str:
    if source_pieces is not None:
        return "pieces"
    # An open convex surface (a drawer without its top) is not a convex solid: boxes decide.
    closed = mesh.to_trimesh().is_watertight
    return "hull" if closed and is_convex(mesh) else "boxes"


def _extent(pieces: Sequence[Mesh]) -> float:
    """The longest side of the pieces' axis-aligned bounds (m)."""
    points = np.concatenate([_used_vertices(p) for p in pieces if len(p.vertices)] or
                            [np.zeros((1, 3))])
    return float(np.ptp(points, axis=0).max())


def _split_hollow(pieces: Sequence[Mesh], pitch: float, min_thickness: float,
                  max_pieces: int) -> list[np.ndarray]:
    """Point sets to hull: each piece's vertices, or its boxes when it is hollow at
    ``pitch`` (its hull would fill an opening)."""
    out = []
    for p in pieces:
        points = _used_vertices(p)
        if len(points) == 0:
            continue
        if len(p.faces) and len(points) >= 4 and np.ptp(points, axis=0).max() >= 3 * pitch:
            try:
                volume = float(convex_hull(p, min_thickness=min_thickness).to_trimesh().volume)
            except InputError:
                volume = 0.0
            boxes = hollow_pieces(p, volume, pitch, max_pieces)
            if boxes:
                out.extend(boxes)
                continue
        out.append(points)
    return out


def is_convex(mesh: Mesh, rel_tol: float = 1e-3) -> bool:
    """Whether ``mesh`` is (close to) convex: a closed mesh with at least 95 % of its hull's
    volume, or an open one whose vertices all lie on its hull's boundary."""
    import trimesh

    try:
        hull = convex_hull(mesh).to_trimesh()
    except ValueError:
        return False
    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=True)
    if tm.is_volume:
        return abs(tm.volume) >= _CONVEX_VOLUME_RATIO * hull.volume
    tol = rel_tol * float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
    depth = _depth_inside(_hull_planes(hull), _used_vertices(mesh))
    return bool(np.all(depth <= tol))


def _components(mesh: Mesh) -> list[Mesh] | None:
    """The connected components of ``mesh``, or None when there are too many to hull one by
    one (a triangle soup, as many PartNet OBJs are)."""
    import trimesh

    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=True)
    labels = trimesh.graph.connected_component_labels(tm.face_adjacency, node_count=len(tm.faces))
    if labels.max() + 1 > _MAX_COMPONENTS:
        return None
    faces = np.asarray(tm.faces)
    return [Mesh(tm.vertices, faces[labels == k]) for k in range(labels.max() + 1)]


# -- "pieces" ----------------------------------------------------------------------------------
class _Hull:
    """A convex piece with what merging needs: its points, volume, planes, centroid."""

    def __init__(self, points: np.ndarray, min_thickness: float):
        self.mesh = convex_hull(Mesh(points, np.zeros((0, 3))), min_thickness=min_thickness)
        self.points = self.mesh.vertices
        tm = self.mesh.to_trimesh()
        self.volume = float(tm.volume)
        self.planes = _hull_planes(tm)
        self.centroid = self.points.mean(axis=0)
        self.diagonal = float(np.linalg.norm(np.ptp(self.points, axis=0)))


def _hull_planes(tm) -> np.ndarray:
    """(F, 4) outward unit normals n and offsets d of a convex mesh: inside is n.x <= d."""
    normals = np.asarray(tm.face_normals)
    offsets = np.einsum("ij,ij->i", normals, np.asarray(tm.triangles_center))
    return np.column_stack([normals, offsets])


def _depth_inside(planes: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Per point, how far it is outside the convex hull's planes (<= 0: inside)."""
    return (points @ planes[:, :3].T - planes[:, 3]).max(axis=1)


def _piece_hulls(pieces: Sequence[np.ndarray], max_pieces: int, min_thickness: float
                 ) -> list[Mesh]:
    hulls = [_Hull(p, min_thickness) for p in pieces if len(p)]
    if not hulls:
        raise InputError("no non-empty pieces to build collision hulls from")
    part_diag = float(np.linalg.norm(np.ptp(np.concatenate([h.points for h in hulls]), axis=0)))
    tol = max(1e-6 * part_diag, 1e-9)
    hulls = _drop_contained(hulls, tol)

    # Tiny pieces: merge into the neighbour whose hull grows least, if it grows little.
    for h in sorted(hulls, key=lambda h: (h.volume, tuple(h.centroid))):
        if h not in hulls or h.diagonal >= _TINY_PIECE_FRACTION * part_diag or len(hulls) == 1:
            continue
        others = [o for o in hulls if o is not h]
        best, merged, growth = _best_merge(h, others, min_thickness)
        if growth <= _TINY_MERGE_GROWTH:
            hulls = [o for o in others if o is not best] + [merged]

    # Too many pieces: merge the smallest into its cheapest neighbour until under the cap.
    while len(hulls) > max_pieces:
        h = min(hulls, key=lambda h: (h.volume, tuple(h.centroid)))
        others = [o for o in hulls if o is not h]
        best, merged, _ = _best_merge(h, others, min_thickness)
        hulls = [o for o in others if o is not best] + [merged]
    return [h.mesh for h in hulls]


def _drop_contained(hulls: list[_Hull], tol: float) -> list[_Hull]:
    """Drop hulls lying inside another (which also drops exact duplicates, keeping one)."""
    order = sorted(hulls, key=lambda h: (-h.volume, tuple(h.centroid)))
    kept: list[_Hull] = []
    for h in order:
        if not any(_depth_inside(k.planes, h.points).max() <= tol for k in kept):
            kept.append(h)
    return kept


def _best_merge(h: _Hull, others: list[_Hull], min_thickness: float,
                candidates: int = 4) -> tuple[_Hull, _Hull, float]:
    """Among the nearest few (by centroid), the neighbour whose hull grows least, relative to
    its own volume, when ``h`` joins it: that neighbour, the merged hull and the growth."""
    near = sorted(others, key=lambda o: (float(np.linalg.norm(o.centroid - h.centroid)),
                                         tuple(o.centroid)))[:candidates]
    best = None
    for o in near:
        merged = _Hull(np.concatenate([o.points, h.points]), min_thickness)
        growth = (merged.volume - o.volume - h.volume) / o.volume
        if best is None or growth < best[2]:
            best = (o, merged, growth)
    assert best is not None
    return best


def _sorted(pieces: list[Mesh]) -> list[Mesh]:
    """Deterministic order: by centroid (rounded to 1 nm), then size."""
    def key(m: Mesh):
        c = np.round(m.vertices.mean(axis=0), 9)
        return (*c.tolist(), len(m.vertices), len(m.faces))
    return sorted(pieces, key=key)


# -- "coacd" -----------------------------------------------------------------------------------
def default_cache_dir() -> Path | None:
    """``$REAL2CODE_CACHE/coacd`` (default ``~/.cache/real2code_export/coacd``); None when
    ``REAL2CODE_CACHE=off``."""
    root = meshcache.cache_root()
    return None if root is None else root / "coacd"


def _coacd_key(mesh: Mesh, threshold: float, max_pieces: int, min_thickness: float) -> str:
    params = {
        "cache_version": _CACHE_VERSION,
        "coacd": _coacd_version(),
        "threshold": float(threshold),
        "max_pieces": int(max_pieces),
        "min_thickness": float(min_thickness),
        "seed": 0,
    }
    h = hashlib.sha256(mesh.digest().encode())
    h.update(json.dumps(params, sort_keys=True).encode())
    return h.hexdigest()


def _coacd_version() -> str:
    """Part of the cache key: a new CoACD may decompose differently."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("coacd")
    except PackageNotFoundError:
        return "unknown"


def _coacd_cached(mesh: Mesh, threshold: float, max_pieces: int, min_thickness: float,
                  cache_dir: Path | None) -> list[Mesh]:
    folder = cache_dir or default_cache_dir()
    path = None if folder is None else (
        Path(folder) / f"{_coacd_key(mesh, threshold, max_pieces, min_thickness)}.npz")
    cached = None if path is None else _read_cache(path)
    if cached is not None:
        return cached
    try:
        raw = _run_coacd(mesh, threshold, max_pieces)
        pieces = [convex_hull(p, min_thickness=min_thickness) for p in raw]
    except Exception as e:  # CoACD raises bare RuntimeErrors (or crashes inside ctypes)
        warn(f"CoACD decomposition failed ({e}); using one convex hull instead")
        return [convex_hull(mesh, min_thickness=min_thickness)]
    if not pieces:
        warn("CoACD returned no pieces; using one convex hull instead")
        return [convex_hull(mesh, min_thickness=min_thickness)]
    pieces = _sorted(pieces)
    if path is not None:
        _write_cache(path, pieces)
    return pieces


def _run_coacd(mesh: Mesh, threshold: float, max_pieces: int) -> list[Mesh]:
    import coacd

    coacd.set_log_level("error")
    result = coacd.run_coacd(coacd.Mesh(mesh.vertices, mesh.faces), threshold=threshold,
                             max_convex_hull=max_pieces, seed=0)
    return [Mesh(np.asarray(v), np.asarray(f)) for v, f in result]


def _read_cache(path: Path) -> list[Mesh] | None:
    """The cached pieces, or None when absent or unreadable (then recomputed)."""
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            count = int(data["count"])
            pieces = [Mesh(data[f"v{k}"], data[f"f{k}"]) for k in range(count)]
        if not pieces or any(len(p.faces) == 0 or p.faces.max() >= len(p.vertices) for p in pieces):
            raise InputError("empty or inconsistent pieces")
        return pieces
    except Exception as e:  # a truncated or foreign file: ignore it, it will be rewritten
        warn(f"ignoring unreadable collision cache entry {path}: {e}")
        return None


def _write_cache(path: Path, pieces: list[Mesh]) -> None:
    """Atomic (temporary file + rename), so concurrent processes never see half a file;
    a cache that cannot be written is only a lost speed-up."""
    buf = io.BytesIO()
    arrays = {"count": np.array(len(pieces))}
    for k, p in enumerate(pieces):
        arrays[f"v{k}"], arrays[f"f{k}"] = p.vertices, p.faces
    np.savez(buf, **arrays)
    with contextlib.suppress(OSError):
        write_bytes(path, buf.getvalue())
