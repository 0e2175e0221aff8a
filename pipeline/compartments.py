"""The compartment seen past a swung-open door, and pieces of the carcass cut out as parts of
their own, go back to the carcass, an open panel's points in other labels go to it, and what
of the carcass's label stands out past its walls goes to the part it hangs on, and a
drawer's body cut from its pulled-out front joins it again, a door's outer face and liner
in two labels are one part, the compartment past a door swung square goes back, a drawer
left in the carcass's label is found beside one pulled out as far, a label holding two
drawers pulled out by different lengths is split, so is one holding two panels swung
apart, so is one holding a drawer and a door swung square beside it, a body cut
across its length is one again, a label inside two stacked drawers goes to both and a
piece with no front of its own in a drawer's outline goes back, and a body in pieces under a
lid that is the largest label is one again: repairs of a part segmentation by what a carcass is, their
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
from .isolate import views_up
from .obb import OBB, part_obb
from .ransac import fit_plane
from .segment.prompting import Segmentation, label_views, numbered_by_size


@dataclass(frozen=True)
class CompartmentOptions:
    """Tuned on procedural dev objects (seeds disjoint from training and the test set)."""

    panel_min_angle: float = 10.0  # deg: a part whose main plane is turned this far from
    panel_fraction: float = 0.3  # the carcass's axes (and holds this share of its points,
    panel_voxels: float = 1.5  # within this many spacings) is a door swung open; its points
    behind_voxels: float = 3.0  # farther than this from that plane, inside the carcass's box,
    # are the compartment seen through the opening and go back to the carcass (so does a
    # part inside the box whose front lies this far behind the faces open parts stand out past)
    panel_normal_deg: float = 20.0  # a plane counts as a panel by its points whose measured
    # normals lie within this of its own (RANSAC also fits planes across a box's edges)
    panel_link_voxels: float = 2.5  # other labels' points on an open panel's plane, joined
    # to it through points this close, are the panel's (the strip beside a flap's hinge) ...
    claim_share: float = 0.1  # ... when they are at least this share of its plane's points
    claim_most: float = 0.5  # ... and, from another moving part, at most this share of its
    # label (more is a panel of its own beside it: two doors on one hinge line swung to
    # within a few degrees of each other lie on one plane)
    enclosed_share: float = 0.03  # a part of at most this share of the carcass's points ...
    enclosed_inside: float = 0.98  # ... with this share of them inside the carcass's box ...
    enclosed_margin_voxels: float = 1.0  # ... (grown by this many spacings) is the carcass's
    enclosed_thick: float = 0.5  # so is a larger one wholly inside spanning at least this
    # share of the carcass's box along each of its axes (no door or drawer front is) ...
    thick_inside: float = 0.9  # ... with this share of its points in the box (true moving
    # parts seen ajar from a ring have at most two thirds of theirs in it)
    wall_margin_voxels: float = 1.0  # the carcass's points this far past its walls stand out
    nested_share: float = 0.9  # a moving part with this share of its points in a larger
    nested_margin_voxels: float = 2.0  # one's box (grown by this), standing out of the
    # carcass, is a piece of it (a drawer's side cut from its front)
    front_share: float = 0.15  # a label whose fronts (points facing out of the face it
    front_points: int = 30  # stands out past) fall at depths behind_voxels apart, each this
    # share of them and this many, at the face or out of it, with outlines apart on the
    # face, is two parts (two drawers pulled out by different lengths); a drawer left in
    # the carcass's label is found by a front of this many points level with a sibling's
    front_span: float = 0.5  # a sibling's front spans at least this share of the part's
    # front's lesser span on the face both ways (not a rim's edge strip)
    seam_step_voxels: float = 0.5  # two fronts side by side, each flat, at depths this many
    # spacings apart, on either side of a straight seam, are two parts too (two drawers
    # pulled out by lengths a centimetre or two apart)
    shell_span: float = 0.9  # a part standing out whose points past the face span this
    shell_wall_share: float = 0.1  # share of the carcass's box across it both ways, with
    # this share of its points on the box's sides around the face, is the carcass's shell
    beside_inside: float = 0.5  # a door swung square beside a drawer's front in one label
    # stands out of the carcass's box with less than this share of its points in it ...
    beside_reach: float = 0.5  # ... and its panel spans this share of the box's depth out
    # of the face (its width; a strip of the carcass lying across the face does not)
    settle_rounds: int = 3  # return_enclosed again, after the others, until nothing moves
    # (and split_fronts on what it split, until nothing splits)
    panels_apart_deg: float = 20.0  # a label holding two turned panels this far apart ...
    panel_width_voxels: float = 5.0  # ... each this many spacings wide both ways (not a
    # door's edge strip) is two swung panels (two flaps on one rail opened opposite ways)
    handle_facing: float = 0.5  # what stands past a label's front facing out as it does
    # at least this share, is a handle, not a part standing out (return_face_fronts)
    past_walls_share: float = 0.1  # at most this share of the carcass's label lying past a
    # face beyond its walls, where parts stand out, is a part's (more is its own surface,
    # its walls seen short of it: on hand-held phone views 12 % of a fridge's label) ...
    past_walls_held: float = 0.5  # ... a piece of it touching no part is one of its own
    # when at most this share of it touches the carcass (more goes on from the carcass)
    front_cover: float = 0.3  # a front a part in the box shows (return_frontless) is a
    # surface: its label's points at its depth fill at least this share of its outline's
    # cells a spacing wide (a front seen does, 48 % and up on phone LiDAR; the carcass's
    # face frame and shelf edges past a divider are strips: 13 % on a hand-held path)


def carcass_box(points: np.ndarray, voxel: float,
                options: CompartmentOptions = CompartmentOptions()) -> OBB:
    """The carcass's box (:func:`part_obb`) without the stray pieces the masks gave it: its
    points linked (within ``panel_link_voxels`` spacings) into pieces, those with fewer
    points than a row across the box's shortest side (in spacings) left out. Such a piece
    hangs on no carcass surface (the edge of a drawer's front or a handle labelled
    carcass, standing out with the part it belongs to), and the whole box follows its
    outermost points: on a procedural cabinet 11 of 13,186 carcass points, the edge of an
    open drawer's front, stood 16 cm in front of its face, and four drawers in their
    openings read as compartments 7 cm behind that false face (:func:`return_enclosed`).
    A carcass's own surface past its walls (a fridge's back seen edge-on) is linked to
    them and stays."""
    from .segment.pieces import linked_components

    body = part_obb(points)
    row = max(int(2.0 * float(body.extent.min()) / voxel), 1)
    piece = linked_components(points, options.panel_link_voxels * voxel)
    sizes = np.bincount(piece)
    keep = sizes[piece] >= row
    if keep.all() or np.count_nonzero(keep) < 4:
        return body
    return part_obb(points[keep])


def within_walls(body: OBB, points: np.ndarray, normals: np.ndarray, parts: np.ndarray,
                 voxel: float, options: CompartmentOptions = CompartmentOptions()) -> OBB:
    """The carcass's box ``body`` with each face that the carcass's label (``points``, with
    their measured ``normals``) reaches far past its walls, where the moving parts'
    points (``parts``) past the walls outnumber the label's and the label's are at most
    ``past_walls_share`` of it, drawn in to the walls: there the label holds a part's
    points, not the carcass's (:func:`give_past_walls` gives them away; the other rules
    then measure the label's own box, no longer stretched).

    The walls: the label's points facing along one of the box's axes (within
    ``panel_min_angle``), grouped by depth along it (a gap of more than ``behind_voxels``
    spacings parts two groups), each group of at least ``front_points`` and
    ``front_share`` of them, spanning more than ``behind_voxels`` spacings both ways across
    the axis (a carcass's sides, top, back and floor; a front's rim where it is seen
    whole). A face lies more than ``behind_voxels`` spacings past every wall's points (the
    walls' extent, grown by ``wall_margin_voxels`` spacings) only where the label holds
    points that no wall holds: the carcass's own overhang (a table top past its sides, a
    back seen edge-on) is more of the label's than of the parts' there, and stays; a
    drawer pulled out whose points the masks left in the carcass's label lies past the
    face the other parts stand out past. On a hand-held phone-LiDAR path a 7-drawer
    table's label held 270 points of its top drawer and 80 of another, pulled out 27 cm
    past the table's front: the box reached as far, every drawer's label lay inside it,
    no face was open, and four pieces of the carcass kept slides."""
    local = (points - body.center) @ body.R
    square = np.abs(normals @ body.R) >= np.cos(np.radians(options.panel_min_angle))
    walls = carcass_walls(local, square, voxel, options)
    if not walls:
        return body
    behind = options.behind_voxels * voxel
    margin = options.wall_margin_voxels * voxel
    others = (parts - body.center) @ body.R
    low, high = -body.extent.copy(), body.extent.copy()
    for a in range(3):
        for sign in (1, -1):
            # a wall facing out of the face is at it; else the second wall out along it (a
            # part's side lying along one wall stretches that wall alone)
            out = [float(np.max(sign * local[w, a])) for f, w in walls
                   if f == a and np.median(sign * local[w, a]) > 0]
            reach = sorted(float(np.max(sign * local[w, a])) for f, w in walls if f != a)
            if len(reach) > 1:
                out.append(reach[-2])
            face = max(out or reach or [body.extent[a]]) + margin
            if body.extent[a] - face <= behind:
                continue
            past = np.count_nonzero(sign * local[:, a] > face)
            if (past <= options.past_walls_share * len(points)
                    and np.count_nonzero(sign * others[:, a] > face) > past):
                if sign > 0:
                    high[a] = face
                else:
                    low[a] = -face
    if np.array_equal(low, -body.extent) and np.array_equal(high, body.extent):
        return body
    return OBB(body.center + body.R @ ((low + high) / 2), body.R, (high - low) / 2)


def carcass_walls(local: np.ndarray, square: np.ndarray, voxel: float,
                  options: CompartmentOptions = CompartmentOptions(),
                  ) -> list[tuple[int, np.ndarray]]:
    """The carcass's walls (:func:`within_walls`), each as (the axis it faces along, its
    points' indices): its points facing along one of its box's axes (``square``: per point
    and axis), grouped by depth along it (a gap of more than ``behind_voxels`` spacings
    parts two groups), each group of at least ``front_points`` and ``front_share`` of
    them, spanning more than ``behind_voxels`` spacings both ways across the axis.
    ``local``: the points in the box's frame."""
    behind = options.behind_voxels * voxel
    walls = []
    for a in range(3):
        facing = np.nonzero(square[:, a])[0]
        if len(facing) == 0:
            continue
        across = [b for b in range(3) if b != a]
        depth = np.sort(local[facing, a])
        cuts = np.nonzero(np.diff(depth) > behind)[0]
        bounds = np.concatenate([[-np.inf], (depth[cuts] + depth[cuts + 1]) / 2, [np.inf]])
        group = np.searchsorted(bounds, local[facing, a]) - 1
        least = max(options.front_points, options.front_share * len(facing))
        walls += [(a, w) for w in (facing[group == g] for g in range(len(bounds) - 1))
                  if len(w) >= least and np.ptp(local[w][:, across], axis=0).min() > behind]
    return walls


def return_to_carcass(capture: Capture, seg: Segmentation,
                      options: CompartmentOptions = CompartmentOptions()) -> Segmentation:
    """``seg`` with stray stretches of the carcass in moving parts' labels given back,
    drawers left in the carcass's label found, a label holding two swung
    panels split, open panels' points in other labels given to them, then the compartments behind open doors given back to the
    carcass, what of the carcass stands out past its walls given to the parts it touches,
    what of its label lies past the walls where parts stand out given to a part,
    enclosed pieces given back to the carcass, a part lying in another's box or behind its
    front merged into it, a door's two faces merged, the compartment past a door swung
    square given back, parts in the box with no front on the opening and a standing
    label's front level with the face given back, a label with two drawers' fronts split,
    pieces of the
    carcass's shell standing past its box merged into it, and a body in pieces under a lid
    that is the largest label joined (its cloud's labels and every
    view's label image); what moved is in ``details["returned_to_carcass"]``.
    A segmentation without a fused cloud spacing (the capture's own masks) is returned as is."""
    if seg.spacing is None:
        return seg
    measured = [(point_map(f)[0][f.depth > 0], normal_map(f)[f.depth > 0])
                for f in capture.frames]
    normals = axis_mean(seg.points, np.concatenate([p for p, _ in measured]),
                        np.concatenate([n for _, n in measured]))
    labels, stray = return_stray_pieces(seg.points, seg.point_labels, seg.spacing, options,
                                        normals)
    labels, found = find_level_fronts(seg.points, labels, seg.spacing, options, normals)
    found = stray + found
    labels, parted = split_panels(seg.points, labels, seg.spacing, options, normals)
    found += parted
    labels, claimed = claim_panels(seg.points, labels, seg.spacing, options, normals)
    labels, moved = return_compartments(seg.points, labels, seg.spacing, options, normals)
    labels, protruding = give_protrusions(seg.points, labels, seg.spacing, options, normals)
    labels, walled = give_past_walls(seg.points, labels, seg.spacing, options, normals)
    moved = found + claimed + moved + protruding + walled
    labels, enclosed = return_enclosed(seg.points, labels, seg.spacing, options)
    moved += enclosed
    labels, nested = merge_nested(seg.points, labels, seg.spacing, options, normals)
    moved += nested
    labels, faces = merge_faces(seg.points, labels, seg.spacing, options, normals)
    moved += faces
    labels, behind = merge_behind(seg.points, labels, seg.spacing, options, normals)
    moved += behind
    labels, past = return_past_square_panels(seg.points, labels, seg.spacing, options, normals)
    moved += past
    labels, frontless = return_frontless(seg.points, labels, seg.spacing, options, normals)
    moved += frontless
    labels, face = return_face_fronts(seg.points, labels, seg.spacing, options, normals)
    moved += face
    labels, split = split_fronts(seg.points, labels, seg.spacing, options, normals)
    moved += split
    labels, shell = merge_shell(seg.points, labels, seg.spacing, options, normals)
    moved += shell
    labels, seams = return_seam_strips(seg.points, labels, seg.spacing, options)
    moved += seams
    labels, pieces = return_frontless_pieces(seg.points, labels, seg.spacing, options, normals)
    moved += pieces
    labels, body = join_body_under_lid(seg.points, labels, seg.spacing, options, normals,
                                       views_up(capture.frames))
    moved += body
    labels, settled = settle(seg.points, labels, seg.spacing, options)
    moved += settled
    if not moved:  # the labels stand (already numbered by size): no views to redo
        return replace(seg, details={**seg.details, "returned_to_carcass": []})
    return replace(seg, labels=label_views(capture, seg.points, labels),
                   n_parts=int(labels.max()), point_labels=labels,
                   details={**seg.details, "parts": int(labels.max()),
                            "returned_to_carcass": moved})


def return_stray_pieces(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                        options: CompartmentOptions = CompartmentOptions(),
                        normals: np.ndarray | None = None) -> tuple[np.ndarray, list[dict]]:
    """A piece of a moving part's label lying apart from the label's main piece, in the
    carcass's box and apart from the main piece's outline seen along each of the box's axes,
    goes to the label it touches most: a stretch of the carcass (a table's leg, a rail) the
    masks gave the part.

    Pieces: points linked within ``panel_link_voxels`` spacings; the main piece the
    largest; a stray one at least ``front_points`` points, at most ``claim_most`` of the
    main piece, more than ``behind_voxels`` spacings from it, ``enclosed_inside`` of it in
    the carcass's box (grown by ``enclosed_margin_voxels`` spacings), and seen along every
    axis of the box apart from the main piece (no more than ``1 - nested_share`` of it
    within ``nested_margin_voxels`` spacings of its points, as :func:`_apart` judges
    fronts). On a hand-held path a table's drawer label held
    the table's back leg (164 points, 64 cm behind the drawer, touching the carcass at its
    top only: too little for :func:`pipeline.segment.pieces.reassign_detached`), its box
    spanned the table's depth and the drawer's slide read 90 degrees off. A part's own
    pieces overlap its outline seen along one axis: a drawer's back panel cut from its
    front seen along the slide, a door's handle seen across the door, a panel cut in two by
    an occluder seen along the cut (both halves span the same stretch of its other side);
    a procedural cabinet's drawer's own 334-point piece, 83 % within its front's outline
    seen along one axis, went to the carcass while the rule asked only that it not lie
    wholly within (90 %), and the drawer's third label, no longer in its box, kept a joint.
    Returns the labels, renumbered by size, and what moved."""
    from scipy.spatial import cKDTree

    from .segment.pieces import linked_components

    out = labels.copy()
    moved: list[dict] = []
    if labels.max() < 2 or np.count_nonzero(labels == 1) < 4:
        return out, moved
    body = carcass_box(cloud[labels == 1], voxel, options)
    local = (cloud - body.center) @ body.R
    link = options.panel_link_voxels * voxel
    margin = options.nested_margin_voxels * voxel
    for k in range(2, int(labels.max()) + 1):
        index = np.nonzero(labels == k)[0]
        if len(index) < 2 * options.front_points:
            continue
        piece = linked_components(cloud[index], link)
        sizes = np.bincount(piece)
        main = int(np.argmax(sizes))
        own = index[piece == main]
        near_main = cKDTree(cloud[own])
        for p in np.nonzero((sizes >= options.front_points)
                            & (sizes <= options.claim_most * sizes[main]))[0]:
            members = index[piece == p]
            if (near_main.query(cloud[members])[0].min() <= options.behind_voxels * voxel
                    or body.contains(cloud[members], tol=options.enclosed_margin_voxels
                                     * voxel).mean() < options.enclosed_inside):
                continue
            seen = [[b for b in range(3) if b != a] for a in range(3)]
            if any(_share_within(local[members][:, ab], local[own][:, ab], margin)
                   > 1.0 - options.nested_share for ab in seen):
                continue  # not apart from the main piece's outline along one axis: its own
            others = np.nonzero(out != k)[0]
            touching = others[np.unique(np.concatenate(cKDTree(cloud[others]).query_ball_point(
                cloud[members], link)).astype(int))] if len(others) else others
            if len(touching) == 0:
                continue
            to = int(np.bincount(out[touching]).argmax())
            out[members] = to
            moved.append({"part": k, "points": len(members), "stray_to": to})
    return numbered_by_size(out), moved


def _share_within(points: np.ndarray, outline: np.ndarray, margin: float) -> float:
    """The share of ``points`` within ``margin`` of ``outline``'s points (both seen in the
    same two coordinates)."""
    from scipy.spatial import cKDTree

    return float(np.isfinite(cKDTree(outline).query(points, distance_upper_bound=margin)[0])
                 .mean())


def settle(cloud: np.ndarray, labels: np.ndarray, voxel: float,
           options: CompartmentOptions = CompartmentOptions(),
           ) -> tuple[np.ndarray, list[dict]]:
    """:func:`return_enclosed` again once the other rules have run, up to
    ``settle_rounds`` times, until it moves nothing, taking back only parts whose front
    lies deep behind the open faces (``deep_m``).

    It measures against what the other rules left: the carcass's box and the faces parts
    stand out past. A label merged or claimed later changes them, and a patch the first
    pass had no reason to give back is then plainly the carcass's: on the phone-LiDAR ring
    of PartNet-Mobility dev, a table's two patches of 420 and 111 points deep inside its
    carcass and a refrigerator's patch 0.58 m behind its opening kept joints of their own.
    The first pass's other reasons are not taken again: after the merges a small drawer
    seen shut lies wholly in the box too, and one whose label holds a few strays across the
    table spans it (a table's, 359 points, 10 % strays, ``small`` and ``thick`` on the
    clean ring: its joint was lost). Only merges, so the rounds end. The merging rules are
    not run again: a second round of :func:`merge_nested` and :func:`merge_behind` joined
    real parts (dev's phone ring, 4-5 parts: type accuracy 0.78 -> 0.50; its clean ring,
    6-15 parts: 1.00 -> 0.92)."""
    moved: list[dict] = []
    for _ in range(options.settle_rounds):
        labels, enclosed = return_enclosed(cloud, labels, voxel, options,
                                           evidence=("deep_m",))
        if not enclosed:
            break
        moved += enclosed
    return labels, moved


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
    box are square to them. So for each part whose main plane (RANSAC,
    :mod:`pipeline.ransac`) holds enough of its points and is turned at least
    ``panel_min_angle`` from every axis of the carcass's box, the points well off that plane
    and inside the carcass's box are handed to the carcass. Drawers and closed doors are
    left alone (no turned panel); a door opened
    past ~80 degrees is too (its panel is square to the carcass again). With the points'
    measured ``normals`` (:func:`pipeline.fuse.axis_mean`), only the plane's points that
    face along it count: RANSAC also fits planes that cut across a box's edges (on the demo
    capture a drawer's got one, turned 13 degrees, and lost its front to the carcass).
    A compartment lies within the carcass's walls (:func:`within_walls`, with the
    ``normals``): what of those points lies past them, where the carcass's label stretches
    its box out past its walls, is a part standing out behind the door's swing, and becomes
    a part of its own where at least ``front_points`` of it face along the box's axes (on
    a hand-held path a cabinet's inner drawer pulled 14 cm out behind a door swung 21
    degrees: the door's label held its front, the carcass's label a strip of the door 23 cm
    past the front, and the drawer went to the carcass whole).
    Returns the labels, renumbered by size, and what was moved, per part."""
    from scipy.spatial import cKDTree

    out = labels.copy()
    moved = []
    if labels.max() < 2 or np.count_nonzero(labels == 1) < 4:
        return out, moved
    body = carcass_box(cloud[labels == 1], voxel, options)
    carcass = labels == 1
    walls = body if normals is None else \
        within_walls(body, cloud[carcass], normals[carcass], cloud[labels > 1], voxel, options)
    square_to_box = None if normals is None else np.any(
        np.abs(normals @ body.R) >= np.cos(np.radians(options.panel_min_angle)), axis=1)
    top = int(labels.max())
    for k in range(2, int(labels.max()) + 1):
        index = np.nonzero(labels == k)[0]
        panel = turned_panel(cloud[index], body, voxel, options,
                             None if normals is None else normals[index])
        if panel is None:
            continue
        normal, offset, inliers, turn = panel
        pts = cloud[index]
        off_panel = np.abs(pts @ normal + offset) > options.behind_voxels * voxel
        if normals is not None:  # near the hinge the compartment lies close to the plane:
            # what faces along the carcass and not along the panel is the carcass's, unless
            # it touches the panel's own plane points (the panel's edges, which face so too)
            along, square = _facing(normals[index], normal, body)
            tight = np.cos(np.radians(options.panel_normal_deg))
            link = options.panel_link_voxels * voxel  # beyond it the query answers inf
            apart = np.isinf(cKDTree(pts[inliers]).query(pts, distance_upper_bound=link)[0])
            off_panel |= (square >= tight) & (along < tight) & apart
        back = off_panel & body.contains(pts, tol=voxel)
        # past the walls: no compartment, a part standing out behind the door's swing
        past = back & ~walls.contains(pts, tol=voxel)
        if (square_to_box is not None and np.count_nonzero(past & square_to_box[index])
                >= options.front_points):
            top += 1
            out[index[past]] = top
            back &= ~past
            moved.append({"part": top, "points": int(past.sum()), "past_walls_of": k})
        ahead = off_panel & ~body.contains(pts, tol=voxel)
        if np.count_nonzero(ahead) >= options.front_points:
            held = _standing_out(pts, (pts - body.center) @ body.R, ahead, back, body.extent,
                                 voxel, options)
            if held.any():
                top += 1
                out[index[held]] = top
                back &= ~held
                moved.append({"part": top, "points": int(held.sum()), "standing_out_of": k})
        if back.any():
            out[index[back]] = 1
            moved.append({"part": k, "points": int(back.sum()), "panel_turn_deg": round(turn, 1)})
    return numbered_by_size(out), moved


def _standing_out(pts: np.ndarray, local: np.ndarray, ahead: np.ndarray, back: np.ndarray,
                  extent: np.ndarray, voxel: float,
                  options: CompartmentOptions = CompartmentOptions()) -> np.ndarray:
    """Of a swung door's off-panel points (:func:`return_compartments`), a part standing out
    of the carcass's box behind the door's swing and reaching into it: the points past the
    box (``ahead``) with those inside it going back (``back``) that lie within their
    outline seen along the axis they stand out along (within ``nested_margin_voxels``
    spacings), linked into pieces (``panel_link_voxels``); a piece holding at least
    ``front_points`` points on either side of the face and reaching into the box at least
    ``behind_voxels`` spacings and as deep as it stands out past the face is such a part:
    a drawer pulled out behind the door, its front past the face, its body running back
    into the carcass (on the phone-LiDAR ring a cabinet's drawer pulled 16 cm out behind a
    door swung 21 degrees reached 30 cm in; its front stayed with the door, its body went
    to the carcass, and the drawer was lost). A door's own bins or shelves, swung with it,
    stand out far and touch the box only beside the hinge (a refrigerator door's, 4 to 6
    cm in); a handle or a fringe of smeared depth past the face reaches nothing inside
    within its outline.
    ``local``: ``pts`` in the box's frame (``extent`` its half sizes). Returns a mask over
    ``pts``."""
    from scipy.spatial import cKDTree

    from .segment.pieces import linked_components

    axis = int(np.bincount(np.argmax(np.abs(local[ahead]) - extent, axis=1), minlength=3)
               .argmax())
    across = [b for b in range(3) if b != axis]
    outline = cKDTree(local[ahead][:, across])
    within = back & np.isfinite(outline.query(local[:, across], distance_upper_bound=options
                                              .nested_margin_voxels * voxel)[0])
    index = np.nonzero(ahead | within)[0]
    piece = linked_components(pts[index], options.panel_link_voxels * voxel)
    sign = 1.0 if np.median(local[ahead, axis]) > 0 else -1.0
    held = np.zeros(len(pts), bool)
    for p in range(int(piece.max()) + 1):
        members = index[piece == p]
        depth = sign * local[members, axis] - extent[axis]  # past the face: > 0
        if (min(np.count_nonzero(ahead[members]),
                np.count_nonzero(within[members])) >= options.front_points
                and -depth.min() >= max(depth.max(), options.behind_voxels * voxel)):
            held[members] = True
    return held


def split_panels(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                 options: CompartmentOptions = CompartmentOptions(),
                 normals: np.ndarray | None = None) -> tuple[np.ndarray, list[dict]]:
    """A moving label holding two swung panels turned apart is two parts: every point to the
    panel whose plane points lie nearest it.

    A label whose main plane is a turned panel (:func:`turned_panel`), and whose points off
    that plane hold a second turned panel at least ``panels_apart_deg`` from the first,
    each panel at least ``panel_width_voxels`` spacings wide both ways across its plane.
    On noisy depth the mask network can take two neighbouring panels for one part: on the
    room demo capture (hand-held, phone LiDAR) the noise-trained network gave two flaps on
    one rail, swung opposite ways about 20 degrees each, one label (1,577 and 1,452 of its
    3,319 points); :func:`return_compartments` then handed the second flap to the carcass
    as the compartment behind the first. One panel's back is parallel to its front, its
    edges are strips a thickness wide, and what lies behind it is square to the carcass,
    so none of them is a second panel. Nothing splits where the largest label is itself one
    panel (:func:`_one_panel`): a box's lid swung open can be the largest label, and
    measured against its box every wall of the body is a turned panel (on PartNet-Mobility
    dev's phone-LiDAR ring the box 100189's body label holding two walls was split, 5
    movable joints for 1). Runs before the rules that read a label's panel. Needs the
    measured ``normals``. Returns the labels, renumbered by size, and what split."""
    out = labels.copy()
    moved: list[dict] = []
    if normals is None or labels.max() < 2 or np.count_nonzero(labels == 1) < 4:
        return out, moved
    carcass = np.nonzero(labels == 1)[0]
    if _one_panel(cloud[carcass], normals[carcass], voxel, options):
        return out, moved  # a lid, not a carcass: every wall of the body is turned from it
    body = carcass_box(cloud[carcass], voxel, options)
    for k in range(2, int(labels.max()) + 1):
        index = np.nonzero(labels == k)[0]
        first = turned_panel(cloud[index], body, voxel, options, normals[index])
        if first is None or not _wide_panel(cloud[index[first[2]]], first[0], voxel, options):
            continue
        off = np.nonzero(np.abs(cloud[index] @ first[0] + first[1])
                         > options.panel_voxels * voxel)[0]
        second = turned_panel(cloud[index[off]], body, voxel, options, normals[index[off]])
        if second is None:
            continue
        apart = float(np.degrees(np.arccos(min(1.0, abs(float(first[0] @ second[0]))))))
        plane = index[off[second[2]]]
        if apart < options.panels_apart_deg or not _wide_panel(cloud[plane], second[0],
                                                               voxel, options):
            continue
        planes = _two_planes(cloud[index], [first[:2], second[:2]],
                             options.panel_voxels * voxel)
        apart = float(np.degrees(np.arccos(min(1.0, abs(float(planes[0][0] @ planes[1][0]))))))
        new = index[_nearer_panel_second(cloud[index], planes, options.panel_voxels * voxel)]
        out[new] = int(out.max()) + 1
        moved.append({"part": k, "points": len(new), "panels_apart_deg": round(apart, 1)})
    return numbered_by_size(out), moved


def _one_panel(points: np.ndarray, normals: np.ndarray, voxel: float,
               options: CompartmentOptions) -> bool:
    """Whether most of ``points`` lie on one plane (within ``panel_voxels`` spacings, their
    measured ``normals`` facing along it): a panel, not a carcass's box of walls (on
    PartNet-Mobility dev's phone-LiDAR ring a box's lid: 66 % of its label; the room demo's
    carcass 14 %, a refrigerator's 13 %)."""
    if len(points) < 30:
        return False
    normal, _, inliers = fit_plane(points, options.panel_voxels * voxel, 300,
                                   np.random.default_rng(0))
    facing = np.abs(normals[inliers] @ normal) >= np.cos(np.radians(options.panel_normal_deg))
    return bool(np.count_nonzero(facing) > 0.5 * len(points))


def _nearer_second(points: np.ndarray, planes) -> np.ndarray:
    """Whether each point lies nearer the second of two planes ((normal, offset) pairs)."""
    (n1, d1), (n2, d2) = planes
    return np.abs(points @ n2 + d2) < np.abs(points @ n1 + d1)


def _nearer_panel_second(points: np.ndarray, planes, tolerance: float) -> np.ndarray:
    """Whether each point lies nearer the second panel's points than the first's: a panel's
    points lie within ``tolerance`` of its plane and nearer it than the other's (near where
    they meet, both planes pass close; off both, what is nearest on the surfaces decides,
    not the planes' extensions)."""
    from scipy.spatial import cKDTree

    second = _nearer_second(points, planes)
    near = [np.abs(points @ n + d) <= tolerance for n, d in planes]
    on = [near[0] & ~second, near[1] & second]
    if not on[0].any() or not on[1].any():
        return second
    d0, d1 = (cKDTree(points[mine]).query(points)[0] for mine in on)
    return d1 < d0


def _two_planes(points: np.ndarray, planes, tolerance: float, rounds: int = 2):
    """Two planes refitted to the points nearer each, within ``tolerance`` of it (RANSAC's
    first plane also holds the other panel's strip along the line where they meet, which
    tilts it toward the other)."""
    for _ in range(rounds):
        second = _nearer_second(points, planes)
        refit = []
        for (normal, offset), mine in zip(planes, (~second, second), strict=True):
            near = points[mine & (np.abs(points @ normal + offset) <= tolerance)]
            if len(near) < 3:
                return planes
            centre = near.mean(axis=0)
            normal = np.linalg.svd(near - centre, full_matrices=False)[2][-1]
            refit.append((normal, float(-normal @ centre)))
        planes = refit
    return planes


def _wide_panel(points: np.ndarray, normal: np.ndarray, voxel: float,
                options: CompartmentOptions) -> bool:
    """Whether a plane's points span ``panel_width_voxels`` spacings both ways across it
    (a panel, not an edge strip), by their 5-95 % spread along its two main directions."""
    centred = points - points.mean(axis=0)
    centred = centred - np.outer(centred @ normal, normal)
    directions = np.linalg.svd(centred, full_matrices=False)[2][:2]
    lo, hi = np.quantile(centred @ directions.T, [0.05, 0.95], axis=0)
    return bool(np.all(hi - lo >= options.panel_width_voxels * voxel))


def claim_panels(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                 options: CompartmentOptions = CompartmentOptions(),
                 normals: np.ndarray | None = None) -> tuple[np.ndarray, list[dict]]:
    """Points of a swung-open panel that other labels took go to the panel's part: points on
    that part's turned plane, facing along it more than along any of the carcass's axes,
    joined to the part's own plane points through such points, and at least
    ``claim_share`` as many as those (fewer are the blurred normals at a corner of the
    carcass). Points on their own label's turned plane stay.

    The reverse of :func:`return_compartments`. A flap swung open and seen nearly edge-on
    loses the strip beside its hinge to the carcass (on the demo capture 257 of a top
    flap's 788 points: the carcass's box grew 18 cm forward, and two flaps that shut
    against that false face closed onto one place); on a noisy capture two flaps hinged on
    one rail shared a label while the rest of one had a label of its own (the room demo
    capture). A carcass is built square, so none of its own surface lies in a plane turned
    from its axes and faces along it; a neighbouring panel turned another way faces
    elsewhere, and a panel swung to within a few degrees of it keeps most of its label
    (``claim_most``: a procedural cabinet's two doors on one hinge line, open 76 and 83
    degrees, the nearer square of them no turned panel of its own, lost 726 of 764 points).
    Needs the measured ``normals``: without them a turned plane cuts the carcass's walls
    along lines that would be taken too. Returns the labels, renumbered by size, and what
    moved, per part and source label."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    out = labels.copy()
    moved = []
    if normals is None or labels.max() < 2 or np.count_nonzero(labels == 1) < 4:
        return out, moved
    body = carcass_box(cloud[labels == 1], voxel, options)
    panels, own = {}, np.zeros(len(cloud), dtype=bool)  # own: on its own label's open panel
    for k in range(2, int(labels.max()) + 1):
        index = np.nonzero(labels == k)[0]
        panel = turned_panel(cloud[index], body, voxel, options, normals[index])
        if panel is not None:
            panels[k] = (index, *panel)
            own[index[panel[2]]] = True
    for k, (index, normal, offset, inliers, turn) in panels.items():
        candidates = np.nonzero((out != k) & ~own)[0]
        # on the panel (return_compartments' complement: within behind_voxels of its plane),
        # facing along it, and closer to it than to any of the carcass's own axes
        on_plane = np.abs(cloud[candidates] @ normal + offset) <= options.behind_voxels * voxel
        along, square = _facing(normals[candidates], normal, body)
        facing = (along >= np.cos(np.radians(options.panel_normal_deg))) & (along > square)
        candidates = candidates[on_plane & facing]
        if len(candidates) == 0:
            continue
        # joined to the part's panel through the candidates (points this close are one surface)
        nodes = np.concatenate([index[inliers], candidates])
        pairs = cKDTree(cloud[nodes]).query_pairs(options.panel_link_voxels * voxel,
                                                  output_type="ndarray")
        graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                           shape=(len(nodes), len(nodes)))
        component = connected_components(graph, directed=False)[1]
        joined = np.isin(component[len(inliers):], component[:len(inliers)])
        for source in np.unique(out[candidates[joined]]):
            taken = candidates[joined][out[candidates[joined]] == source]
            if len(taken) < options.claim_share * len(inliers):  # a corner's blurred normals
                continue
            if source != 1 and len(taken) > options.claim_most * np.count_nonzero(
                    labels == source):  # a panel of its own beside this one
                continue
            out[taken] = k
            moved.append({"part": k, "points": len(taken), "claimed_from": int(source),
                          "panel_turn_deg": round(turn, 1)})
    return numbered_by_size(out), moved


def _facing(normals: np.ndarray, panel: np.ndarray, body) -> tuple[np.ndarray, np.ndarray]:
    """How far each measured normal faces along a turned panel's normal ``panel`` and along
    the nearest of the carcass's axes (normals the views disagree on are shortened by
    :func:`pipeline.fuse.axis_mean`, and so face along neither). Returns
    (|n . panel|, the largest |n . axis|)."""
    return np.abs(normals @ panel), np.abs(normals @ body.R).max(axis=1)


def turned_panel(points: np.ndarray, body, voxel: float,
                 options: CompartmentOptions = CompartmentOptions(),
                 normals: np.ndarray | None = None,
                 ) -> tuple[np.ndarray, float, np.ndarray, float] | None:
    """A part's main plane when it is a panel turned away from the carcass's box ``body``
    (a door or flap swung open): RANSAC's plane (:func:`pipeline.ransac.fit_plane`) holding
    ``panel_fraction`` of ``points`` within ``panel_voxels`` spacings, counting with measured
    ``normals`` only the points that face along it, turned at least ``panel_min_angle``
    from every axis of
    ``body``. Returns (unit normal, offset: n . x + offset = 0 on the plane, the inliers'
    indices, the turn in degrees), or None."""
    if len(points) < 30:
        return None
    # our own seeded RANSAC: open3d's segment_plane gave other planes run to run, seeded
    normal, offset, inliers = fit_plane(points, options.panel_voxels * voxel, 300,
                                        np.random.default_rng(0))
    if not normal.any():
        return None
    if normals is not None:  # the plane's points that face along it
        facing = np.abs(normals[inliers] @ normal)
        inliers = inliers[facing >= np.cos(np.radians(options.panel_normal_deg))]
    if len(inliers) < options.panel_fraction * len(points):
        return None
    turn = float(np.degrees(np.arccos(min(1.0, float(np.max(np.abs(body.R.T @ normal)))))))
    if turn < options.panel_min_angle:
        return None
    return normal, offset, inliers, turn


def give_protrusions(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                     options: CompartmentOptions = CompartmentOptions(),
                     normals: np.ndarray | None = None) -> tuple[np.ndarray, list[dict]]:
    """The carcass's points standing out past its walls go to the moving part they hang on:
    a handle, or a swung panel's side edge, that the masks gave to the carcass.

    The carcass's walls are its points whose measured normals face along one of its box's
    axes (within ``panel_min_angle``, square as a carcass is built); along each axis its
    extent is that of the points facing along it, grown by ``wall_margin_voxels``
    spacings; a side past which more than ``enclosed_share`` of the carcass's points lie is
    not bounded (its bottom unseen and a shelf the lowest surface facing down, an open
    front seen without its rim). Past it, a piece (points joined through points this
    close: ``panel_link_voxels`` spacings) of at most that share, more of whose points
    touch one moving part than touch the carcass inside its walls, is that part's. On the
    demo capture 128 points of three panels' handles and a top flap's side edge (facing
    along the hinge, so no panel claims it) stood up to 18 cm in front of the carcass; its
    box grew as far, and the flap, shut against that false face, read an opening of 0.001
    rad for 0.98. A carcass's own
    overhang (a table top over its drawers) joins its walls along its whole inner edge and
    stays; so does a piece hanging on a part thick inside the box (:func:`enclosed_parts`:
    a piece of the carcass in a label of its own, which :func:`return_enclosed` gives
    back): on a hand-held path a cabinet's bottom edge, 202 points, went to the carcass's
    other half, which then stood out of the shrunk box and kept a joint. Only the thick
    kind: the others read the open faces off the box that the protruding pieces still
    stretch (on a phone-LiDAR ring a table's drawer read as deep behind its bottom face
    until 210 such points left the box). Needs the measured ``normals``. Returns the
    labels, renumbered by size, and what moved, per piece."""
    from scipy.spatial import cKDTree

    from .segment.pieces import linked_components

    out = labels.copy()
    moved: list[dict] = []
    carcass = labels == 1
    if normals is None or labels.max() < 2 or np.count_nonzero(carcass) < 4:
        return out, moved
    body = carcass_box(cloud[carcass], voxel, options)
    local = (cloud - body.center) @ body.R
    square = np.abs(normals @ body.R) >= np.cos(np.radians(options.panel_min_angle))
    margin = options.wall_margin_voxels * voxel
    largest = options.enclosed_share * np.count_nonzero(carcass)
    past = np.zeros(len(cloud), dtype=bool)
    for k in range(3):
        wall = local[carcass & square[:, k], k]
        if len(wall) == 0:
            continue
        for beyond in (local[:, k] > wall.max() + margin, local[:, k] < wall.min() - margin):
            # more of the carcass than that past its walls: they do not close that side
            # (its bottom unseen, a shelf the outermost wall facing that way)
            if np.count_nonzero(carcass & beyond) <= largest:
                past |= beyond
    standing = np.nonzero(carcass & past)[0]
    if len(standing) == 0:
        return out, moved
    link = options.panel_link_voxels * voxel
    piece = linked_components(cloud[standing], link)
    # a part spanning the carcass's box every way is a piece of it, nothing to hang on
    # (the other kinds read open faces off the box these pieces still stretch)
    shell = [k for k, kinds in enclosed_parts(cloud, labels, voxel, options, body).items()
             if "thick" in kinds]
    inside = cKDTree(cloud[(carcass | np.isin(labels, shell)) & ~past])
    parts = {k: cKDTree(cloud[labels == k]) for k in range(2, int(labels.max()) + 1)
             if np.any(labels == k) and k not in shell}

    def share_touching(tree, points: np.ndarray) -> float:
        return float(np.isfinite(tree.query(points, distance_upper_bound=link)[0]).mean())

    for p in range(int(piece.max()) + 1):
        members = standing[piece == p]
        if len(members) > largest:
            continue
        touching = {k: share_touching(tree, cloud[members]) for k, tree in parts.items()}
        to = max(touching, key=touching.get, default=None)
        if to is not None and touching[to] > share_touching(inside, cloud[members]):
            out[members] = to
            moved.append({"part": to, "points": len(members), "protruding": True})
    return numbered_by_size(out), moved


def give_past_walls(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                    options: CompartmentOptions = CompartmentOptions(),
                    normals: np.ndarray | None = None) -> tuple[np.ndarray, list[dict]]:
    """The carcass's points past a face of its box that :func:`within_walls` drew in to its
    walls are a part's: each piece of them (points joined through points this close:
    ``panel_link_voxels`` spacings) goes to the moving part more of its points touch than
    touch the carcass inside the face, else becomes a part of its own when no more than
    ``past_walls_held`` of it touches the carcass (more goes on from the carcass's own
    surface: on the phone-LiDAR ring a cabinet's side, its wall not found, 435 points, 91 %
    touching) and it holds at least ``enclosed_share`` of the carcass's points (no smaller
    than a part :func:`return_enclosed` leaves alone: on hand-held views a cabinet's top
    edge seen past walls seen short, 38 points); others stay; what lies on a wall's plane (:func:`carcass_walls`,
    within ``panel_voxels`` spacings, facing along it) stays: a table top overhanging the
    front past its sides. Left in the carcass's label they stretch the box the
    joint predictor reads the carcass by, past the drawers pulled out, and it read a
    7-drawer table's slides across the drawers (all 90 degrees off on a hand-held
    phone-LiDAR path). Needs the measured ``normals``. Returns the labels, renumbered by
    size, and what moved, per piece."""
    from scipy.spatial import cKDTree

    from .segment.pieces import linked_components

    out = labels.copy()
    moved: list[dict] = []
    carcass = labels == 1
    if normals is None or labels.max() < 2 or np.count_nonzero(carcass) < 4:
        return out, moved
    whole = carcass_box(cloud[carcass], voxel, options)
    body = within_walls(whole, cloud[carcass], normals[carcass], cloud[labels > 1], voxel,
                        options)
    if body is whole:
        return out, moved
    # past a drawn-in face, not the strays carcass_box leaves out, nor a wall's own plane
    # going on past it (a table top overhanging its front)
    past = carcass & ~body.contains(cloud) & whole.contains(cloud, tol=voxel)
    local = (cloud - whole.center) @ whole.R
    square = np.abs(normals @ whole.R) >= np.cos(np.radians(options.panel_min_angle))
    index = np.nonzero(carcass)[0]
    for a, wall in carcass_walls(local[index], square[index], voxel, options):
        past &= ~(square[:, a] & (np.abs(local[:, a] - np.median(local[index[wall], a]))
                                  <= options.panel_voxels * voxel))
    standing = np.nonzero(past)[0]
    if len(standing) == 0:
        return out, moved
    link = options.panel_link_voxels * voxel
    piece = linked_components(cloud[standing], link)
    inside = cKDTree(cloud[carcass & ~past])
    parts = {k: cKDTree(cloud[labels == k]) for k in range(2, int(labels.max()) + 1)
             if np.any(labels == k)}

    def share_touching(tree, points: np.ndarray) -> float:
        return float(np.isfinite(tree.query(points, distance_upper_bound=link)[0]).mean())

    top = int(labels.max())
    for p in range(int(piece.max()) + 1):
        members = standing[piece == p]
        touching = {k: share_touching(tree, cloud[members]) for k, tree in parts.items()}
        to = max(touching, key=touching.get, default=None)
        held = share_touching(inside, cloud[members])
        if to is not None and touching[to] > held:
            out[members] = to
            moved.append({"part": to, "points": len(members), "past_walls": True})
        elif (held <= options.past_walls_held
              and len(members) >= options.enclosed_share * np.count_nonzero(carcass)):
            top += 1
            out[members] = top
            moved.append({"part": top, "points": len(members), "past_walls": True,
                          "own": True})
    return numbered_by_size(out), moved


def return_enclosed(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                    options: CompartmentOptions = CompartmentOptions(),
                    evidence: tuple[str, ...] | None = None,
                    ) -> tuple[np.ndarray, list[dict]]:
    """Small parts lying wholly inside the carcass's box (label 1, the largest part) go back
    to it: pieces of its shell that the masks cut out as parts of their own.

    A part is only seen to move when it is seen out of place: a drawer pulled out stands
    out of the carcass's box, a door swung open leaves it (the pipeline, like the paper's,
    reads joints off an object seen partly open). A patch of the carcass's top or side that
    the mask network, on noisy depth, gave a label of its own lies inside the box, and
    the joint predictor makes a drawer or a door of it (on phone-LiDAR rings of the
    procedural test set, one or two such patches of 1 to 2 % of the carcass's points per
    object, each given a joint). A larger part wholly inside is the carcass's too when it is
    thick along every axis of the carcass's box (``enclosed_thick`` of its extent): a door
    or drawer seen closed shows its front, thin across the box, and seen open it stands out
    of the box, while the mask network on real shapes cuts carcasses in two (one side of a
    cabinet, 20 % of its points, spanning its depth and height) and gives pieces wholly
    inside them labels of their own. So is one whose front lies more than ``behind_voxels``
    spacings behind every face parts stand out past (:func:`open_faces`; the inside of a
    fridge seen past its open door, where a drawer or door seen shut is flush with the
    opening), or that reaches ``enclosed_thick`` of the box's depth behind each of them (no
    front seen shut reaches in so far). A returned part's points outside the box go to the
    part nearest them (given to the carcass, they stretch its box). Other parts of more
    than ``enclosed_share`` of the carcass's points (a whole side wall) are left alone.
    ``evidence``: only parts with one of these kinds go back (:func:`settle`). Returns the
    labels, renumbered by size, and what was moved."""
    out = labels.copy()
    moved = []
    if labels.max() < 2 or np.count_nonzero(labels == 1) < 4:
        return out, moved
    body = carcass_box(cloud[labels == 1], voxel, options)
    margin = options.enclosed_margin_voxels * voxel
    for k, kinds in enclosed_parts(cloud, labels, voxel, options, body).items():
        index = np.nonzero(labels == k)[0]
        if kinds and (evidence is None or any(kind in kinds for kind in evidence)):
            out[index] = 1
            stray = index[~body.contains(cloud[index], tol=margin)]
            if len(stray):  # they would stretch the carcass's box: to the nearest other part
                out[stray] = _nearest_label(cloud, out, stray, index)
            kind = next(name for name in kinds if evidence is None or name in evidence)
            moved.append({"part": k, "points": len(index), "enclosed": True,
                          **({} if kind == "small" else {kind: kinds[kind]})})
    return numbered_by_size(out), moved


def enclosed_parts(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                   options: CompartmentOptions = CompartmentOptions(),
                   body: OBB | None = None) -> dict[int, dict]:
    """Each moving part with at least ``thick_inside`` of its points in the carcass's box
    ``body`` (:func:`carcass_box` of label 1 when None), with why it is the carcass's
    (:func:`enclosed_kinds`; empty when no reason holds): what :func:`return_enclosed`
    judges, and :func:`give_protrusions` reads (a piece of the carcass is nothing for the
    carcass's points to hang on)."""
    carcass = labels == 1
    if body is None:
        body = carcass_box(cloud[carcass], voxel, options)
    margin = options.enclosed_margin_voxels * voxel
    local = (cloud - body.center) @ body.R
    parts = [k for k in range(2, int(labels.max()) + 1) if np.any(labels == k)]
    inside = {k: float(body.contains(cloud[labels == k], tol=margin).mean()) for k in parts}
    standing = [k for k in parts if inside[k] < options.enclosed_inside]
    for k in standing:
        if inside[k] >= options.thick_inside:
            inside[k] += _held_past(cloud, labels, body, margin, k, standing, voxel, options)
    faces = open_faces(local, labels, body.extent, margin,
                       [k for k in parts if inside[k] < options.enclosed_inside])
    return {k: enclosed_kinds(local[labels == k], body.extent, faces, inside[k],
                              int(carcass.sum()), voxel, options)
            for k in parts if inside[k] >= options.thick_inside}


def _held_past(cloud: np.ndarray, labels: np.ndarray, body: OBB, margin: float, k: int,
               standing: list[int], voxel: float, options: CompartmentOptions) -> float:
    """The share of part ``k``'s points that lie out of the carcass's box ``body`` (grown by
    ``margin``) touching another part standing out of it (within ``panel_link_voxels``
    spacings): the masks' border with that part, not ``k`` standing out
    (:func:`enclosed_parts` counts them as inside; :func:`return_enclosed` gives them to
    the part nearest them). On a phone-LiDAR ring a strip of a cabinet's side wall, its
    depth front to back, held 45 points (3 %) of the drawer pulled out beside it, past
    the face the drawer stands out of, and kept a slide of its own."""
    from scipy.spatial import cKDTree

    index = np.nonzero(labels == k)[0]
    out = index[~body.contains(cloud[index], tol=margin)]
    others = np.isin(labels, [j for j in standing if j != k])
    if len(out) == 0 or not others.any():
        return 0.0
    near, _ = cKDTree(cloud[others]).query(cloud[out], distance_upper_bound=options
                                           .panel_link_voxels * voxel)
    return float(np.count_nonzero(np.isfinite(near))) / len(index)


def enclosed_kinds(local: np.ndarray, extent: np.ndarray, faces: list[tuple[int, int]],
                   inside: float, carcass_points: int, voxel: float,
                   options: CompartmentOptions = CompartmentOptions()) -> dict:
    """Why a part lying in the carcass's box is the carcass's (:func:`return_enclosed`), the
    first reason first: ``small``, ``thick``, ``deep_m`` (how far its front lies behind the
    open ``faces``) or ``through``; empty when none holds. ``local``: its points in the box's
    frame; ``extent``: the box's half-lengths; ``inside``: the share of its points in the
    box (below ``enclosed_inside`` only the thick rule, at ``thick_inside``, applies)."""
    kinds: dict = {}
    thick = bool(np.all(np.ptp(local, axis=0) >= options.enclosed_thick * 2 * extent))
    if inside < options.enclosed_inside and not thick:
        return kinds
    if len(local) <= options.enclosed_share * carcass_points:
        kinds["small"] = True
    if thick:
        kinds["thick"] = True
    # how far behind each open face the part's front lies (its points but the strays
    # enclosed_inside leaves out)
    depth = min((float(np.quantile(extent[a] - sign * local[:, a], 1.0 - options.enclosed_inside))
                 for a, sign in faces), default=0.0)
    if depth > options.behind_voxels * voxel:
        kinds["deep_m"] = round(depth, 3)
    # from the open face to the back: no front seen shut reaches so far in
    lo, hi = np.quantile(local, [1.0 - options.enclosed_inside, options.enclosed_inside], axis=0)
    if faces and all(hi[a] - lo[a] >= options.enclosed_thick * 2 * extent[a] for a, _ in faces):
        kinds["through"] = True
    return kinds


def _nearest_label(cloud: np.ndarray, labels: np.ndarray, points: np.ndarray,
                   exclude: np.ndarray) -> np.ndarray:
    """The label of the nearest point to each of ``points`` (indices) not in ``exclude``."""
    from scipy.spatial import cKDTree

    others = np.setdiff1d(np.arange(len(cloud)), exclude)
    return labels[others[cKDTree(cloud[others]).query(cloud[points])[1]]]


def open_faces(local: np.ndarray, labels: np.ndarray, extent: np.ndarray, margin: float,
               standing: list[int]) -> list[tuple[int, int]]:
    """The sides of the carcass's box (axis, sign) that the parts ``standing`` out of it
    stand out past: for each, the side most of its points beyond the box lie past. ``local``:
    every point in the box's frame; ``extent``: its half-lengths."""
    faces = set()
    for k in standing:
        points = local[labels == k]
        beyond = [(np.count_nonzero(sign * points[:, a] > extent[a] + margin), a, sign)
                  for a in range(3) for sign in (1, -1)]
        count, a, sign = max(beyond)
        if count:
            faces.add((a, sign))
    return sorted(faces)


def merge_nested(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                 options: CompartmentOptions = CompartmentOptions(),
                 normals: np.ndarray | None = None) -> tuple[np.ndarray, list[dict]]:
    """A moving part lying in a larger moving part's box is a piece of it, when that one
    stands out of the carcass's box: a drawer pulled out, cut by the masks into its front
    and its side (on a phone-LiDAR ring a 4-part cabinet's drawer came out as a label of
    2,193 of its points and one of 740, its side, wholly inside the first one's box, and
    the side was given a joint of its own). Parts side by side (two doors, stacked drawers)
    do not lie in each other's boxes; a part inside the carcass is left to
    :func:`return_enclosed`. ``nested_share`` of the smaller part's points within the
    larger's box grown by ``nested_margin_voxels`` spacings; standing out: less than
    ``enclosed_inside`` of the larger's points in the carcass's box. A smaller part with a
    front of its own (:func:`_fronts`, on the face the larger stands out past, with the
    measured ``normals``) apart on the face from a front of the larger (:func:`_apart`) is
    no piece of it but a part beside it that the larger's mixed label reaches around (on
    a hand-held path a drawer's own label lay in the box of one holding a door swung
    square and the other drawer); a side or a body cut from its front has no such front.
    Returns the labels, renumbered by size, and what merged."""
    out = labels.copy()
    moved: list[dict] = []
    if labels.max() < 3 or np.count_nonzero(labels == 1) < 4:
        return out, moved
    body = carcass_box(cloud[labels == 1], voxel, options)
    sizes = np.bincount(labels)
    parts = [k for k in np.argsort(sizes, kind="stable") if k >= 2 and sizes[k] >= 4]
    boxes = {k: _box(cloud[labels == k]) for k in parts}
    out_of_place = {k: body.contains(cloud[labels == k], tol=options.enclosed_margin_voxels
                                     * voxel).mean() < options.enclosed_inside for k in parts}
    margin = options.nested_margin_voxels * voxel
    local = (cloud - body.center) @ body.R
    square = None if normals is None else \
        np.abs(normals @ body.R) >= np.cos(np.radians(options.panel_min_angle))
    for i, small in enumerate(parts):
        points = cloud[labels == small]
        for large in parts[i + 1:]:
            if (out_of_place[large] and boxes[large] is not None and sizes[large] > sizes[small]
                    and boxes[large].contains(points, tol=margin).mean() >= options.nested_share):
                into = _front_owner(local, square, labels, parts, small, large, body.extent,
                                    voxel, options)
                if not into:  # a front of its own beside the larger's: a part of its own
                    continue
                if out[labels == into][0] == out[labels == small][0]:
                    break  # the part whose front it continues has already joined it
                out[out == small] = out[labels == into][0]
                moved.append({"part": int(small), "points": int(sizes[small]),
                              "merged_into": int(into)})
                break
    return numbered_by_size(out), moved


def _front_owner(local: np.ndarray, square: np.ndarray | None, labels: np.ndarray,
                 parts: list[int], small: int, large: int, extent: np.ndarray, voxel: float,
                 options: CompartmentOptions) -> int:
    """Which part the part ``small``, lying in the box of the part ``large``, is a piece of
    (:func:`merge_nested`), by their fronts (:func:`_fronts`) on the face ``large`` stands
    out past: ``large``, unless a front of ``small``'s lies apart on the face from one of
    ``large``'s (:func:`_apart`); then the largest other part with a front on that face
    that ``small``'s front is not apart from and lies within ``behind_voxels`` spacings of
    in depth (one front the masks cut in two), or 0 (a part of its own). ``square``: per
    point and axis of the carcass's box, whether its measured normal faces along it (None
    without normals: ``large``)."""
    if square is None:
        return large
    faces = open_faces(local, labels, extent, options.enclosed_margin_voxels * voxel, [large])
    if not faces:
        return large
    a = faces[0][0]
    across = [b for b in range(3) if b != a]
    apart = options.nested_margin_voxels * voxel

    def fronts(k):
        return _fronts(local, square, np.nonzero(labels == k)[0], faces[0], extent, voxel,
                       options)

    own = fronts(small)
    if not any(_apart(local[f][:, across], local[g][:, across], apart, options)
               for f in own for g in fronts(large)):
        return large
    for k in reversed(parts):  # the largest first
        if k in (small, large):
            continue
        if any(not _apart(local[f][:, across], local[g][:, across], apart, options)
               and abs(float(np.median(local[f, a]) - np.median(local[g, a])))
               <= options.behind_voxels * voxel for f in own for g in fronts(k)):
            return k
    return 0


def merge_faces(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                options: CompartmentOptions = CompartmentOptions(),
                normals: np.ndarray | None = None) -> tuple[np.ndarray, list[dict]]:
    """Two turned panels (:func:`turned_panel`) that are one panel's two faces are one
    part: a door seen from outside and from inside, its outer face and its inner liner in
    two labels (a hand-held path walks round a refrigerator's door open 28 degrees: its
    outer face and its liner, 5 cm behind it, each a label and a hinge of their own).
    One panel's faces are parallel (their planes within ``panel_min_angle``), the smaller's
    plane points within the larger's outline on its plane (``nested_share`` of them within
    ``nested_margin_voxels`` spacings of the larger's points, seen across the plane) and its
    plane within the larger's points across it (between their ``1 - enclosed_inside`` and
    ``enclosed_inside`` quantiles, grown by as much: the larger holds the door's bins and
    edges). Two doors on one hinge line swung alike lie in one plane side by side, not
    within each other's outline; double doors swung open turn opposite ways. Needs the
    measured ``normals``. Returns the labels, renumbered by size, and what merged."""
    from scipy.spatial import cKDTree

    out = labels.copy()
    moved: list[dict] = []
    if normals is None or labels.max() < 3 or np.count_nonzero(labels == 1) < 4:
        return out, moved
    body = carcass_box(cloud[labels == 1], voxel, options)
    margin = options.nested_margin_voxels * voxel
    sizes = np.bincount(labels)
    panels = {}
    for k in range(2, int(labels.max()) + 1):
        index = np.nonzero(labels == k)[0]
        panel = turned_panel(cloud[index], body, voxel, options, normals[index])
        if panel is not None:
            panels[k] = (index, panel)
    parallel = np.cos(np.radians(options.panel_min_angle))
    for small in sorted(panels, key=lambda k: sizes[k]):
        index, (normal, offset, inliers, _) = panels[small]
        for large in sorted(panels, key=lambda k: -sizes[k]):
            if sizes[large] <= sizes[small]:
                break
            big, (n, o, _, _) = panels[large]
            if abs(float(normal @ n)) < parallel:
                continue
            across = cloud[big] @ n + o
            lo, hi = np.quantile(across, [1.0 - options.enclosed_inside,
                                          options.enclosed_inside])
            plane = float(np.median(cloud[index[inliers]] @ n + o))
            if not lo - margin <= plane <= hi + margin:
                continue
            flat = np.linalg.svd(np.eye(3) - np.outer(n, n))[0][:, :2]  # the plane's axes
            outline = cKDTree(cloud[big] @ flat)
            within = np.isfinite(outline.query(cloud[index[inliers]] @ flat,
                                               distance_upper_bound=margin)[0])
            if within.mean() >= options.nested_share:
                out[out == small] = out[labels == large][0]
                moved.append({"part": int(small), "points": int(sizes[small]),
                              "faces_of": int(large)})
                break
    return numbered_by_size(out), moved


def merge_behind(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                 options: CompartmentOptions = CompartmentOptions(),
                 normals: np.ndarray | None = None) -> tuple[np.ndarray, list[dict]]:
    """A part lying in the carcass's box right behind a part that stands out past one of the
    box's faces, within that part's outline on the face, is a piece of it: a drawer pulled
    out, cut by the masks into its front (out of the box) and its body behind (in it), each
    body then a label of its own given a slide of its own. Within the outline: ``nested_share`` of the part's points, seen
    across the face, within ``nested_margin_voxels`` spacings of the standing part's points
    (not of their extent: a label of a few strays spread across the whole box has an
    extent that takes in any drawer); right behind: its front (the points but the ``1 - enclosed_inside`` foremost) no more
    than ``behind_voxels`` spacings behind the face (what lies deeper is the carcass's
    inside, :func:`return_enclosed`); deeper in the box than the front (more of its points
    in it: a drawer pulled out past half its depth keeps less than half its body in the
    box; a procedural cabinet's such drawer stood 30 % in once the box left out a stray
    piece of 7 points, :func:`carcass_box`). A front is no
    swung panel (:func:`turned_panel`, with the measured ``normals`` where given): a drawer
    barely open below a door swung 40 degrees lies within the door's outline. A
    closed part beside an open one is not in its outline; the carcass's rim around an
    opening holds the outline's edge, not its inside. Returns the labels, renumbered by
    size, and what merged."""
    from scipy.spatial import cKDTree

    out = labels.copy()
    moved: list[dict] = []
    if labels.max() < 3 or np.count_nonzero(labels == 1) < 4:
        return out, moved
    body = carcass_box(cloud[labels == 1], voxel, options)
    local = (cloud - body.center) @ body.R
    margin = options.enclosed_margin_voxels * voxel
    parts = [k for k in range(2, int(labels.max()) + 1) if np.count_nonzero(labels == k) >= 4]
    inside = {k: float(body.contains(cloud[labels == k], tol=margin).mean()) for k in parts}
    standing = [k for k in parts if inside[k] < options.enclosed_inside
                and turned_panel(cloud[labels == k], body, voxel, options,
                                 None if normals is None else normals[labels == k]) is None]
    grow = options.nested_margin_voxels * voxel
    square = None if normals is None else \
        np.abs(normals @ body.R) >= np.cos(np.radians(options.panel_min_angle))
    for k in parts:
        points = local[labels == k]
        for front in (f for f in standing if inside[f] < inside[k]):
            faces = open_faces(local, labels, body.extent, margin, [front])
            if not faces:
                continue
            a, sign = faces[0]
            across = [b for b in range(3) if b != a]
            # in its shadow on the face: near its points there, not only in their extent
            # (a label of a few strays across the whole box has an extent too)
            shadow = cKDTree(local[labels == front][:, across])
            within = np.isfinite(shadow.query(points[:, across],
                                              distance_upper_bound=grow)[0])
            depth = float(np.quantile(body.extent[a] - sign * points[:, a],
                                      1.0 - options.enclosed_inside))
            if within.mean() >= options.nested_share and depth <= options.behind_voxels * voxel:
                out[labels == k] = front
                moved.append({"part": k, "points": len(points), "behind": front})
                break
        else:
            shares = _behind_fronts(local, square, labels, k, [f for f in standing
                                                               if inside[f] < inside[k]],
                                    body.extent, voxel, options)
            if shares:
                index = np.nonzero(labels == k)[0]
                for front, held in shares.items():
                    out[index[held]] = front
                moved.append({"part": k, "points": len(points),
                              "behind": {f: int(h.sum()) for f, h in shares.items()}})
    return numbered_by_size(out), moved


def _behind_fronts(local: np.ndarray, square: np.ndarray | None, labels: np.ndarray, k: int,
                   fronts: list[int], extent: np.ndarray, voxel: float,
                   options: CompartmentOptions) -> dict[int, np.ndarray]:
    """The part ``k`` as the bodies of two or more parts standing out past one face side by
    side (:func:`merge_behind`, one front's outline holding too little of it): two drawers
    stacked and pulled out, the masks giving each its front and one label to the inside of
    both (the lower's sides and floor, a piece of the upper; on a clean ring a
    5-drawer cabinet's such label held 898 points of one drawer and 345 of the next, with
    no face of its own facing out). ``nested_share`` of its points within
    ``nested_margin_voxels`` spacings of their points seen across the face, each front
    holding at least ``1 - nested_share`` of them, its own front (the points but the ``1 -
    enclosed_inside`` foremost) no more than ``behind_voxels`` spacings behind the face,
    and no front of its own (:func:`_fronts`) apart on the face from every one of theirs (a
    drawer of its own between two others has one). Returns, per front, which of ``k``'s
    points lie nearest its outline, or {} (``square`` None: no normals, nothing told)."""
    from scipy.spatial import cKDTree

    if square is None or len(fronts) < 2:
        return {}
    index = np.nonzero(labels == k)[0]
    margin = options.enclosed_margin_voxels * voxel
    grow = options.nested_margin_voxels * voxel
    for face in open_faces(local, labels, extent, margin, fronts):
        on = [f for f in fronts if open_faces(local, labels, extent, margin, [f]) == [face]]
        if len(on) < 2:
            continue
        a, sign = face
        across = [b for b in range(3) if b != a]
        depth = float(np.quantile(extent[a] - sign * local[index, a],
                                  1.0 - options.enclosed_inside))
        if depth > options.behind_voxels * voxel:
            continue
        gaps = np.stack([cKDTree(local[labels == f][:, across]).query(local[index][:, across])[0]
                         for f in on])
        nearest = np.argmin(gaps, axis=0)
        within = gaps.min(axis=0) <= grow
        held = {f: within & (nearest == i) for i, f in enumerate(on)}
        if (within.mean() < options.nested_share
                or sum(h.mean() >= 1.0 - options.nested_share for h in held.values()) < 2):
            continue
        theirs = [g for f in on for g in _fronts(local, square, np.nonzero(labels == f)[0],
                                                 face, extent, voxel, options)]
        own = _fronts(local, square, index, face, extent, voxel, options)
        apart = options.nested_margin_voxels * voxel
        if any(all(_apart(local[g][:, across], local[h][:, across], apart, options)
                   for h in theirs) for g in own):
            continue
        near = np.argmin(gaps, axis=0)  # every point, within or not, to the nearest outline
        return {f: near == i for i, f in enumerate(on) if np.any(near == i)}
    return {}


def _box(points: np.ndarray):
    """The part's box, or None where its points span no volume (a flat panel's exact points:
    nothing can lie inside it)."""
    from scipy.spatial import QhullError

    try:
        return part_obb(points)
    except (QhullError, ValueError):
        return None


def _carcass_frame(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                   options: CompartmentOptions, normals: np.ndarray | None):
    """The carcass's box, every point in its frame, and whether each point's measured normal
    is square to the box's axes; None without normals or a carcass to measure against."""
    if normals is None or labels.max() < 2 or np.count_nonzero(labels == 1) < 4:
        return None
    body = carcass_box(cloud[labels == 1], voxel, options)
    local = (cloud - body.center) @ body.R
    square = np.abs(normals @ body.R) >= np.cos(np.radians(options.panel_min_angle))
    return body, local, square


def return_past_square_panels(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                              options: CompartmentOptions = CompartmentOptions(),
                              normals: np.ndarray | None = None,
                              ) -> tuple[np.ndarray, list[dict]]:
    """The compartment seen past a door swung square goes back to the carcass: what
    :func:`return_compartments` does for a panel turned from the carcass's axes, for one
    square to them (swung about 90 degrees, no turned panel).

    A label standing out past a face of the carcass's box (:func:`_standing`) with no
    front on it (:func:`_fronts`: a drawer pulled out shows one) that is a panel square to
    the face (RANSAC's plane holding ``panel_fraction`` of its points within
    ``panel_voxels`` spacings, counting those whose measured ``normals`` face along it,
    turned no more than ``panel_min_angle`` from square), those points standing out of
    the box (less than ``beside_inside`` of them in it: a drawer's side the merges left
    apart lies mostly in it), is a door swung open: it stands wholly out of the face, so
    its points in the box more than ``behind_voxels`` spacings
    behind the face are the carcass's inside (a refrigerator's inner side wall, 3.5 cm from
    its door's plane, in the door's label on a hand-held path: 1,561 points that pulled the
    hinge's line into the carcass). Runs after :func:`merge_nested` and
    :func:`merge_behind`, which give a drawer's side or body cut from its front back to it.
    Needs the measured ``normals``. Returns the labels, renumbered by size, and what moved."""
    from .ransac import fit_plane

    out = labels.copy()
    moved: list[dict] = []
    frame = _carcass_frame(cloud, labels, voxel, options, normals)
    if frame is None:
        return out, moved
    body, local, square = frame
    cos = np.cos(np.radians(options.panel_normal_deg))
    for k, index, (a, sign), inside in _standing(cloud, labels, body, local, voxel, options,
                                                 normals):
        if _fronts(local, square, index, (a, sign), body.extent, voxel, options):
            continue
        normal, offset, inliers = fit_plane(cloud[index], options.panel_voxels * voxel, 300,
                                            np.random.default_rng(0))
        facing = np.abs(normals[index[inliers]] @ normal) >= cos
        if (not normal.any() or facing.sum() < options.panel_fraction * len(index)
                or abs(float(body.R[:, a] @ normal)) > np.sin(np.radians(
                    options.panel_min_angle))
                or inside[inliers[facing]].mean() >= options.beside_inside):
            continue  # no panel square to the face standing out of the box
        deep = inside & (sign * local[index, a] < body.extent[a]
                         - options.behind_voxels * voxel)
        if deep.any():
            out[index[deep]] = 1
            moved.append({"part": k, "points": int(deep.sum()), "past_square_panel": True})
    return numbered_by_size(out), moved


def return_frontless(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                     options: CompartmentOptions = CompartmentOptions(),
                     normals: np.ndarray | None = None) -> tuple[np.ndarray, list[dict]]:
    """A moving part lying in the carcass's box with no front on any face parts stand out
    past is the carcass's: a divider or an inner wall the masks gave a label of its own.

    A door or drawer seen shut shows its front at the opening (:func:`_fronts`: points
    facing out of the face, at it, a patch wider than ``behind_voxels`` spacings both
    ways); seen open it stands out of the box. A part with ``enclosed_inside`` of its
    points in the box (grown by ``enclosed_margin_voxels`` spacings) and no front on any
    open face (:func:`open_faces`) is neither: on a hand-held path a cabinet's divider
    (734 points, 3.5 % of the carcass, above :func:`return_enclosed`'s ``small``; facing
    sideways, as tall as the box, half its depth, flush with the opening) kept a slide.
    A front is a surface: the label's points at its depth fill at least ``front_cover`` of
    its outline (:func:`_front_cover`); on the same path the divider's label also held 111
    points of the carcass's face frame and shelves' front edges at the opening, a "front"
    31 cm wide and 98 cm tall filling 13 % of it, and kept its slide (the fronts of the
    moving parts of PartNet-Mobility dev's cabinets and tables seen on rings and hand-held
    paths, clean or phone LiDAR, fill 48 to 100 %).
    Runs after :func:`merge_nested` and :func:`merge_behind`, which give a drawer's body
    cut from its front back to it. With no part standing out there is no open face and
    nothing moves. Needs the measured ``normals``. Returns the labels, renumbered (the
    carcass first), and what moved."""
    out = labels.copy()
    moved: list[dict] = []
    frame = _carcass_frame(cloud, labels, voxel, options, normals)
    if frame is None:
        return out, moved
    body, local, square = frame
    margin = options.enclosed_margin_voxels * voxel
    parts = [k for k in range(2, int(labels.max()) + 1) if np.count_nonzero(labels == k) >= 4]
    inside = {k: float(body.contains(cloud[labels == k], tol=margin).mean()) for k in parts}
    faces = open_faces(local, labels, body.extent, margin,
                       [k for k in parts if inside[k] < options.enclosed_inside])
    for k in parts:
        if not faces or inside[k] < options.enclosed_inside:
            continue
        index = np.nonzero(labels == k)[0]
        if any(_front_cover(local, index, f, face[0], voxel, options) >= options.front_cover
               for face in faces for f in _fronts(local, square, index, face, body.extent,
                                                  voxel, options)):
            continue
        out[index] = 1
        moved.append({"part": k, "points": len(index), "frontless": True})
    return numbered_by_size(out), moved


def return_face_fronts(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                       options: CompartmentOptions = CompartmentOptions(),
                       normals: np.ndarray | None = None) -> tuple[np.ndarray, list[dict]]:
    """A label standing out past a face of the carcass's box whose one front
    (:func:`_fronts`) lies level with the face, while the label reaches more than
    ``behind_voxels`` spacings past that front out of the box, holds a stretch of the
    carcass's face: that front goes back to the carcass.

    A part standing out shows its front where it stands (a drawer pulled out, at its
    outer end); a door swung open is a turned panel or shows only its edges (no front).
    Past the front: at least ``front_points`` of the label's points, fewer than
    ``handle_facing`` of them facing out as the front does (a drawer's sides and bottom
    do not; a shut drawer's handle, 7 cm out of its front, does: on a hand-held path a
    cabinet's drawer 1.8 cm out lost its front to a first version that read reach alone).
    On a ring in a room a drawer pulled out 13 cm below a door swung 21 degrees, its own
    front hidden by the door, shared a label with the carcass's face frame beside the
    door (222 of the label's 798 points, facing out of the face, level with it): mostly
    the carcass's, the label stood for no part and the drawer's joint was lost. Two
    fronts at two depths (a drawer shut beside one pulled out, both fronts seen) are
    :func:`split_fronts`'s and stay; a shut drawer's front alone in the label of a
    drawer whose own front is hidden would go to the carcass. Needs the measured
    ``normals``. Returns the labels,
    renumbered by size, and what moved."""
    out = labels.copy()
    moved: list[dict] = []
    frame = _carcass_frame(cloud, labels, voxel, options, normals)
    if frame is None:
        return out, moved
    body, local, square = frame
    behind = options.behind_voxels * voxel
    margin = options.enclosed_margin_voxels * voxel
    for k, index, (a, sign), _ in _standing(cloud, labels, body, local, voxel, options,
                                            normals):
        fronts = _fronts(local, square, index, (a, sign), body.extent, voxel, options)
        if len(fronts) != 1:
            continue
        level = float(np.median(sign * local[fronts[0], a]))
        beyond = index[sign * local[index, a] > level + behind]
        if (level <= body.extent[a] + margin and len(beyond) >= options.front_points
                and square[beyond, a].mean() < options.handle_facing):
            out[fronts[0]] = 1
            moved.append({"part": k, "points": len(fronts[0]), "face_front": True})
    return numbered_by_size(out), moved


def split_fronts(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                 options: CompartmentOptions = CompartmentOptions(),
                 normals: np.ndarray | None = None) -> tuple[np.ndarray, list[dict]]:
    """:func:`split_fronts_once`, then again on what it split, up to ``settle_rounds``
    times, until nothing splits: a front is judged by its share of the label it lies in,
    and a drawer's front beside two others in one label is a small share of it (on the
    phone-LiDAR ring a cabinet's label held three drawers pulled out 78, 55 and 38 cm;
    the third's front, 43 of the label's 364 facing points, fell short of
    ``front_share``, and its drawer stayed with the second: scored lost). Once split, the
    second and third are judged as the label they share. The doors swung square beside the
    fronts (:func:`_beside_fronts`, judged by their share of the label the masks gave) are
    found in the first round only: a later round's label is one a split made, a drawer's
    side that its front's outline missed no door."""
    out, moved = split_fronts_once(cloud, labels, voxel, options, normals)
    split = moved
    for _ in range(options.settle_rounds - 1):
        if not split:
            break
        out, split = split_fronts_once(cloud, out, voxel, options, normals, beside=False)
        moved += split
    return out, moved


def split_fronts_once(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                      options: CompartmentOptions = CompartmentOptions(),
                      normals: np.ndarray | None = None,
                      beside: bool = True) -> tuple[np.ndarray, list[dict]]:
    """A label standing out past a face of the carcass's box whose fronts lie at two depths,
    side by side, is two parts: two drawers pulled out by different lengths that the masks
    gave one label.

    Its fronts are its points whose measured ``normals`` face along the face's axis (within
    ``panel_min_angle``), grouped by depth along it (a gap of more than ``behind_voxels``
    spacings parts two groups); a group of at least ``front_share`` of them and
    ``front_points``, at the face or out of it (no more than ``behind_voxels`` spacings
    behind it), spanning more than ``behind_voxels`` spacings both ways across the face, is
    a front (a door swung square to the face shows its edges there, strips a spacing or two
    wide: a procedural refrigerator's door open 95 degrees was cut in two by its free edge
    and its hinge's). A drawer's own back panel, seen past its front from above,
    faces the same way at another depth but lies within the front's outline on the face;
    two drawers' fronts lie apart on it (no more than ``1 - nested_share`` of the smaller's points within
    ``nested_margin_voxels`` spacings of the other's, seen across the face: their edges
    touch). Fronts whose depths differ by less than the grouping parts (a centimetre or
    two) are two where a straight seam across the face parts two flat fronts
    (:func:`_seam_fronts`). Every point of the label then goes to the front nearest it
    across the face (a drawer's sides and bottom lie behind its own front). A turned panel
    is no drawer and is left alone; so are two drawers pulled out alike (one front). Needs
    the measured ``normals``. Returns the labels, renumbered by size, and what was split."""
    from scipy.spatial import cKDTree

    out = labels.copy()
    moved: list[dict] = []
    frame = _carcass_frame(cloud, labels, voxel, options, normals)
    if frame is None:
        return out, moved
    body, local, square = frame
    apart = options.nested_margin_voxels * voxel
    for k, index, (a, sign), _ in _standing(cloud, labels, body, local, voxel, options,
                                            normals):
        across = [b for b in range(3) if b != a]
        facing = index[square[index, a]]
        least = max(options.front_points, options.front_share * len(facing))
        fronts = _fronts(local, square, index, (a, sign), body.extent, voxel, options)
        # fronts apart on the face: of the smaller, no more than 1 - nested_share near the
        # other (their edges touch); a back panel lies wholly within its front's outline
        kept: list[np.ndarray] = []
        for f in sorted(fronts, key=len, reverse=True):
            if all(_apart(local[f][:, across], local[g][:, across], apart, options)
                   for g in kept):
                kept.append(f)
        if len(kept) < 2:  # two fronts side by side a little apart in depth: a seam
            at_face = facing[sign * local[facing, a] >= body.extent[a]
                             - options.behind_voxels * voxel]
            kept = _seam_fronts(at_face, sign * local[:, a], local, across, voxel, least,
                                options) or kept
        if not kept:
            continue
        nearest = np.full(len(index), np.inf)
        which = np.zeros(len(index), dtype=int)
        for i, f in enumerate(kept):
            d = cKDTree(local[f][:, across]).query(local[index][:, across])[0]
            which[d < nearest] = i
            nearest = np.minimum(nearest, d)
        top = int(out.max())
        for i in range(1, len(kept)):
            out[index[which == i]] = top + i
        doors = _beside_fronts(cloud, index, nearest > apart, body, a, voxel, options,
                               normals) if beside else []
        for i, piece in enumerate(doors):
            out[piece] = top + len(kept) + i
        if len(kept) + len(doors) < 2:
            continue
        moved.append({"part": k, "points": len(index), "fronts": len(kept),
                      "split_m": [round(float(np.median(local[f, a])), 3) for f in kept],
                      **({"beside": [len(p) for p in doors]} if doors else {})})
    return numbered_by_size(out), moved


def _beside_fronts(cloud: np.ndarray, index: np.ndarray, far: np.ndarray, body, axis: int,
                   voxel: float, options: CompartmentOptions,
                   normals: np.ndarray) -> list[np.ndarray]:
    """The doors swung square beside a label's fronts (:func:`split_fronts`): of the label's
    points (``index``) outside every front's outline on the face of axis ``axis`` (``far``,
    per point), each piece (points linked within ``panel_link_voxels`` spacings) of at
    least ``front_points`` and ``front_share`` of the label that is a panel square to the
    face (RANSAC's plane holding ``panel_fraction`` of it within ``panel_voxels`` spacings,
    counting the points whose measured ``normals`` face along it, turned no more than
    ``panel_min_angle`` from square) standing out of the carcass's box (less than
    ``beside_inside`` of it in the box grown by ``enclosed_margin_voxels`` spacings),
    reaching ``beside_reach`` of the box's depth out of the face, and not going on within
    the outline (the label's other points on its plane, facing along it, fewer than
    ``claim_share`` of its own) is a part of its own. A refrigerator's door swung square
    with its bins, in a label of its own, has a front (the bins' faces) and its panel
    past their outline; that panel goes on behind them (on a ring 712 points on its
    plane within the outline, 279 past it), and stays. On a hand-held path one label held a door swung square and a drawer
    pulled out below it; its door, seen across the face, is a strip beside the drawer's
    front. A drawer's own sides and bottom lie within its front's outline, or, where the
    masks cut its front short, reach no further out of the box than it is pulled (on the
    same path a drawer's bottom, 64 % in the box); a strip of a refrigerator's carcass
    beside a front, out of the box, reached 15 % of its depth out of the face."""
    from .ransac import fit_plane
    from .segment.pieces import linked_components

    far, near = index[far], index[~far]
    if len(far) < options.front_points:
        return []
    piece = linked_components(cloud[far], options.panel_link_voxels * voxel)
    least = max(options.front_points, options.front_share * len(index))
    margin = options.enclosed_margin_voxels * voxel
    out = []
    for p in range(int(piece.max()) + 1):
        members = far[piece == p]
        reach = float(np.ptp((cloud[members] - body.center) @ body.R[:, axis]))
        if (len(members) < least or reach < options.beside_reach * 2.0 * body.extent[axis]
                or body.contains(cloud[members], tol=margin).mean() >= options.beside_inside):
            continue
        normal, offset, inliers = fit_plane(cloud[members], options.panel_voxels * voxel, 300,
                                            np.random.default_rng(0))
        cos = np.cos(np.radians(options.panel_normal_deg))
        facing = np.abs(normals[members[inliers]] @ normal) >= cos
        square = abs(float(body.R[:, axis] @ normal)) <= np.sin(np.radians(
            options.panel_min_angle))
        goes_on = np.count_nonzero((np.abs(cloud[near] @ normal + offset)
                                    <= options.panel_voxels * voxel)
                                   & (np.abs(normals[near] @ normal) >= cos))
        if (normal.any() and square and facing.sum() >= options.panel_fraction * len(members)
                and goes_on < options.claim_share * facing.sum()):
            out.append(members)
    return out


def _fronts(local: np.ndarray, square: np.ndarray, index: np.ndarray, face: tuple[int, int],
            extent: np.ndarray, voxel: float, options: CompartmentOptions) -> list[np.ndarray]:
    """A label's fronts on a face (axis, sign) of the carcass's box (:func:`split_fronts`):
    its points (``index``) facing along the face's axis (``square``: per point and axis),
    grouped by depth along it (a gap of more than ``behind_voxels`` spacings parts two
    groups), each group of at least ``front_share`` of them and ``front_points``, at the
    face or out of it, spanning more than ``behind_voxels`` spacings both ways across it.
    ``local``: every point in the box's frame; ``extent``: its half-lengths."""
    a, sign = face
    across = [b for b in range(3) if b != a]
    facing = index[square[index, a]]
    if len(facing) == 0:
        return []
    depth = np.sort(local[facing, a])
    cuts = np.nonzero(np.diff(depth) > options.behind_voxels * voxel)[0]
    bounds = np.concatenate([[-np.inf], (depth[cuts] + depth[cuts + 1]) / 2, [np.inf]])
    group = np.searchsorted(bounds, local[facing, a]) - 1
    least = max(options.front_points, options.front_share * len(facing))
    # at the face or out of it: a drawer's front, open or shut (not a back panel)
    return [f for f in (facing[group == g] for g in range(len(bounds) - 1))
            if len(f) >= least and float(np.median(sign * local[f, a]))
            >= extent[a] - options.behind_voxels * voxel
            and np.ptp(local[f][:, across], axis=0).min() > options.behind_voxels * voxel]


def _front_cover(local: np.ndarray, index: np.ndarray, front: np.ndarray, axis: int,
                 voxel: float, options: CompartmentOptions) -> float:
    """The share of a front's outline on the face of axis ``axis`` (the extent of its points
    ``front`` across it, in cells a spacing wide) that holds a point of its label
    (``index``) within ``behind_voxels`` spacings of the front's depth, whatever way the
    point faces (noisy depth blurs normals, not where the surface is): near 1 for a surface
    seen, low for strips and edges spread across a face. ``local``: every point in the
    carcass's box frame."""
    across = [b for b in range(3) if b != axis]
    lo, hi = local[front][:, across].min(axis=0), local[front][:, across].max(axis=0)
    points = local[index]
    near = points[(np.abs(points[:, axis] - np.median(local[front, axis]))
                   <= options.behind_voxels * voxel)
                  & np.all((points[:, across] >= lo) & (points[:, across] <= hi), axis=1)]
    cells = np.unique(np.floor((near[:, across] - lo) / voxel).astype(int), axis=0)
    return len(cells) / float(np.prod(np.floor((hi - lo) / voxel) + 1))


def _apart(front: np.ndarray, other: np.ndarray, apart: float,
           options: CompartmentOptions) -> bool:
    """Whether two fronts (their points on the face, in its two axes) lie apart on it: of
    ``front`` no more than ``1 - nested_share`` within ``apart`` of ``other`` (their edges
    touch; a drawer's back panel lies wholly within its front's outline)."""
    from scipy.spatial import cKDTree

    near = np.isfinite(cKDTree(other).query(front, distance_upper_bound=apart)[0])
    return float(near.mean()) <= 1.0 - options.nested_share


def _seam_fronts(front: np.ndarray, depth: np.ndarray, local: np.ndarray, across: list[int],
                 voxel: float, least: float, options: CompartmentOptions) -> list[np.ndarray]:
    """Two fronts side by side whose depths differ by less than the grouping by depth
    parts (two drawers pulled out by lengths a centimetre or two apart): a straight seam
    across the face (along one of the carcass's axes) splits the ``front`` points (at the
    face, facing out; ``depth``: every point's, out of it) into two sides, each side's front
    is the plane most of its points lie on (within a quarter of ``seam_step_voxels``
    spacings of its depth mode), each plane at least ``least`` points, their depths
    ``seam_step_voxels`` to ``behind_voxels`` spacings apart (a larger step is the grouping
    by depth's: a drawer's back panel lies that far behind its front pulled out), and the
    planes apart across the seam: of each plane's points at most ``1 - nested_share`` lie
    on the other side (a recessed panel's rim surrounds it on every side of any seam; two
    drawers' fronts each lie on their own side). The two planes' points, the larger
    first, or [] where no seam does."""
    if len(front) < 2 * least:
        return []
    tol = 0.25 * options.seam_step_voxels * voxel
    step_min, step_max = options.seam_step_voxels * voxel, options.behind_voxels * voxel
    x = depth[front]
    best = None
    for b in across:
        u = local[front, b]
        for cut in np.quantile(u, np.linspace(0.1, 0.9, 33)):
            side = u > cut
            if min(side.sum(), (~side).sum()) < least:
                continue
            modes = [_depth_mode(x[~side], tol), _depth_mode(x[side], tol)]
            if not step_min <= abs(modes[1] - modes[0]) <= step_max:
                continue
            on = [np.abs(x - m) <= tol for m in modes]  # each plane, over the whole front
            planes = [on[0] & ~side, on[1] & side]
            stray = [float((on[0] & side).sum()) / max(planes[0].sum(), 1),
                     float((on[1] & ~side).sum()) / max(planes[1].sum(), 1)]
            size = min(int(p.sum()) for p in planes)
            if size >= least and max(stray) <= 1.0 - options.nested_share \
                    and (best is None or size > best[0]):
                best = (size, [front[p] for p in planes])
    return [] if best is None else sorted(best[1], key=len, reverse=True)


def _depth_mode(x: np.ndarray, tol: float) -> float:
    """The depth with the most of ``x`` within ``tol`` of it (the middle of the densest
    window of width 2 ``tol``)."""
    x = np.sort(x)
    count = np.searchsorted(x, x + 2.0 * tol, side="right") - np.arange(len(x))
    i = int(np.argmax(count))
    return float(np.median(x[i:i + count[i]]))


def _standing(cloud: np.ndarray, labels: np.ndarray, body, local: np.ndarray, voxel: float,
              options: CompartmentOptions, normals: np.ndarray | None):
    """The moving parts (at least 30 points) standing out of the carcass's box ``body``
    (less than ``enclosed_inside`` of their points in it) that are no turned panel, each as
    (label, its points' indices, the face it stands out past (:func:`open_faces`), which of
    its points lie in the box). ``local``: every point in the box's frame."""
    margin = options.enclosed_margin_voxels * voxel
    for k in range(2, int(labels.max()) + 1):
        index = np.nonzero(labels == k)[0]
        if len(index) < 30:
            continue
        inside = body.contains(cloud[index], tol=margin)
        if (inside.mean() >= options.enclosed_inside
                or turned_panel(cloud[index], body, voxel, options,
                                None if normals is None else normals[index]) is not None):
            continue
        faces = open_faces(local, labels, body.extent, margin, [k])
        if faces:
            yield k, index, faces[0], inside


def merge_shell(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                options: CompartmentOptions = CompartmentOptions(),
                normals: np.ndarray | None = None) -> tuple[np.ndarray, list[dict]]:
    """A part standing out past a face of the carcass's box that spans the whole face and
    runs on along the box's sides is a piece of the carcass's shell: the masks cut a body
    in two (a box's end, 40 % of it, standing 6 cm past the rest's box, read as a slide).

    Spanning the face: its points beyond it (but the ``1 - enclosed_inside`` outermost
    each way) span ``shell_span`` of the box along both axes across the face; along the
    sides: at least ``shell_wall_share`` of its points in the box lie within
    ``enclosed_margin_voxels`` spacings of the box's four sides around that face, where a
    carcass's walls are. A drawer pulled out lies inside its opening, within the carcass's
    walls (and the walls hide its sides); a door or a lid standing out spans the face one
    way only, or is a turned panel (left alone). A drawer whose front covers the carcass's
    whole face and whose sides run along its walls within a spacing would go to the
    carcass. Returns the labels, renumbered by size, and what merged."""
    out = labels.copy()
    moved: list[dict] = []
    if labels.max() < 2 or np.count_nonzero(labels == 1) < 4:
        return out, moved
    body = carcass_box(cloud[labels == 1], voxel, options)
    local = (cloud - body.center) @ body.R
    margin = options.enclosed_margin_voxels * voxel
    for k, index, (a, sign), inside in _standing(cloud, labels, body, local, voxel, options,
                                                 normals):
        across = [b for b in range(3) if b != a]
        points = local[index]
        beyond = points[sign * points[:, a] > body.extent[a] + margin]
        if len(beyond) < 4:
            continue
        lo, hi = np.quantile(beyond, [1.0 - options.enclosed_inside,
                                      options.enclosed_inside], axis=0)
        spans = all(hi[b] - lo[b] >= options.shell_span * 2 * body.extent[b] for b in across)
        sides = np.zeros(len(index), dtype=bool)
        for b in across:
            sides |= np.abs(np.abs(points[:, b]) - body.extent[b]) <= margin
        on_sides = float(np.count_nonzero(sides & inside)) / len(index)
        if spans and on_sides >= options.shell_wall_share:
            out[index] = 1
            moved.append({"part": k, "points": len(index), "shell": True,
                          "on_sides": round(on_sides, 2)})
    return numbered_by_size(out), moved


def return_seam_strips(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                       options: CompartmentOptions = CompartmentOptions(),
                       ) -> tuple[np.ndarray, list[dict]]:
    """A moving part's label that is a strip along other labels' borders, with no surface
    of its own, is given back point by point, each point to the label of the other point
    nearest it: ``nested_share`` of its points lie within ``nested_margin_voxels`` spacings
    of other labels' points. The mask network's seams: on the phone-LiDAR ring a table's
    166-point label along the seams of three drawers' fronts (36 % the largest's; every
    point within 2 spacings of another label) and, on a hand-held clean path, a cabinet's
    186-point strip along the seam of its carcass and a swung door (124 points the
    carcass's, 62 the door's) each kept a joint. A part seen as a surface has points
    farther inside it than that: on the 48 saved segmentations of the evaluation's dev
    objects (the phone ring, the clean room, hand-held paths clean and phone LiDAR) no label holding
    most of a part has 90 % of its points within 3 spacings of other labels (the table's
    smallest drawer front, 218 points: 6). Limit: a front narrower than about four
    spacings (9 cm on phone LiDAR at 2.2 cm) flush among other parts would be one.
    Returns the labels, renumbered by size, and what moved."""
    from scipy.spatial import cKDTree

    out = labels.copy()
    moved: list[dict] = []
    margin = options.nested_margin_voxels * voxel
    for k in range(2, int(labels.max()) + 1):
        index = np.nonzero(out == k)[0]
        others = np.nonzero((out != k) & (out > 0))[0]
        if len(index) == 0 or len(others) == 0:
            continue
        d, nearest = cKDTree(cloud[others]).query(cloud[index])
        if np.mean(d <= margin) < options.nested_share:
            continue
        out[index] = out[others[nearest]]
        moved.append({"part": k, "points": len(index), "seam_strip": True})
    return numbered_by_size(out), moved


def return_frontless_pieces(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                            options: CompartmentOptions = CompartmentOptions(),
                            normals: np.ndarray | None = None) -> tuple[np.ndarray, list[dict]]:
    """A label standing out of the carcass's box with no front of its own on the face it
    stands out past (:func:`_fronts`) and no swung panel (:func:`turned_panel`), lying in
    the outlines of parts with fronts on that face or in the carcass's box, is pieces of
    them, given back point by point, each point to the nearest point of those parts or the
    carcass: a moving part shows a front or a panel. The pieces the masks cut from pulled-out
    drawers that no earlier rule joined (on the phone-LiDAR ring a table's 74-point label,
    46 points of a drawer's side and 27 of a divider behind it, 0.81 in the drawer's
    outline; on its clean ring a 51-point patch of a drawer's floor, what was left of a
    label once the carcass's points in it went back) each kept a slide. Within an outline:
    within ``nested_margin_voxels`` spacings of the part's points seen across the face, a
    part counted where it holds at least ``1 - nested_share`` of the label; in all
    ``nested_share`` of the label in the outlines or the box (grown by
    ``enclosed_margin_voxels`` spacings); and at most ``1 - nested_share`` of the points of
    the parts it lies in (a drawer whose front a hand-held path's few views missed is a
    part of its own, not a scrap: a 761-point drawer lying in its neighbour's outline was
    given back, its slide lost). A door swung square lies beside the opening, out
    of the other parts' outlines. Needs the measured ``normals``. Returns the labels,
    renumbered by size, and what moved."""
    from scipy.spatial import cKDTree

    out = labels.copy()
    moved: list[dict] = []
    frame = _carcass_frame(cloud, labels, voxel, options, normals)
    if frame is None:
        return out, moved
    body, local, square = frame
    margin = options.enclosed_margin_voxels * voxel
    grow = options.nested_margin_voxels * voxel
    parts = [k for k in range(2, int(labels.max()) + 1) if np.count_nonzero(labels == k) >= 4]
    inside = {k: float(body.contains(cloud[labels == k], tol=margin).mean()) for k in parts}
    standing = [k for k in parts if inside[k] < options.enclosed_inside
                and turned_panel(cloud[labels == k], body, voxel, options,
                                 normals[labels == k]) is None]
    faces = {k: open_faces(local, labels, body.extent, margin, [k]) for k in standing}
    fronted = {k: bool(faces[k]) and bool(_fronts(local, square, np.nonzero(labels == k)[0],
                                                  faces[k][0], body.extent, voxel, options))
               for k in standing}
    for k in standing:
        if fronted[k] or not faces[k]:
            continue
        a = faces[k][0][0]
        across = [b for b in range(3) if b != a]
        index = np.nonzero(labels == k)[0]
        held, within = [], np.zeros(len(index), bool)
        for f in standing:
            if f == k or not fronted[f] or faces[f] != faces[k]:
                continue
            near = np.isfinite(cKDTree(local[labels == f][:, across]).query(
                local[index][:, across], distance_upper_bound=grow)[0])
            if near.mean() >= 1.0 - options.nested_share:
                held.append(f)
                within |= near
        in_box = body.contains(cloud[index], tol=margin)
        if not held or np.mean(within | in_box) < options.nested_share:
            continue
        if len(index) > (1.0 - options.nested_share) * np.count_nonzero(np.isin(labels, held)):
            # more than a tenth of the parts it lies in: a part of its own whose front
            # the views missed (a drawer seen from a hand-held path), not a scrap of them
            continue
        owners = np.nonzero(np.isin(labels, [1, *held]))[0]
        nearest = cKDTree(cloud[owners]).query(cloud[index])[1]
        out[index] = labels[owners[nearest]]
        moved.append({"part": k, "points": len(index), "frontless_piece_of": held})
    return numbered_by_size(out), moved


def join_body_under_lid(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                        options: CompartmentOptions = CompartmentOptions(),
                        normals: np.ndarray | None = None,
                        up: np.ndarray | None = None) -> tuple[np.ndarray, list[dict]]:
    """Where the largest label is one panel (:func:`_one_panel`: a lid or a door swung
    open, larger than what the views show of the body it hangs on) standing off the
    object's foot, the labels that stand on the foot, none of them one panel, are the body
    cut in pieces: they join the largest of them. Every rule before this one measures
    against the largest label as the carcass; a lid gives no walls to measure by, and a
    body in two labels is a part with a slide. On a phone-LiDAR ring around a real lidded
    box the lid was 9,808 points, its body 8,067 and 3,349 (the body's front wall and a
    side in the second), both reaching its foot, the lid 29 cm above it; the second kept a
    slide. A part moving on a carcass stands on it, not on the floor beside it: a drawer's
    bottom lies above the carcass's, a door swung open is one panel (and stands on the
    foot: nothing joins under it). The foot: the lowest of the cloud's points along ``up``
    (:func:`pipeline.isolate.views_up`); a label stands on it when its lowest point lies
    within ``behind_voxels`` spacings of it. Needs the measured ``normals`` and ``up``.
    Returns the labels, renumbered by size, and what joined."""
    out = labels.copy()
    moved: list[dict] = []
    carcass = np.nonzero(labels == 1)[0]
    if normals is None or up is None or labels.max() < 3 or len(carcass) < 4:
        return out, moved
    height = cloud @ up
    foot = float(height.min())
    reach = options.behind_voxels * voxel
    if (float(height[carcass].min()) - foot <= reach
            or not _one_panel(cloud[carcass], normals[carcass], voxel, options)):
        return out, moved  # a carcass, or a panel standing on the foot (a door)
    standing = []
    for k in range(2, int(labels.max()) + 1):
        index = np.nonzero(labels == k)[0]
        if (len(index) >= 4 and float(height[index].min()) - foot <= reach
                and not _one_panel(cloud[index], normals[index], voxel, options)):
            standing.append(k)
    if len(standing) < 2:
        return out, moved
    for k in standing[1:]:  # into the largest (labels are numbered by size)
        out[labels == k] = standing[0]
        moved.append({"part": k, "points": int(np.count_nonzero(labels == k)),
                      "body_under_lid": standing[0]})
    return numbered_by_size(out), moved


def find_level_fronts(cloud: np.ndarray, labels: np.ndarray, voxel: float,
                      options: CompartmentOptions = CompartmentOptions(),
                      normals: np.ndarray | None = None) -> tuple[np.ndarray, list[dict]]:
    """A drawer the masks left in the carcass's label, found beside a drawer pulled out as
    far: the carcass's points facing the way a moving part's front faces, level with that
    front, where the part stands out past the carcass's walls, are another front, and what
    lies behind it within its outline, as deep as the part, is another part.

    The part's front: its points whose measured ``normals`` face along an axis of the
    carcass's box (within ``panel_min_angle``), their outermost tenth along one side, at
    least ``front_points`` of them, reaching that face of the box (within ``behind_voxels``
    spacings: the drawer left in the carcass's label stretches the box to itself) and
    ``behind_voxels`` spacings past the carcass's own walls facing that way (the median of
    its points facing along the axis on that side) or past where its walls end
    (:func:`_walls_reach`): a table open at the front has few points of its own facing out
    of it, and on a hand-held path the drawer left in its label (152 points facing out,
    against the table's 52) was that median; the table's side and top end at its front,
    15 cm behind the drawers. Level: within ``behind_voxels``
    spacings of it; each piece of them (points linked within ``panel_link_voxels``
    spacings) of at least ``front_points`` points, away from the part's own front on the
    face (:func:`_on_own_front`), as tall and as wide as ``front_span`` of the part's
    front's lesser span on the face (a table top's front edge level with a drawer pulled
    out, 3 cm tall, is no drawer front 9 cm tall), is a front. Behind it: the carcass's
    points within its outline on the face (``enclosed_margin_voxels`` spacings) as deep as
    the part reaches along the axis; at
    most twice the part's points, as a sibling drawer is (a table top's edge level with the
    fronts has the whole top behind it). A turned panel is no drawer and finds nothing; nor
    does a small piece of the carcass in a label of its own (what :func:`return_enclosed`
    gives back: on a phone-LiDAR ring a patch of a cabinet's floor "found" two pieces of
    the floor beside it). Needs the measured ``normals``.
    Returns the labels, renumbered by size, and what was found."""
    from scipy.spatial import cKDTree

    from .segment.pieces import linked_components

    out = labels.copy()
    moved: list[dict] = []
    carcass = np.nonzero(labels == 1)[0]
    if normals is None or labels.max() < 2 or len(carcass) < 4:
        return out, moved
    body = carcass_box(cloud[carcass], voxel, options)
    local = (cloud - body.center) @ body.R
    square = np.abs(normals @ body.R) >= np.cos(np.radians(options.panel_min_angle))
    behind = options.behind_voxels * voxel
    apart = options.nested_margin_voxels * voxel
    margin = options.enclosed_margin_voxels * voxel
    wall_reach = _walls_reach(local[carcass], square[carcass], body.extent, voxel, options)
    for k in range(2, int(labels.max()) + 1):
        index = np.nonzero(labels == k)[0]
        patch = (len(index) <= options.enclosed_share * len(carcass)  # the carcass's own,
                 and body.contains(cloud[index], tol=margin).mean()  # as return_enclosed
                 >= options.enclosed_inside)  # finds it: a patch of its floor is no drawer
        if (len(index) < options.front_points or patch
                or turned_panel(cloud[index], body, voxel, options, normals[index]) is not None):
            continue
        for a in range(3):
            across = [b for b in range(3) if b != a]
            for sign in (1, -1):
                facing = index[square[index, a] & (sign * local[index, a] > 0)]
                if len(facing) < options.front_points:
                    continue
                front = float(np.quantile(sign * local[facing, a], 0.9))
                walls = carcass[square[carcass, a] & (sign * local[carcass, a] > 0)]
                if (front < body.extent[a] - behind or len(walls) == 0
                        or front - min(float(np.median(sign * local[walls, a])),
                                       wall_reach[a, (1 - sign) // 2]) < behind):
                    continue
                level = walls[np.abs(sign * local[walls, a] - front) <= behind]
                level = level[out[level] == 1]
                if len(level) < options.front_points:
                    continue
                own = cKDTree(local[facing][:, across])
                piece = linked_components(cloud[level], options.panel_link_voxels * voxel)
                reach = front - float(np.quantile(sign * local[index, a], 0.02))
                for p in range(int(piece.max()) + 1):
                    members = level[piece == p]
                    if len(members) < options.front_points or _on_own_front(
                            local[members][:, across], own, apart, options) or np.ptp(
                            local[members][:, across], axis=0).min() < options.front_span \
                            * np.ptp(local[facing][:, across], axis=0).min():
                        continue
                    free = np.nonzero(out == 1)[0]
                    depth = sign * local[free, a]
                    near = np.isfinite(cKDTree(local[members][:, across]).query(
                        local[free][:, across], distance_upper_bound=margin)[0])
                    part = free[near & (depth >= front - reach) & (depth <= front + behind)]
                    if len(part) > 2 * len(index):
                        continue
                    out[part] = int(out.max()) + 1
                    moved.append({"part": k, "points": len(part), "level_front": True,
                                  "side": [a, sign]})
    return numbered_by_size(out), moved


def _walls_reach(local: np.ndarray, square: np.ndarray, extent: np.ndarray, voxel: float,
                 options: CompartmentOptions) -> np.ndarray:
    """How far the carcass's walls (:func:`carcass_walls`) reach out of each face of its box
    (``[axis, 0]`` the + face, ``[axis, 1]`` the - face), as :func:`within_walls` reads
    them: a wall facing out of the face is at it (its farthest point); else the second
    farthest of the walls facing along the other axes, each by its points on its own plane
    (within ``panel_voxels`` spacings of its median: a part's side lying along a wall, a
    spacing or two off it, stretches neither); the box's extent where neither is found.
    ``local``: the carcass's points in the box's frame."""
    reach = np.tile(extent[:, None], (1, 2)).astype(float)
    walls = carcass_walls(local, square, voxel, options)
    for a in range(3):
        for side, sign in ((0, 1), (1, -1)):
            out = [float(np.max(sign * local[w, a])) for f, w in walls
                   if f == a and np.median(sign * local[w, a]) > 0]
            far = []
            for f, w in walls:
                if f == a:
                    continue
                on = w[np.abs(local[w, f] - np.median(local[w, f]))
                       <= options.panel_voxels * voxel]
                if len(on):
                    far.append(float(np.max(sign * local[on, a])))
            if out:
                reach[a, side] = max(out)
            elif len(far) > 1:
                reach[a, side] = sorted(far)[-2]
    return reach


def _on_own_front(members: np.ndarray, own, apart: float,
                  options: CompartmentOptions = CompartmentOptions()) -> bool:
    """Whether a level piece of the carcass's label (``members``: its points on the face, in
    the face's two axes) is the part's own front (``own``: a KD-tree of that front's points
    on the face) rather than a sibling's: more than ``1 - nested_share`` of it within
    ``apart`` of the front, unless those lie in a strip along one edge no wider than twice
    ``apart``: a sibling beside it touches it there only, across the gap between them (no
    wider than ``apart`` where any of its points are that near) and ``apart`` into it (a
    table's drawer 34 cm wide beside its neighbour 3.4 cm away: 11 % of it within 3.7 cm,
    in a strip 6.7 cm wide)."""
    near = np.isfinite(own.query(members, distance_upper_bound=apart)[0])
    if near.mean() <= 1.0 - options.nested_share:
        return False
    return float(np.min(np.ptp(members[near], axis=0))) > 2.0 * apart
