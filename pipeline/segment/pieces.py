"""Stray pieces of a moving part's label go to the part they lie in: a piece cut off from the
label's main piece, far from it, and touching another part along much of its outline.

Under a depth sensor's faults the mask network's masks stray: a drawer's masks also take a
patch of the carcass beside it, seen from a view or two, and the vote keeps it. The patch
lies apart from the drawer's own surface, so its box (fitted to both) grows to the
carcass's size and the joint read off it turns (on a phone-LiDAR ring a table's drawer
label held a 300-point patch of the table's body, and the table's two joints came out 90
degrees off). Geometry tells such patches apart where the masks cannot: a stray patch lies well
away from its label's own surface and inside another part's (a good share of its points
touch that part). A true part's surface can fall apart too, and must not lose pieces: cut
by an occluder or a thin gap its pieces lie a few spacings apart, and where a piece borders
another part it does so along an edge (with exact masks on a 9-part cabinet such pieces lay
2.8 to 9.7 spacings from their main piece with at most 27 % of their points touching
another part; the stray patches of phone-LiDAR captures lay 5 to 57 spacings away, most
with 30 to 100 % touching).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PieceOptions:
    link_spacings: float = 2.5  # points this close (in cloud spacings) are one surface
    max_share: float = 0.5  # a piece up to this share of its label's main piece may move ...
    min_gap_spacings: float = 5.0  # ... when it lies this far from the main piece ...
    min_touching: float = 0.3  # ... and this share of its points touch the part it goes to
    min_points: int = 5  # a piece of fewer points tells nothing of where it belongs


def linked_components(points: np.ndarray, radius: float) -> np.ndarray:
    """Connected-component index of every point, points within ``radius`` linked."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    pairs = cKDTree(points).query_pairs(radius, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                       shape=(len(points), len(points)))
    return connected_components(graph, directed=False)[1]


def reassign_detached(cloud: np.ndarray, labels: np.ndarray, spacing: float,
                      options: PieceOptions = PieceOptions()) -> tuple[np.ndarray, list[dict]]:
    """``labels`` (1..n over ``cloud``, 1 the largest: the carcass) with every stray piece of
    a moving part's label given to the part whose points it touches most (within
    ``link_spacings`` spacings): a piece cut off from its label's main (largest) piece, of
    at least ``min_points`` and at most ``max_share`` of its size, at least
    ``min_gap_spacings`` from it, and with at least ``min_touching`` of its points touching
    that part. Returns the labels (the same numbering: a label keeps its main piece) and
    what moved.

    The carcass keeps its own pieces (its shell, seen past doors and through gaps, falls
    into pieces that border the parts in front of them), and a piece of a few points says
    nothing of where it belongs: on the demo capture both kinds of move were wrong, and a
    2-point piece 40 spacings from its part, handed to another, turned that one's joint."""
    from scipy.spatial import cKDTree

    radius = options.link_spacings * spacing
    out = labels.copy()
    moved = []
    tree = cKDTree(cloud)
    for label in range(2, int(labels.max()) + 1):  # the carcass keeps its own pieces
        index = np.nonzero(labels == label)[0]
        if len(index) < 2:
            continue
        piece = linked_components(cloud[index], radius)
        sizes = np.bincount(piece)
        if len(sizes) < 2:
            continue
        main = int(np.argmax(sizes))
        main_tree = cKDTree(cloud[index[piece == main]])
        for p in np.argsort(-sizes):
            if (p == main or sizes[p] > options.max_share * sizes[main]
                    or sizes[p] < options.min_points):
                continue
            members = index[piece == p]
            if main_tree.query(cloud[members])[0].min() < options.min_gap_spacings * spacing:
                continue
            near = [labels[n] for n in tree.query_ball_point(cloud[members], radius)]
            others = np.concatenate([n[n != label] for n in near]).astype(int)
            if len(others) == 0:
                continue
            to = int(np.bincount(others).argmax())
            if np.mean([np.any(n == to) for n in near]) < options.min_touching:
                continue
            out[members] = to
            moved.append({"from": label, "to": to, "points": len(members)})
    return out, moved
