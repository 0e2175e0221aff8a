"""The compartment seen past a swung-open door, and pieces of the carcass cut out as parts of
their own, go back to the carcass: repairs of a part segmentation by what a carcass is, their
own stage between segmentation and fusion.

The mask network's commonest error: prompted on an open door it also takes the inside of the
compartment the door reveals, which the carcass's own masks leave out, so no vote gives those
points back, and the door becomes a carcass-deep box that reads as a drawer. Segmentation
(``pipeline.segment``) stays generic; this stage knows about doors and carcasses.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .capture import Capture
from .fuse import axis_mean, normal_map, point_map
from .obb import part_obb
from .segment.prompting import Segmentation, label_views, numbered_by_size


@dataclass(frozen=True)
class CompartmentOptions:
    """Tuned on procedural dev objects (seeds disjoint from training and the test set)."""

    panel_min_angle: float = 10.0  # deg: a part whose main plane is turned this far from
    panel_fraction: float = 0.3  # the carcass's axes (and holds this share of its points,
    panel_voxels: float = 1.5  # within this many spacings) is a door swung open; its points
    behind_voxels: float = 3.0  # farther than this from that plane, inside the carcass's box,
    # are the compartment seen through the opening and go back to the carcass
    panel_normal_deg: float = 20.0  # a plane counts as a panel by its points whose measured
    # normals lie within this of its own (RANSAC also fits planes across a box's edges)
    enclosed_share: float = 0.03  # a part of at most this share of the carcass's points ...
    enclosed_inside: float = 0.98  # ... with this share of them inside the carcass's box ...
    enclosed_margin_voxels: float = 1.0  # ... (grown by this many spacings) is the carcass's


def return_to_carcass(capture: Capture, seg: Segmentation,
                      options: CompartmentOptions = CompartmentOptions()) -> Segmentation:
    """``seg`` with the compartments behind open doors given back to the carcass (its cloud's
    labels and every view's label image); what moved is in ``details["returned_to_carcass"]``.
    A segmentation without a fused cloud spacing (the capture's own masks) is returned as is."""
    if seg.spacing is None:
        return seg
    measured = [(point_map(f)[0][f.depth > 0], normal_map(f)[f.depth > 0])
                for f in capture.frames]
    normals = axis_mean(seg.points, np.concatenate([p for p, _ in measured]),
                        np.concatenate([n for _, n in measured]))
    labels, moved = return_compartments(seg.points, seg.point_labels, seg.spacing, options,
                                        normals)
    labels, enclosed = return_enclosed(seg.points, labels, seg.spacing, options)
    moved += enclosed
    if not moved:  # the labels stand (already numbered by size): no views to redo
        return replace(seg, details={**seg.details, "returned_to_carcass": []})
    return replace(seg, labels=label_views(capture, seg.points, labels),
                   n_parts=int(labels.max()), point_labels=labels,
                   details={**seg.details, "parts": int(labels.max()),
                            "returned_to_carcass": moved})


def return_compartments(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                        options: CompartmentOptions = CompartmentOptions(),
                        normals: np.ndarray | None = None,
                        ) -> tuple[np.ndarray, list[dict]]:
    """Points of a swung-open door's part that are the compartment behind it go back to the
    carcass (label 1, the largest part).

    The mask network's commonest error: prompted on an open door it also takes the inside of
    the compartment the door reveals, which the carcass's own masks leave out, so no vote
    gives those points back, and the door becomes a carcass-deep box that reads as a drawer.
    Geometry tells them apart where the masks cannot: a door swung open is a panel turned
    away from the carcass's axes, while the compartment's walls and a drawer's front and
    box are square to them. So for each part whose main plane (RANSAC, open3d) holds enough
    of its points and is turned at least ``panel_min_angle`` from every axis of the
    carcass's box, the points well off that plane and inside the carcass's box are handed to
    the carcass. Drawers and closed doors are left alone (no turned panel); a door opened
    past ~80 degrees is too (its panel is square to the carcass again). With the points'
    measured ``normals`` (:func:`pipeline.fuse.axis_mean`), only the plane's points that
    face along it count: RANSAC also fits planes that cut across a box's edges (on the demo
    capture a drawer's got one, turned 13 degrees, and lost its front to the carcass).
    Returns the labels, renumbered by size, and what was moved, per part."""
    import open3d as o3d

    out = labels.copy()
    moved = []
    if labels.max() < 2 or np.count_nonzero(labels == 1) < 4:
        return out, moved
    body = part_obb(cloud[labels == 1])
    o3d.utility.random.seed(0)  # RANSAC, deterministic
    for k in range(2, int(labels.max()) + 1):
        index = np.nonzero(labels == k)[0]
        if len(index) < 30:
            continue
        pts = cloud[index]
        pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts))
        (a, b, c, d), inliers = pcd.segment_plane(options.panel_voxels * voxel, 3, 300)
        normal = np.array([a, b, c]) / np.linalg.norm([a, b, c])
        if normals is not None:  # the plane's points that face along it
            inliers = np.asarray(inliers, dtype=int)
            facing = np.abs(normals[index[inliers]] @ normal)
            inliers = inliers[facing >= np.cos(np.radians(options.panel_normal_deg))]
        if len(inliers) < options.panel_fraction * len(pts):
            continue
        turn = np.degrees(np.arccos(min(1.0, float(np.max(np.abs(body.R.T @ normal))))))
        if turn < options.panel_min_angle:
            continue
        behind = np.abs(pts @ normal + d / np.linalg.norm([a, b, c])) > (
            options.behind_voxels * voxel)
        back = behind & body.contains(pts, tol=voxel)
        if back.any():
            out[index[back]] = 1
            moved.append({"part": k, "points": int(back.sum()), "panel_turn_deg": round(turn, 1)})
    return numbered_by_size(out), moved


def return_enclosed(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                    options: CompartmentOptions = CompartmentOptions(),
                    ) -> tuple[np.ndarray, list[dict]]:
    """Small parts lying wholly inside the carcass's box (label 1, the largest part) go back
    to it: pieces of its shell that the masks cut out as parts of their own.

    A part is only seen to move when it is seen out of place: a drawer pulled out stands
    out of the carcass's box, a door swung open leaves it (the pipeline, like the paper's,
    reads joints off an object seen partly open). A patch of the carcass's top or side that
    the mask network, on noisy depth, gave a label of its own lies inside the box, and
    the joint predictor makes a drawer or a door of it (on phone-LiDAR rings of the
    procedural test set, one or two such patches of 1 to 2 % of the carcass's points per
    object, each given a joint). Parts of more than ``enclosed_share`` of the carcass's
    points are left alone. Returns the labels, renumbered by size, and what was moved."""
    out = labels.copy()
    moved = []
    carcass = labels == 1
    if labels.max() < 2 or np.count_nonzero(carcass) < 4:
        return out, moved
    body = part_obb(cloud[carcass])
    for k in range(2, int(labels.max()) + 1):
        index = np.nonzero(labels == k)[0]
        if len(index) == 0 or len(index) > options.enclosed_share * carcass.sum():
            continue
        inside = body.contains(cloud[index], tol=options.enclosed_margin_voxels * voxel)
        if inside.mean() >= options.enclosed_inside:
            out[index] = 1
            moved.append({"part": k, "points": len(index), "enclosed": True})
    return numbered_by_size(out), moved
