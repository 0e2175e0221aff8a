"""Which mesh assets an export writes once and places several times (``Mesh.placements``).

Every writer whose format can place one mesh data several times (USD references, MJCF mesh
assets named by several geoms, URDF elements naming one file, object.json) asks the same
two questions: is this asset's data otherwise written more than once (:func:`shared_assets`),
and is a part's mesh wholly made of such placements (:func:`placed_pieces`,
:func:`whole_placement`)? The answers live here, once.

The merged mesh stays the model's truth: a mesh that is not wholly placements (a repair, a
concatenation with other triangles, a textured visual) is written merged, as before.
"""

from __future__ import annotations

import numpy as np

from . import transforms as tf
from .model import RGBA, ArticulatedObject, Mesh, Part, Placement


def shared_assets(obj: ArticulatedObject) -> dict[int, Mesh]:
    """id(asset) -> asset, for every asset whose data the object would otherwise hold more
    than once, in the order first placed (parts in order, visual before colliders). An asset
    placed once, or whole meshes at one pose only (a part's visual and its collider; a left
    and a right finger, each in its own frame: writers write equal meshes once already), is
    not shared: it is written where it is placed, as before."""
    copies: dict[int, set] = {}  # id(asset) -> where its data would be written
    order: dict[int, Mesh] = {}
    for part in obj.parts:
        for mesh in ([part.visual] if part.visual is not None else []) + part.collision:
            whole = len(mesh.placements) == 1 and len(mesh.faces) == len(
                mesh.placements[0].asset.faces) and not mesh.primitives
            for placement in mesh.placements:
                key = id(placement.asset)
                order.setdefault(key, placement.asset)
                copies.setdefault(key, set()).add(
                    (None if whole else id(mesh), placement.pose.tobytes()))
    return {key: asset for key, asset in order.items() if len(copies[key]) > 1}


def _holds(mesh: Mesh, p: Placement, exact: bool) -> bool:
    """Whether ``mesh``'s stretch is ``p``'s asset at its pose bit for bit (``exact``: a
    lossless format recomputes it so) or as :class:`Placement` promises (to float64
    rounding, always true of a valid model)."""
    if not exact:
        return True
    return np.array_equal(mesh.vertices[p.vertex:p.vertex_end],
                          p.asset.transformed(p.pose).vertices)


def placed_pieces(own: Mesh, part: Part, shared: dict[int, Mesh], *,
                  exact: bool = False) -> list[tuple[Placement, RGBA | None]] | None:
    """A visual's own triangles (``own``: its remainder, shapes left out) as the assets it
    places, in order, each with its colour (None: the part's), where every triangle lies in
    one placement of one colour, rigidly placed, and some asset is shared (placed more than
    once in the object); else None (the visual is written as one mesh). A textured part
    keeps one mesh: its images need one. ``exact``: only where each stretch is its asset
    moved bit for bit (:func:`_holds`)."""
    if not own.placements or part.texture is not None or part.maps \
            or not any(id(p.asset) in shared for p in own.placements):
        return None
    runs = own.face_color_runs()
    out, vertex, face = [], 0, 0
    for p in sorted(own.placements, key=lambda p: p.face):
        if p.face != face or p.vertex != vertex or p.asset.colors or p.asset.primitives \
                or (p.asset.uv is None) != (own.uv is None) \
                or not tf.is_rotation(p.pose[:3, :3]) or not _holds(own, p, exact):
            return None
        rgba = None
        if runs:
            run = next((r for r in runs if r[0] <= p.face < r[1]), None)
            if run is None or p.face_end > run[1]:
                return None
            rgba = run[2]
        out.append((p, rgba))
        vertex, face = p.vertex_end, p.face_end
    return out if (vertex, face) == (len(own.vertices), len(own.faces)) else None


def whole_placement(mesh: Mesh, shared: dict[int, Mesh], *,
                    exact: bool = False) -> Placement | None:
    """The one placement of a shared asset that is the whole of ``mesh`` (a collider that is
    one mesh asset placed), else None."""
    if len(mesh.placements) != 1 or mesh.primitives:
        return None
    p = mesh.placements[0]
    whole = (p.vertex, p.face, p.vertex_end, p.face_end) == (0, 0, len(mesh.vertices),
                                                             len(mesh.faces))
    return p if whole and id(p.asset) in shared and tf.is_rotation(p.pose[:3, :3]) \
        and _holds(mesh, p, exact) else None
