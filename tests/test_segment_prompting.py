"""Test-time prompting and 3D voting, with a stand-in mask model that answers from the
ground-truth masks: the voting must recover one label per rigid part, the same in every
view, and must not be thrown by masks that are wrong in some views."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.predictors.data import ajar_configuration
from pipeline.procedural import generate
from pipeline.render import render_object
from pipeline.segment import segment
from pipeline.segment.evaluate import matched_part_iou
from pipeline.segment.features import (
    SIZE,
    frame_features,
    object_window,
    sample_nearest,
    whole_view,
)
from pipeline.segment.prompting import segment_capture


class MaskOracle:
    """Answers every prompt with the true mask of the part under it; ``corrupt`` is the
    share of masks replaced by the union of that part and a random other one, with a
    low stated quality (as a real model's doubtful masks)."""

    name = "oracle"

    def __init__(self, corrupt: float = 0.0, seed: int = 0):
        self.corrupt = corrupt
        self.rng = np.random.default_rng(seed)

    def set_views(self, frames):
        self.frames = frames

    def predict(self, view, prompts_uv, query_uv):
        mask = self.frames[view].mask
        h, w = mask.shape

        def label(uv):
            col = np.clip(np.floor(uv[:, 0]).astype(int), 0, w - 1)
            row = np.clip(np.floor(uv[:, 1]).astype(int), 0, h - 1)
            return mask[row, col]

        at, query = label(prompts_uv), label(query_uv)
        probs = ((query[None] == at[:, None]) & (at[:, None] > 0)).astype(float)
        quality = np.full(len(at), 0.95)
        parts = np.unique(mask[mask > 0])
        for i in np.nonzero(self.rng.random(len(at)) < self.corrupt)[0]:
            probs[i] = np.maximum(probs[i], query == self.rng.choice(parts))
            quality[i] = 0.2
        return probs, quality


@pytest.fixture(scope="module")
def cabinet_capture():
    obj = generate("storage_furniture", 9, 3)
    q = ajar_configuration(obj, np.random.default_rng(3))
    return render_object(obj, q=q, views=12, width=160, height=160, seed=1)


def _truth(capture):
    return [f.mask for f in capture.frames]


def test_oracle_masks_give_one_label_per_part(cabinet_capture):
    seg = segment_capture(cabinet_capture, MaskOracle())
    assert seg.n_parts == len(cabinet_capture.parts)
    assert seg.details["detached_points_moved"] <= 0.001 * seg.details["cloud_points"]
    mean, per_part = matched_part_iou(seg.labels, _truth(cabinet_capture))
    assert min(per_part.values()) > 0.95, per_part
    for lab, frame in zip(seg.labels, cabinet_capture.frames, strict=True):
        assert np.array_equal(lab > 0, frame.depth > 0)  # every measured pixel labelled
    # the next stage, compartments behind open doors back to the carcass, keeps exact parts
    from pipeline.compartments import return_to_carcass

    after = return_to_carcass(cabinet_capture, seg)
    assert after.n_parts == seg.n_parts and after.details["returned_to_carcass"] == []
    assert np.array_equal(after.point_labels, seg.point_labels)
    assert all(np.array_equal(a, b) for a, b in zip(after.labels, seg.labels, strict=True))


def test_doubtful_wrong_masks_are_outvoted(cabinet_capture):
    seg = segment_capture(cabinet_capture, MaskOracle(corrupt=0.25, seed=1))
    assert seg.n_parts == len(cabinet_capture.parts)
    assert matched_part_iou(seg.labels, _truth(cabinet_capture))[0] > 0.95


def test_ground_truth_mode_uses_the_masks(cabinet_capture):
    seg = segment(cabinet_capture, "gt")
    assert seg.method == "gt" and seg.n_parts == len(cabinet_capture.parts)
    from pipeline.compartments import return_to_carcass

    assert return_to_carcass(cabinet_capture, seg) is seg  # the capture's masks: nothing to do
    assert matched_part_iou(seg.labels, _truth(cabinet_capture))[0] == 1.0


def test_metric_scores_a_merge_and_a_split():
    truth = [np.array([[1, 1, 2, 2], [3, 3, 0, 0]])]
    assert matched_part_iou(truth, truth) == (1.0, {1: 1.0, 2: 1.0, 3: 1.0})
    merged = [np.array([[1, 1, 1, 1], [3, 3, 0, 0]])]  # parts 1 and 2 as one
    mean, per = matched_part_iou(merged, truth)
    assert per[3] == 1.0 and sorted([per[1], per[2]]) == [0.0, 0.5]


def test_model_grid_maps_capture_pixels(cabinet_capture):
    frame = cabinet_capture.frames[0]
    h, w = frame.mask.shape
    rows, cols = np.nonzero(frame.mask)
    window = object_window(frame.depth)
    # the object's window: the object fills the grid, with a margin
    side = window.scale * SIZE
    assert max(np.ptp(rows) + 1, np.ptp(cols) + 1) < side < 1.2 * max(h, w)
    assert window.u0 < cols.min() and window.u0 + side > cols.max() + 1
    for win in (window, whole_view(h, w)):
        grid = sample_nearest(frame.mask, win)
        pick = np.random.default_rng(0).choice(len(rows), 300, replace=False)
        uv = np.stack([cols[pick] + 0.5, rows[pick] + 0.5], 1)
        model = np.floor(win.to_model(uv)).astype(int)
        # nearest sampling: at least the interior of each part keeps its label on the grid
        agree = grid[model[:, 1], model[:, 0]] == frame.mask[rows[pick], cols[pick]]
        assert agree.mean() > 0.9
    features = frame_features(frame)
    assert features.shape == (10, SIZE, SIZE) and np.isfinite(features).all()
    valid = features[4] > 0
    assert valid.mean() > 0.3  # the object fills its window
    normals = features[5:8][:, valid]
    assert np.allclose(np.linalg.norm(normals, axis=0)[np.linalg.norm(normals, axis=0) > 0], 1,
                       atol=1e-5)


def test_normals_of_a_flat_panel_are_exact_wherever_the_window_falls():
    """A plane seen at a slant: the normals the network sees are the plane's, for windows
    whose pixels fall anywhere on the capture's pixel grid (points are computed through the
    sampled pixels' own centres)."""
    from pipeline.capture import Camera
    from pipeline.segment.features import Window, grid_features, pixel_rays, sample_rgb

    cam = Camera(200.0, 200.0, 96.0, 96.0, 192, 192)
    normal = np.array([0.3, -0.2, 0.93])
    normal /= np.linalg.norm(normal)  # the plane n . p = d, in front of the camera
    u, v = np.meshgrid(np.arange(192) + 0.5, np.arange(192) + 0.5)
    ray = np.stack([(u - cam.cx) / cam.fl_x, -(v - cam.cy) / cam.fl_y, -np.ones_like(u)], -1)
    depth = (-2.0 / (ray @ normal)).astype(np.float32)  # z-depth where each ray meets it
    rgb = np.full((192, 192, 3), 128, np.uint8)
    for window in (Window(10.3, 7.9, 1.37), Window(0.0, 0.0, 1.5), Window(31.7, 2.2, 0.91),
                   Window(12.0, 9.0, 1.2, 0.1)):
        rays = pixel_rays(cam.fl_x, cam.fl_y, cam.cx, cam.cy, window, 192, 192)
        f = grid_features(sample_rgb(rgb, window), sample_nearest(depth, window), rays)
        n = f[5:8].reshape(3, -1)
        n = n[:, np.linalg.norm(n, axis=0) > 0]
        assert n.shape[1] > 1000
        c, s = np.cos(window.angle), np.sin(window.angle)  # a turned window: the camera turned
        seen = np.array([c * normal[0] - s * normal[1], s * normal[0] + c * normal[1], normal[2]])
        assert np.abs(n.T @ seen).min() > 1 - 1e-4


def test_a_turned_window_maps_its_own_pixels_back():
    from pipeline.segment.features import Window

    window = Window(20.5, -3.0, 1.3, np.radians(4.0))
    centres = window.source_centres()
    grid = (np.arange(SIZE) + 0.5)
    np.testing.assert_allclose(window.to_model(centres.reshape(-1, 2)).reshape(SIZE, SIZE, 2),
                               np.stack(np.meshgrid(grid, grid), -1), atol=1e-9)


def test_the_cameras_up_is_found_and_rolled_views_are_turned_upright():
    """Upright cameras (ring, half ring, the front arc) get no turn at all; cameras rolled a
    few degrees each get much of their roll back (the world's up from their x axes, least
    squares);
    and a rolled view seen through its turned window is the upright view: the same pixels,
    colours and normals (nearest sampling moves only the silhouette's pixels)."""
    from pipeline.camera_paths import _rolled, camera_path, look_at
    from pipeline.capture import Frame
    from pipeline.render import Raycaster, default_camera
    from pipeline.segment.features import upright_angles
    from real2code_export.kinematics import world_part_meshes

    cam = default_camera(160, 160)
    rng = np.random.default_rng(0)
    for path in ("ring", "half-ring", "front-arc"):
        poses = camera_path(path, np.zeros(3), 0.5, cam, 8, rng, front=np.array([1.0, 0, 0]))
        frames = [Frame(cam, p, None, None) for p in poses]
        assert upright_angles(frames) == [0.0] * 8
    rolls = np.radians(rng.normal(0.0, 4.0, 12))
    poses = camera_path("ring", np.zeros(3), 0.5, cam, 12, rng)
    frames = [Frame(cam, _rolled(p, r), None, None) for p, r in zip(poses, rolls, strict=True)]
    found = np.array(upright_angles(frames))
    # up is estimated from the rolled views themselves, and a tilt of it absorbs the part
    # of the rolls that varies with the azimuth as its sine (2 of 12 degrees of freedom):
    # the rest of each roll comes back
    assert np.sqrt(np.mean((found - rolls) ** 2)) < 0.75 * np.sqrt(np.mean(rolls ** 2))

    cabinet = generate("storage_furniture", 4, 3)
    meshes = world_part_meshes(cabinet, cabinet.observed_configuration(), np.eye(4))
    names = [p.name for p in cabinet.parts if p.name in meshes]
    caster = Raycaster([meshes[n] for n in names], [p.color for p in cabinet.parts
                                                    if p.name in meshes])
    points = np.concatenate([meshes[n].vertices for n in names])
    centre = (points.min(0) + points.max(0)) / 2
    pose = look_at(centre + np.array([1.8, -1.2, 1.0]), centre)
    views = []
    for roll in (0.0, np.radians(6.0)):
        rgb, depth, mask = caster.render(cam, _rolled(pose, roll))
        views.append(Frame(cam, _rolled(pose, roll), rgb, depth, mask))
    upright = frame_features(views[0], object_window(views[0].depth))
    for angle, agree in ((np.radians(6.0), 0.98), (0.0, None)):
        rolled = frame_features(views[1], object_window(views[1].depth, angle=angle))
        same = np.mean((upright[4] > 0) == (rolled[4] > 0))
        if agree is None:  # not turned: another view
            assert same < 0.96
            continue
        both = (upright[4] > 0) & (rolled[4] > 0)
        assert same > agree
        assert np.median(np.abs(upright[5:8] - rolled[5:8]).max(0)[both]) < 1e-3
        assert np.percentile(np.abs(upright[0:3] - rolled[0:3]).max(0)[both], 90) < 0.02


def test_smoothing_clears_speckle_and_keeps_crisp_borders():
    """Two parts split a plate at x = 0; on the left a third, doubtful segment scores a
    little higher than the true part on every third point. Without smoothing it claims
    those points as speckle; with it the left half is one part, and the crisp border
    between the true parts stays exactly where the scores put it."""
    from pipeline.segment.prompting import PromptingOptions, assign

    xs, ys = np.meshgrid(np.linspace(-1, 1, 40), np.linspace(-1, 1, 40))
    cloud = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)], 1)
    left = cloud[:, 0] < 0
    speckle = left & (np.random.default_rng(0).random(len(cloud)) < 0.3)
    score = np.zeros((3, len(cloud)))
    score[0] = np.where(left, np.where(speckle, 0.85, 0.9), 0.0)
    score[1] = np.where(left, 0.0, 1.0)
    score[2] = np.where(speckle, 0.9, np.where(left, 0.85, 0.0))
    raw = assign(score, cloud, min_points=5)
    assert raw.max() == 3
    options = PromptingOptions()  # the shipped smoothing
    smooth = assign(score, cloud, min_points=5, neighbours=options.smoothing_neighbours,
                    rounds=options.smoothing_rounds)
    assert smooth.max() == 2
    assert len(np.unique(smooth[left])) == 1 and len(np.unique(smooth[~left])) == 1
    assert smooth[left][0] != smooth[~left][0]


def _grid(u, v, corner, du, dv, step=0.02):
    """Points on the rectangle corner + s du + t dv, s in [0, u], t in [0, v]."""
    s, t = np.meshgrid(np.arange(0, u + 1e-9, step), np.arange(0, v + 1e-9, step))
    return (np.asarray(corner) + s.reshape(-1, 1) * np.asarray(du)
            + t.reshape(-1, 1) * np.asarray(dv))


def test_compartment_behind_a_swung_door_goes_back_to_the_carcass():
    """A carcass open at the front (x = 0.3), a door swung 40 degrees about its hinge whose
    label also took half the carcass's back wall (the compartment seen past it), and a
    drawer pulled out square to the carcass with its bottom inside: the back wall goes
    back to the carcass; the door's panel, the drawer and the rest stay as they were."""
    from pipeline.compartments import return_compartments

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    back = _grid(0.8, 0.8, (-0.3, -0.4, -0.4), y, z)
    walls = [_grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, z), _grid(0.6, 0.8, (-0.3, 0.4, -0.4), x, z),
             _grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, y), _grid(0.6, 0.8, (-0.3, -0.4, 0.4), x, y)]
    a = np.radians(40)
    door = _grid(0.8, 0.8, (0.3, -0.4, -0.4), (np.sin(a), np.cos(a), 0), z)
    drawer = np.concatenate([_grid(0.3, 0.2, (0.45, 0.05, -0.3), y, z),  # front
                             _grid(0.5, 0.3, (-0.05, 0.05, -0.3), x, y)])  # bottom, inside
    cloud = np.concatenate([back, *walls, door, drawer])
    truth = np.concatenate([np.ones(len(back) + sum(map(len, walls)), int),
                            np.full(len(door), 2), np.full(len(drawer), 3)])
    labels = truth.copy()
    bled = back[:, 1] < 0.0  # the door's masks took the back wall behind it
    labels[:len(back)][bled] = 2
    out, moved = return_compartments(cloud, labels, voxel=0.02)
    assert np.array_equal(out, truth)
    assert moved == [{"part": 2, "points": int(bled.sum()), "panel_turn_deg": 40.0}]
    # exact parts, and a door left closed, are left alone
    assert np.array_equal(return_compartments(cloud, truth, voxel=0.02)[0], truth)
    closed = truth.copy()
    closed[:len(back)][bled] = 2
    shut = cloud.copy()
    shut[truth == 2] = _grid(0.8, 0.8, (0.3, -0.4, -0.4), y, z)
    assert np.array_equal(return_compartments(shut, closed, voxel=0.02)[0], closed)
    # with measured normals: the door's panel faces along its plane and still counts ...
    normals = np.zeros_like(cloud)
    normals[:len(back)] = x
    normals[truth == 2] = (np.cos(a), -np.sin(a), 0)
    normals[truth == 3] = z
    assert np.array_equal(return_compartments(cloud, labels, 0.02, normals=normals)[0], truth)
    # ... while a plane whose points face elsewhere (RANSAC across a box's edges) does not
    normals[truth == 2] = x
    assert np.array_equal(return_compartments(cloud, labels, 0.02, normals=normals)[0], labels)


def test_a_swung_doors_edges_beside_its_hinge_stay_with_the_door():
    """A door swung 15 degrees: its top and bottom edges (facing up and down, along the
    carcass's axis) lie inside the carcass's box beside the hinge, as does the compartment's
    floor behind the door near the plane; the edges touch the door's panel and stay, the
    floor goes to the carcass (where it touches the door's panel it would stay)."""
    from pipeline.compartments import return_compartments

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    a = np.radians(15)
    along, facing = np.array((np.sin(a), np.cos(a), 0)), np.array((np.cos(a), -np.sin(a), 0))
    body = [_grid(0.8, 0.8, (-0.3, -0.4, -0.4), y, z), _grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, z),
            _grid(0.6, 0.8, (-0.3, 0.4, -0.4), x, z), _grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, y),
            _grid(0.6, 0.8, (-0.3, -0.4, 0.4), x, y)]
    door = _grid(0.8, 0.8, (0.3, -0.4, -0.4), along, z)
    edges = [_grid(0.8, 0.04, (0.3, -0.4, h), along, -facing) for h in (-0.4, 0.4)]
    cloud = np.concatenate([*body, door, *edges])
    n_body = sum(map(len, body))
    truth = np.concatenate([np.ones(n_body, int), np.full(len(cloud) - n_body, 2)])
    normals = np.concatenate([np.tile(x, (len(body[0]), 1)), np.tile(y, (len(body[1]), 1)),
                              np.tile(y, (len(body[2]), 1)), np.tile(z, (len(body[3]), 1)),
                              np.tile(z, (len(body[4]), 1)), np.tile(facing, (len(door), 1)),
                              np.tile(z, (sum(map(len, edges)), 1))]).astype(float)
    labels = truth.copy()
    floor = np.zeros(len(cloud), bool)
    floor[sum(map(len, body[:3])):sum(map(len, body[:4]))] = True
    # the floor behind the door beside its hinge, from three spacings off the door's points
    bled = floor & (cloud[:, 0] > 0.1) & (cloud[:, 0] < 0.25) & (cloud[:, 1] < 0.0)
    labels[bled] = 2
    hinge_edges = (truth == 2) & (normals[:, 2] == 1) & (cloud[:, 0] < 0.32)
    assert hinge_edges.sum() >= 10  # the edges inside the carcass's box (grown one spacing)
    out, moved = return_compartments(cloud, labels, 0.02, normals=normals)
    assert np.array_equal(out, truth)
    assert moved[0]["points"] == bled.sum()


def test_a_drawer_behind_a_swung_door_past_the_walls_is_no_compartment():
    """A carcass open at the front (x = 0.3), a door swung 25 degrees, and behind its swing
    a drawer pulled 14 cm out. The door's label took the drawer and half the back wall (the
    compartment seen past it); the carcass's label took a strip of the door, so its box
    reaches 34 cm past the walls. The back wall goes back to the carcass; the drawer's
    front and what of it lies past the walls (where no compartment is) become a part of
    their own; its bottom inside the walls goes to the carcass as before."""
    from pipeline.compartments import return_compartments

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    a = np.radians(25)
    along, facing = np.array((np.sin(a), np.cos(a), 0)), np.array((np.cos(a), -np.sin(a), 0))
    carcass = [(_grid(0.8, 0.8, (-0.3, -0.4, -0.4), y, z), x),
               (_grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, z), y),
               (_grid(0.6, 0.8, (-0.3, 0.4, -0.4), x, z), y),
               (_grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, y), z),
               (_grid(0.6, 0.8, (-0.3, -0.4, 0.4), x, y), z)]
    door = (_grid(0.8, 0.8, (0.3, -0.4, -0.4), along, z), facing)
    drawer = [(_grid(0.24, 0.2, (0.44, 0.1, -0.3), y, z), x),  # its front, 14 cm out
              (_grid(0.63, 0.24, (-0.19, 0.1, -0.3), x, y), z)]  # its bottom
    cloud, normals = _facing(*carcass, door, *drawer)
    n_carcass = sum(len(p) for p, _ in carcass)
    n_door = len(door[0])
    truth = np.r_[np.ones(n_carcass, int), np.full(n_door, 2),
                  np.full(len(cloud) - n_carcass - n_door, 3)]
    labels = truth.copy()
    labels[truth == 3] = 2  # the door's masks took the drawer ...
    bled = (np.arange(len(cloud)) < len(carcass[0][0])) & (cloud[:, 1] > 0.0)
    labels[bled] = 2  # ... and the back wall past it
    strip = (truth == 2) & (cloud[:, 2] > 0.35)
    labels[strip] = 1  # the carcass's masks took the door's top edge
    assert cloud[strip][:, 0].max() > 0.6
    out, moved = return_compartments(cloud, labels, 0.02, normals=normals)
    past = (truth == 3) & (cloud[:, 0] > 0.34)
    assert (out[bled] == 1).all() and (out[(truth == 3) & ~past] == 1).all()
    assert len(set(out[past])) == 1 and out[past][0] not in (1, out[truth == 2][0])
    assert (out[(truth == 2) & ~strip] == out[truth == 2][0]).all()
    assert moved[0] == {"part": int(labels.max()) + 1, "points": int(past.sum()),
                        "past_walls_of": 2}
    # without measured normals the walls are not found: all of it goes back, as before
    out = return_compartments(cloud, labels, 0.02)[0]
    assert (out[truth == 3] == 1).all()


def test_a_drawer_behind_a_swung_door_standing_out_of_the_box_is_a_part():
    """A carcass open at the front (x = 0.3), a door swung 25 degrees, and behind its swing
    a drawer pulled 14 cm out. The door's label took the drawer and half the back wall;
    the carcass's label ends at its front. The back wall goes back to the carcass; the
    drawer, its front and bottom past the box and its bottom inside it (within the front's
    outline, linked to it), is a part of its own, not the carcass's compartment. A handle
    standing 8 cm off the door, past the box too, reaches nothing inside: it stays; so do
    the door's own shelves, which stand out farther than they reach in."""
    from pipeline.compartments import return_compartments

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    a = np.radians(25)
    along, facing = np.array((np.sin(a), np.cos(a), 0)), np.array((np.cos(a), -np.sin(a), 0))
    carcass = [(_grid(0.8, 0.8, (-0.3, -0.4, -0.4), y, z), x),
               (_grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, z), y),
               (_grid(0.6, 0.8, (-0.3, 0.4, -0.4), x, z), y),
               (_grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, y), z),
               (_grid(0.6, 0.8, (-0.3, -0.4, 0.4), x, y), z)]
    door = (_grid(0.8, 0.8, (0.3, -0.4, -0.4), along, z), facing)
    drawer = [(_grid(0.24, 0.2, (0.44, 0.1, -0.3), y, z), x),  # its front, 14 cm out
              (_grid(0.63, 0.24, (-0.19, 0.1, -0.3), x, y), z)]  # its bottom
    handle = (_grid(0.06, 0.2, np.array((0.3, -0.4, -0.1)) + 0.3 * along + 0.08 * facing,
                    along, z), facing)
    cloud, normals = _facing(*carcass, door, *drawer, handle)
    n_carcass = sum(len(p) for p, _ in carcass)
    n_door, n_drawer = len(door[0]), sum(len(p) for p, _ in drawer)
    truth = np.r_[np.ones(n_carcass, int), np.full(n_door, 2), np.full(n_drawer, 3),
                  np.full(len(handle[0]), 2)]
    labels = truth.copy()
    labels[truth == 3] = 2  # the door's masks took the drawer ...
    bled = (np.arange(len(cloud)) < len(carcass[0][0])) & (cloud[:, 1] > 0.0)
    labels[bled] = 2  # ... and the back wall past it
    assert (cloud[truth == 3][:, 0] > 0.32).sum() >= 30  # past the box's front
    out, moved = return_compartments(cloud, labels, 0.02, normals=normals)
    assert (out[bled] == 1).all()
    assert len(set(out[truth == 3])) == 1 and out[truth == 3][0] not in (1, out[truth == 2][0])
    assert (out[truth == 2] == out[truth == 2][0]).all()  # the door with its handle
    assert moved[0] == {"part": int(labels.max()) + 1, "points": n_drawer,
                        "standing_out_of": 2}
    # the door's own shelves on its inner face, swung with it: they stand out far past the
    # face and touch the box beside the hinge only; no part of their own
    hinge = np.array((0.3, -0.4, 0.0))
    shelves = [(_grid(0.7, 0.1, hinge + (0, 0, h) + 0.05 * along, along, -facing), z)
               for h in (-0.2, 0.2)]
    lips = [(_grid(0.7, 0.06, hinge + (0, 0, h) + 0.05 * along - 0.1 * facing, along, z),
             facing) for h in (-0.2, 0.2)]
    inner, inner_normals = _facing(*carcass, door, *shelves, *lips)
    on_door = np.r_[np.ones(n_carcass, int), np.full(len(inner) - n_carcass, 2)]
    on_door[:len(carcass[0][0])][carcass[0][0][:, 1] > 0.0] = 2
    shelf = np.arange(len(inner)) >= n_carcass + n_door
    assert (inner[shelf][:, 0] < 0.32).sum() >= 30 and (inner[shelf][:, 0] > 0.32).sum() >= 30
    moved = return_compartments(inner, on_door, 0.02, normals=inner_normals)[1]
    assert not any("standing_out_of" in m for m in moved)
    # the drawer shut behind the door: nothing stands out, it goes back with the wall
    shut = cloud.copy()
    shut[truth == 3, 0] -= 0.14
    out, moved = return_compartments(shut, labels, 0.02, normals=normals)
    assert not any("standing_out_of" in m for m in moved)
    assert (out[truth == 3] == 1).mean() > 0.95 and len(np.unique(out)) == 2


def _panel(x0, x1, z0, z1, y, step):
    xs, zs = np.meshgrid(np.arange(x0, x1, step), np.arange(z0, z1, step))
    return np.column_stack([xs.ravel(), np.full(xs.size, y), zs.ravel()])


def test_a_patch_cut_off_from_its_part_goes_to_the_part_it_touches():
    from pipeline.segment.pieces import reassign_detached

    step = 0.01
    front = _panel(0.0, 1.0, 0.0, 0.6, 0.0, step)  # a carcass's front
    drawer = _panel(0.3, 0.7, 0.2, 0.4, -0.1, step)  # a drawer pulled 10 cm out of it
    lone = _panel(3.0, 3.1, 0.0, 0.1, 0.0, step)  # a speck touching nothing
    cloud = np.concatenate([front, drawer, lone])
    labels = np.concatenate([np.ones(len(front), int), np.full(len(drawer), 2),
                             np.full(len(lone), 2)])
    patch = ((np.abs(cloud[:, 0] - 0.1) < 0.05) & (np.abs(cloud[:, 2] - 0.5) < 0.05)
             & (cloud[:, 1] == 0.0))
    labels[patch] = 2  # the drawer's masks strayed onto the carcass's front beside it
    out, moved = reassign_detached(cloud, labels, step)
    assert np.all(out[patch] == 1)  # back to the carcass, which surrounds it
    assert np.all(out[len(front):len(front) + len(drawer)] == 2)  # the drawer keeps its own
    assert np.all(out[-len(lone):] == 2)  # touching no other part, the speck stays
    assert moved == [{"from": 2, "to": 1, "points": int(patch.sum())}]
    # the carcass keeps its own pieces, even one lying in a drawer's front
    kept = labels.copy()
    kept[(cloud[:, 1] == -0.1) & (cloud[:, 0] < 0.4)] = 1
    assert all(m["from"] != 1 for m in reassign_detached(cloud, kept, step)[1])
    # a second piece as big as the main one is not a stray patch: nothing moves
    halves = np.where(cloud[:, 0] < 0.5, 1, 2)[: len(front)]
    assert reassign_detached(front, halves, step)[1] == []


def test_a_small_part_inside_the_carcass_box_is_the_carcass():
    """A patch of a carcass's top cut out as a part of its own goes back to the carcass; a
    drawer pulled out of it (outside the box) and a large part inside it stay."""
    from pipeline.compartments import return_enclosed

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    shell = np.concatenate([_grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, z),
                            _grid(0.6, 0.8, (-0.3, 0.4, -0.4), x, z),
                            _grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, y),
                            _grid(0.6, 0.8, (-0.3, -0.4, 0.4), x, y),
                            _grid(0.8, 0.8, (-0.3, -0.4, -0.4), y, z)])
    drawer = np.concatenate([_grid(0.3, 0.2, (0.45, 0.05, -0.3), y, z),  # front, 15 cm out
                             _grid(0.5, 0.3, (-0.05, 0.05, -0.3), x, y)])
    cloud = np.concatenate([shell, drawer])
    truth = np.concatenate([np.ones(len(shell), int), np.full(len(drawer), 2)])
    labels = truth.copy()
    patch = (cloud[:, 2] == 0.4) & (np.abs(cloud[:, 0]) < 0.07) & (np.abs(cloud[:, 1]) < 0.07)
    labels[patch] = 3
    out, moved = return_enclosed(cloud, labels, voxel=0.02)
    assert np.array_equal(out, truth)
    assert moved == [{"part": 3, "points": int(patch.sum()), "enclosed": True}]
    assert np.array_equal(return_enclosed(cloud, truth, voxel=0.02)[0], truth)  # exact parts
    side = (cloud[:, 1] == 0.4) & (truth == 1)  # a whole side wall: too large to be a patch
    whole = truth.copy()
    whole[side] = 3
    assert return_enclosed(cloud, whole, voxel=0.02)[1] == []
    # the carcass cut in two (as the masks cut real cabinets): a side with the floor under
    # it, thick along every axis of the box, goes back; the side wall above, thin across
    # it, stayed
    cut = truth.copy()
    cut[(truth == 1) & (cloud[:, 1] > -0.1) & (cloud[:, 2] < 0.4) & (cloud[:, 0] > -0.3)] = 3
    out, moved = return_enclosed(cloud, cut, voxel=0.02)
    assert np.array_equal(out, truth)
    assert [m.get("thick") for m in moved] == [True]
    # with a few of the drawer's points (5 %) mixed in, out of the box, it still goes back,
    # those to the drawer
    mixed = cut.copy()
    mixed[np.nonzero((truth == 2) & (cloud[:, 0] > 0.4))[0][:int(0.05 * (cut == 3).sum())]] = 3
    assert 0.9 < np.mean(np.abs(cloud[mixed == 3, 0]) <= 0.32) < 0.98
    out, moved = return_enclosed(cloud, mixed, voxel=0.02)
    assert np.array_equal(out, truth)
    assert [m.get("thick") for m in moved] == [True]


def test_an_open_panels_strip_in_other_labels_goes_to_the_panel():
    """A flap tipped 40 degrees forward about its bottom edge on a carcass's front: the strip
    beside its hinge went to the carcass's label and its upper half to a second label that
    also holds another panel (two flaps sharing a label, one of them cut in two). The
    strip and the half, on the flap's plane, facing along it and joined to it, go to the
    flap; the carcass's walls (square to it) and the other panel stay."""
    from pipeline.compartments import claim_panels

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    back = _grid(0.8, 0.8, (-0.3, -0.4, -0.4), y, z)
    walls = [_grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, z), _grid(0.6, 0.8, (-0.3, 0.4, -0.4), x, z),
             _grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, y), _grid(0.6, 0.8, (-0.3, -0.4, 0.4), x, y)]
    a = np.radians(40)
    up = (np.sin(a), 0, np.cos(a))  # along the tipped flap, from its hinge at z = 0
    flap = _grid(0.8, 0.36, (0.3, -0.4, 0.0), y, up)
    other = _grid(0.8, 0.3, (0.3, -0.4, -0.35), y, z)  # a panel shut below it
    cloud = np.concatenate([back, *walls, flap, other])
    n_carcass = len(back) + sum(map(len, walls))
    truth = np.concatenate([np.ones(n_carcass, int), np.full(len(flap), 2),
                            np.full(len(other), 3)])
    normals = np.concatenate([np.tile(x, (len(back), 1)), np.tile(y, (len(walls[0]), 1)),
                              np.tile(y, (len(walls[1]), 1)), np.tile(z, (len(walls[2]), 1)),
                              np.tile(z, (len(walls[3]), 1)),
                              np.tile((np.cos(a), 0, -np.sin(a)), (len(flap), 1)),
                              np.tile(x, (len(other), 1))]).astype(float)
    along = (flap - (0.3, 0, 0)) @ np.asarray(up)
    labels = truth.copy()
    labels[n_carcass:n_carcass + len(flap)][along < 0.08] = 1  # the strip by the hinge
    labels[n_carcass:n_carcass + len(flap)][along > 0.2] = 3  # the upper half
    out, moved = claim_panels(cloud, labels, 0.02, normals=normals)
    kept = out[n_carcass:n_carcass + len(flap)]
    assert (kept == kept[len(kept) // 2]).all() and kept[0] not in (out[0], out[-1])
    assert np.array_equal(out[:n_carcass] == out[0], np.ones(n_carcass, bool))  # walls stay
    assert (out[-len(other):] == out[-1]).all() and out[-1] != out[0]
    assert sorted(m["claimed_from"] for m in moved) == [1, 3]
    # exact parts are left alone; without measured normals nothing is claimed
    assert np.array_equal(claim_panels(cloud, truth, 0.02, normals=normals)[0], truth)
    assert claim_panels(cloud, labels, 0.02)[1] == []


def test_a_door_swung_a_few_degrees_past_its_neighbour_on_one_hinge_line_keeps_its_label():
    """Two doors on one hinge line at a carcass's front, open 78 and 83 degrees: the first
    is a turned panel (12 degrees off the carcass's axes), the second is not (7 degrees)
    and lies within a few centimetres of the first's plane, facing along it, touching it
    at the hinge. It is a panel of its own beside the first, not a piece of it: a
    neighbour's claim never takes most of a moving part's label (``claim_most``; a
    procedural cabinet's such door lost 726 of its 764 points). A strip of it is still
    claimed when the rest stays."""
    from pipeline.compartments import claim_panels

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    back = _grid(0.8, 0.8, (-0.3, -0.4, -0.4), y, z)
    walls = [_grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, z), _grid(0.6, 0.8, (-0.3, 0.4, -0.4), x, z),
             _grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, y), _grid(0.6, 0.8, (-0.3, -0.4, 0.4), x, y)]

    def door(degrees, z0):
        a = np.radians(degrees)  # swung from lying along +y across the front
        return (_grid(0.34, 0.38, (0.31, -0.4, z0), (np.sin(a), np.cos(a), 0), z),
                (np.cos(a), -np.sin(a), 0))

    (lower, n_lower), (upper, n_upper) = door(78, -0.4), door(83, 0.0)
    cloud = np.concatenate([back, *walls, lower, upper])
    n_carcass = len(back) + sum(map(len, walls))
    normals = np.concatenate([np.tile(x, (len(back), 1)), np.tile(y, (len(walls[0]), 1)),
                              np.tile(y, (len(walls[1]), 1)), np.tile(z, (len(walls[2]), 1)),
                              np.tile(z, (len(walls[3]), 1)), np.tile(n_lower, (len(lower), 1)),
                              np.tile(n_upper, (len(upper), 1))]).astype(float)
    labels = np.concatenate([np.ones(n_carcass, int), np.full(len(lower), 2),
                             np.full(len(upper), 3)])
    out, moved = claim_panels(cloud, labels, 0.02, normals=normals)
    assert np.array_equal(out, labels) and moved == []
    # the same upper door with most of it in the carcass's label: what is left of its own
    # label (a strip at its free edge) still keeps it; the carcass's share is claimed
    split = labels.copy()
    upper_at = np.arange(n_carcass + len(lower), len(cloud))
    split[upper_at[(upper[:, 0] - 0.31) < 0.2]] = 1
    out, moved = claim_panels(cloud, split, 0.02, normals=normals)
    assert [m["claimed_from"] for m in moved] == [1]
    assert (out[upper_at[(upper[:, 0] - 0.31) >= 0.2]] != out[n_carcass]).all()


def test_two_flaps_on_one_rail_swung_opposite_ways_in_one_label_are_two_parts():
    """Two flaps on one rail across a carcass's open front, the upper one tipped 20 degrees
    forward about its bottom edge and the lower one 20 degrees about its top edge, in one
    label (the noise-trained masks on the room demo capture): two turned panels 40 degrees
    apart, each flap wide both ways, so the label is split, every point to its flap. One
    flap with its back face (parallel), its edges (strips) and the compartment floor behind
    it (square to the carcass) in its label is one panel and stays; so does a label of two
    flaps tipped alike (one plane), and nothing splits without measured normals."""
    from pipeline.compartments import CompartmentOptions, split_panels

    x, y, z = np.eye(3)
    a = np.radians(20)
    up, down = np.array((np.sin(a), 0, np.cos(a))), np.array((np.sin(a), 0, -np.cos(a)))
    out_up, out_down = np.array((np.cos(a), 0, -np.sin(a))), np.array((np.cos(a), 0, np.sin(a)))
    carcass = [(_grid(0.8, 0.8, (-0.3, -0.4, -0.4), y, z), x),
               (_grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, z), y),
               (_grid(0.6, 0.8, (-0.3, 0.4, -0.4), x, z), y),
               (_grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, y), z),
               (_grid(0.6, 0.8, (-0.3, -0.4, 0.4), x, y), z)]
    upper = (_grid(0.8, 0.38, (0.3, -0.4, 0.02), y, up), out_up)
    lower = (_grid(0.8, 0.38, (0.3, -0.4, -0.02), y, down), out_down)
    cloud, normals = _facing(*carcass, upper, lower)
    n_carcass = sum(len(p) for p, _ in carcass)
    truth = np.concatenate([np.ones(n_carcass, int), np.full(len(upper[0]), 2),
                            np.full(len(lower[0]), 3)])
    labels = np.minimum(truth, 2)  # both flaps in one label
    out, moved = split_panels(cloud, labels, 0.02, normals=normals)
    assert np.array_equal(out, truth)
    assert moved == [{"part": 2, "points": len(lower[0]), "panels_apart_deg": 40.0}]
    # with the rule asked for panels farther apart than these, they stay one label
    far = CompartmentOptions(panels_apart_deg=45.0)
    assert split_panels(cloud, labels, 0.02, far, normals)[1] == []
    assert split_panels(cloud, labels, 0.02)[1] == []  # no measured normals
    # the largest label one panel (a box's lid swung open, its body's walls in the other
    # labels): measured against it every wall is turned, so nothing is read as two panels
    rim = (_grid(0.04, 0.8, (-0.34, -0.4, -0.4), x, z), y)  # the lid's rim, a strip
    cloud, normals = _facing(carcass[0], rim, *carcass[1:], upper, lower)
    n_lid = len(carcass[0][0]) + len(rim[0])
    lid_labels = np.concatenate([np.ones(n_lid, int), np.full(n_carcass - len(carcass[0][0]), 3),
                                 np.full(len(upper[0]) + len(lower[0]), 2)])
    assert split_panels(cloud, lid_labels, 0.02, normals=normals)[1] == []
    # one flap 4 cm thick: its back face, its top edge (a strip, turned too) and the
    # compartment's floor behind it in its label are no second panel
    back = (upper[0] - 0.04 * out_up, -out_up)
    edge = (_grid(0.8, 0.04, (0.3, -0.4, 0.02) + 0.38 * up, y, -out_up), up)
    floor = (_grid(0.3, 0.8, (-0.25, -0.4, -0.38), x, y), z)
    cloud, normals = _facing(*carcass, upper, back, edge, floor)
    labels = np.concatenate([np.ones(n_carcass, int), np.full(len(cloud) - n_carcass, 2)])
    assert split_panels(cloud, labels, 0.02, normals=normals)[1] == []
    # two flaps side by side on the rail, tipped alike: one plane, one label stays
    left = (_grid(0.38, 0.38, (0.3, -0.4, 0.02), y, up), out_up)
    right = (_grid(0.38, 0.38, (0.3, 0.02, 0.02), y, up), out_up)
    cloud, normals = _facing(*carcass, left, right)
    labels = np.concatenate([np.ones(n_carcass, int), np.full(len(cloud) - n_carcass, 2)])
    assert split_panels(cloud, labels, 0.02, normals=normals)[1] == []


def test_a_handle_and_a_flaps_edge_standing_out_of_the_carcass_go_to_the_flap():
    """A flap tipped 40 degrees forward about its bottom edge on a carcass's front: its
    handle (a bar in front of it) and its side edge (facing along the hinge, a carcass axis)
    went to the carcass's label and stand past its front frame; both go to the flap. A table
    top overhanging the front by 4 cm, above a drawer pulled out beneath it, is the
    carcass's and stays; without the frame (nothing faces out of the front) nothing moves."""
    from pipeline.compartments import give_protrusions

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    step = 0.02
    carcass = [_grid(0.8, 0.8, (-0.3, -0.4, -0.4), y, z), _grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, z),
               _grid(0.6, 0.8, (-0.3, 0.4, -0.4), x, z), _grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, y),
               _grid(0.64, 0.8, (-0.3, -0.4, 0.4), x, y),  # the top, 4 cm over the front
               _grid(0.8, 0.04, (0.3, -0.4, -0.4), y, z)]  # the front frame's bottom rail
    carcass_normals = [x, y, y, z, z, x]
    a = np.radians(40)
    up, out = np.array((np.sin(a), 0, np.cos(a))), np.array((np.cos(a), 0, -np.sin(a)))
    flap = _grid(0.5, 0.3, (0.3, -0.4, 0.0), y, up)
    edge = _grid(0.3, 0.02, (0.3, -0.4, 0.0), up, out)  # its side, facing -y
    handle = _grid(0.2, 0.04, (0.3, -0.25, 0.0) + 0.25 * up + 0.03 * out, y, up)
    drawer = _grid(0.4, 0.1, (0.45, -0.1, 0.28), y, z)  # its front, 15 cm out, under the top
    cloud = np.concatenate([*carcass, flap, edge, handle, drawer])
    n = np.cumsum([0, *map(len, carcass), len(flap), len(edge), len(handle), len(drawer)])
    truth = np.concatenate([np.ones(n[6], int), np.full(n[9] - n[6], 2),
                            np.full(n[10] - n[9], 3)])
    normals = np.concatenate([np.tile(v, (len(c), 1))
                              for v, c in zip(carcass_normals, carcass, strict=True)]
                             + [np.tile(out, (len(flap), 1)), np.tile(y, (len(edge), 1)),
                                np.tile(up, (len(handle), 1)), np.tile(x, (len(drawer), 1))])
    labels = truth.copy()
    # the edge and the handle in the carcass's label, past its frame (the edge's first
    # spacing, where it meets the frame, is the carcass's to the masks and to this rule)
    taken = np.zeros(len(cloud), bool)
    taken[n[7]:n[9]] = cloud[n[7]:n[9], 0] > 0.3 + step
    labels[taken] = 1
    normals = normals.astype(float)
    moved_labels, moved = give_protrusions(cloud, labels, step, normals=normals)
    assert np.array_equal(moved_labels, truth)
    assert sorted(m["points"] for m in moved) == sorted(
        [taken[n[7]:n[8]].sum(), taken[n[8]:n[9]].sum()])
    # exact labels are left alone; without measured normals nothing moves
    assert give_protrusions(cloud, truth, step, normals=normals)[1] == []
    assert give_protrusions(cloud, labels, step)[1] == []
    rail = np.arange(n[5], n[6])
    open_front = np.delete(np.arange(len(cloud)), rail)
    assert give_protrusions(cloud[open_front], labels[open_front], step,
                            normals=normals[open_front])[1] == []


def test_a_piece_of_the_carcass_is_nothing_for_its_protruding_edge_to_hang_on():
    """A carcass's shell in two labels: its back, left side, top and a strip of its floor,
    and (a label of its own, spanning the box every way: the carcass's, as
    :func:`return_enclosed` judges) its right side and the rest of the floor. A skirting
    strip below the floor, in the carcass's label, stands past its walls and touches only
    that other half; it stays with the carcass (given to the half, it shrank the carcass's
    box and the half stood out of it)."""
    from pipeline.compartments import enclosed_parts, give_protrusions

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    pieces = [(_grid(0.8, 0.8, (-0.3, -0.4, -0.4), y, z), x, 1),  # back
              (_grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, z), y, 1),  # left side
              (_grid(0.6, 0.8, (-0.3, -0.4, 0.4), x, y), z, 1),  # top
              (_grid(0.6, 0.3, (-0.3, -0.4, -0.4), x, y), z, 1),  # floor, left strip
              (_grid(0.6, 0.8, (-0.3, 0.4, -0.4), x, z), y, 2),  # right side
              (_grid(0.6, 0.46, (-0.3, -0.06, -0.4), x, y), z, 2),  # floor, the rest
              (_grid(0.3, 0.04, (0.3, 0.1, -0.47), y, z), x, 1)]  # skirting, 3 cm below
    cloud = np.concatenate([p for p, _, _ in pieces])
    normals = np.concatenate([np.tile(n, (len(p), 1)) for p, n, _ in pieces]).astype(float)
    labels = np.concatenate([np.full(len(p), k) for p, _, k in pieces])
    assert enclosed_parts(cloud, labels, 0.02)[2].get("thick")
    out, moved = give_protrusions(cloud, labels, 0.02, normals=normals)
    assert moved == [] and np.array_equal(out, labels)


def test_a_doors_outer_face_and_its_liner_are_one_part():
    """A door swung 30 degrees, seen from outside and from inside: its outer face (with the
    shelves on its inner side) in one label, its liner 5 cm behind the face, within its
    outline, in another; one part. Two doors on one hinge line swung alike, side by side
    in one plane, stay two."""
    from pipeline.compartments import merge_faces

    z = np.array((0.0, 0.0, 1.0))
    a = np.radians(30)
    along, out = np.array((np.sin(a), np.cos(a), 0)), np.array((np.cos(a), -np.sin(a), 0))
    hinge = np.array((0.3, -0.4, -0.4))
    face = _grid(0.8, 0.8, hinge, along, z)
    shelves = np.concatenate([_grid(0.6, 0.1, hinge + 0.1 * along + h * z - 0.05 * out,
                                    along, -out) for h in (0.3, 0.6)])
    liner = _grid(0.7, 0.7, hinge + 0.05 * (along + z) - 0.05 * out, along, z)
    carcass = _open_box()
    cloud = np.concatenate([carcass, face, shelves, liner])
    normals = np.concatenate([np.tile((1.0, 0, 0), (len(carcass), 1)),
                              np.tile(out, (len(face), 1)), np.tile(z, (len(shelves), 1)),
                              np.tile(-out, (len(liner), 1))])
    labels = np.concatenate([np.ones(len(carcass), int), np.full(len(face) + len(shelves), 2),
                             np.full(len(liner), 3)])
    merged, moved = merge_faces(cloud, labels, 0.02, normals=normals)
    assert moved == [{"part": 3, "points": len(liner), "faces_of": 2}]
    assert (merged[len(carcass):] == 2).all() and (merged[:len(carcass)] == 1).all()
    assert merge_faces(cloud, labels, 0.02)[1] == []  # needs the measured normals
    # two doors on one hinge line, swung alike: one plane, side by side
    lower = _grid(0.8, 0.38, hinge, along, z)
    upper = _grid(0.8, 0.36, hinge + 0.42 * z, along, z)
    cloud = np.concatenate([carcass, lower, upper])
    normals = np.concatenate([np.tile((1.0, 0, 0), (len(carcass), 1)),
                              np.tile(out, (len(lower) + len(upper), 1))])
    labels = np.concatenate([np.ones(len(carcass), int), np.full(len(lower), 2),
                             np.full(len(upper), 3)])
    assert merge_faces(cloud, labels, 0.02, normals=normals)[1] == []


def test_the_carcass_wall_in_a_square_swung_doors_label_goes_back():
    """A door swung 90 degrees past a carcass's front, 1.5 cm off the carcass's side
    wall's plane: its label also took a stretch of that wall deep in the box (the inside
    seen past the door); the wall goes back, the door keeps all its points. A drawer pulled
    out (its front facing out of the face, its sides in the box) is left alone; so is a
    drawer's side alone in a label, mostly in the box."""
    from pipeline.compartments import return_past_square_panels

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    carcass = _open_box()
    normals_box = np.concatenate([np.tile(n, (len(p), 1)) for p, n in zip(
        (_grid(0.8, 0.8, (-0.3, -0.4, -0.4), y, z), _grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, z),
         _grid(0.6, 0.8, (-0.3, 0.4, -0.4), x, z), _grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, y),
         _grid(0.6, 0.8, (-0.3, -0.4, 0.4), x, y)), (x, y, y, z, z), strict=True)])
    door = _grid(0.4, 0.7, (0.32, -0.415, -0.35), x, z)
    cloud = np.concatenate([carcass, door])
    normals = np.concatenate([normals_box, np.tile(y, (len(door), 1))]).astype(float)
    truth = np.concatenate([np.ones(len(carcass), int), np.full(len(door), 2)])
    labels = truth.copy()
    wall = (cloud[:, 1] == -0.4) & (cloud[:, 0] < 0.2) & (np.abs(cloud[:, 2]) < 0.2)
    labels[wall] = 2
    out, moved = return_past_square_panels(cloud, labels, 0.02, normals=normals)
    assert np.array_equal(out, truth)
    assert moved == [{"part": 2, "points": int(wall.sum()), "past_square_panel": True}]
    assert return_past_square_panels(cloud, labels, 0.02)[1] == []  # needs the normals
    # a drawer pulled 15 cm out: its front faces out of the face; its sides stay with it
    drawer = [(_grid(0.3, 0.2, (0.45, -0.15, -0.3), y, z), x),
              (_grid(0.5, 0.2, (-0.05, -0.15, -0.3), x, z), y),
              (_grid(0.5, 0.2, (-0.05, 0.15, -0.3), x, z), y)]
    cloud = np.concatenate([carcass, *(p for p, _ in drawer)])
    normals = np.concatenate([normals_box, *(np.tile(n, (len(p), 1)) for p, n in drawer)])
    labels = np.concatenate([np.ones(len(carcass), int),
                             np.full(len(cloud) - len(carcass), 2)])
    assert return_past_square_panels(cloud, labels, 0.02, normals=normals.astype(float))[1] == []
    side = np.arange(len(carcass) + len(drawer[0][0]), len(carcass) + len(drawer[0][0])
                     + len(drawer[1][0]))  # one side alone, 0.1 of it out of the box
    assert return_past_square_panels(cloud[np.r_[:len(carcass), side]],
                                     labels[np.r_[:len(carcass), side]], 0.02,
                                     normals=normals[np.r_[:len(carcass), side]])[1] == []


def test_a_drawer_cut_into_its_front_and_its_side_is_one_part_again():
    """A drawer pulled 15 cm out of a carcass, its side in a label of its own (inside the
    front's box): merged into the front. Two doors side by side, and a patch of the carcass's
    floor inside the carcass, keep their labels."""
    from pipeline.compartments import merge_nested

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    carcass = np.concatenate([_grid(0.8, 0.8, (-0.3, -0.4, -0.4), y, z),
                              _grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, z),
                              _grid(0.6, 0.8, (-0.3, 0.4, -0.4), x, z),
                              _grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, y),
                              _grid(0.6, 0.8, (-0.3, -0.4, 0.4), x, y)])
    front = _grid(0.3, 0.2, (0.45, 0.05, -0.3), y, z)
    bottom = _grid(0.5, 0.3, (-0.05, 0.05, -0.3), x, y)
    side = _grid(0.5, 0.18, (-0.05, 0.05, -0.28), x, z)
    doors = [np.concatenate([_grid(0.36, 0.3, (d, w, 0.05), y, z) for d in (0.32, 0.34)])
             for w in (-0.38, 0.02)]  # each door's two faces, swung out square
    cloud = np.concatenate([carcass, front, bottom, side, *doors])
    n = np.cumsum([0, len(carcass), len(front), len(bottom), len(side), *map(len, doors)])
    labels = np.ones(len(cloud), int)
    labels[n[1]:n[3]] = 2  # the drawer's front and bottom
    labels[n[3]:n[4]] = 3  # its side, cut off
    labels[n[4]:n[5]], labels[n[5]:n[6]] = 4, 5
    out, moved = merge_nested(cloud, labels, 0.02)
    assert (out[n[1]:n[4]] == out[n[1]]).all() and len(np.unique(out)) == 4
    assert moved == [{"part": 3, "points": len(side), "merged_into": 2}]
    # the doors beside each other, and a drawer left shut (inside the carcass), stay apart
    shut = cloud.copy()
    shut[n[1]:n[4], 0] -= 0.16
    assert merge_nested(shut, labels, 0.02)[1] == []


def test_a_mixed_label_is_parted_by_its_fronts_not_merged_whole():
    """One label holds a door swung square (full height, left) and a drawer pulled out
    (top right); the drawer below that one lies in the label's box, its front cut in two
    labels (its left half with the bottom, its right half alone). Its fronts lie apart from
    the mixed label's, so it is no piece of it: the right half joins the left (one front),
    and the door, a panel square to the face outside the mixed label's front's outline
    (not going on within it, as a door's panel behind its own bin does), becomes a part of
    its own. Without measured normals the old reading stands: both
    halves merge into the mixed label."""
    from pipeline.compartments import merge_nested, split_fronts

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    carcass = _open_box()
    door = (_grid(0.6, 0.7, (0.32, -0.38, -0.35), x, z), y)
    top = [(_grid(0.3, 0.2, (0.45, 0.05, 0.1), y, z), x),
           (_grid(0.45, 0.3, (0.0, 0.05, 0.1), x, y), z)]
    left = [(_grid(0.14, 0.2, (0.45, 0.05, -0.3), y, z), x),
            (_grid(0.45, 0.14, (0.0, 0.05, -0.3), x, y), z)]
    right = (_grid(0.14, 0.2, (0.45, 0.21, -0.3), y, z), x)
    pieces = [(carcass, x), *left, right, door, *top]
    cloud, normals = _facing(*pieces)
    n = np.cumsum([0, *(len(p) for p, _ in pieces)])
    labels = np.ones(len(cloud), int)
    labels[n[1]:n[3]], labels[n[3]:n[4]], labels[n[4]:] = 3, 4, 2
    out, moved = merge_nested(cloud, labels, 0.02, normals=normals)
    assert moved == [{"part": 4, "points": len(right[0]), "merged_into": 3}]
    assert len(np.unique(out[n[1]:n[4]])) == 1 and len(np.unique(out)) == 3
    split, moved = split_fronts(cloud, out, 0.02, normals=normals)
    assert moved == [{"part": int(out[n[4]]), "points": n[-1] - n[4], "fronts": 1,
                      "split_m": [pytest.approx(0.45)], "beside": [len(door[0])]}]
    assert len(np.unique(split)) == 4 and (split[:n[1]] == 1).all()
    assert len(np.unique(split[n[4]:n[5]])) == 1 and len(np.unique(split[n[5]:])) == 1
    assert len({split[n[1]], split[n[4]], split[n[5]]}) == 3
    # without normals: both halves merge into the mixed label, as before
    assert len(np.unique(merge_nested(cloud, labels, 0.02)[0])) == 2
    # a panel reaching less than half the carcass's depth out of the face (a strip of the
    # carcass standing a little out beside a front) is no door: nothing split
    short = cloud.copy()
    short[n[4]:n[5], 0] = 0.32 + (cloud[n[4]:n[5], 0] - 0.32) / 4
    assert split_fronts(short, out, 0.02, normals=normals)[1] == []
    # a door swung square with a bin on its inside (a front facing out of the face) in a
    # label of its own: its panel goes on behind the bin, one panel, nothing split
    bin_front = (_grid(0.16, 0.2, (0.6, -0.36, -0.1), y, z), x)
    alone, alone_normals = _facing((carcass, x), door, bin_front)
    assert split_fronts(alone, np.r_[np.ones(len(carcass), int),
                                     np.full(len(alone) - len(carcass), 2)], 0.02,
                        normals=alone_normals)[1] == []


def _open_box():
    """A carcass's shell open at the front (x = 0.3): back, sides, floor and top."""
    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    return np.concatenate([_grid(0.8, 0.8, (-0.3, -0.4, -0.4), y, z),
                           _grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, z),
                           _grid(0.6, 0.8, (-0.3, 0.4, -0.4), x, z),
                           _grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, y),
                           _grid(0.6, 0.8, (-0.3, -0.4, 0.4), x, y)])


def test_a_piece_deep_behind_the_open_face_is_the_carcass_at_any_size():
    """A door swung open past the carcass's front; a piece of its inside near the back, in
    a label of its own (5 % of the carcass, thin across the box), goes back, and its few
    strays in front of the box go to the part nearest them; so does a shelf reaching from
    the opening to the back; a drawer seen shut, its front flush with the opening (as large
    and as thin as the piece), stays."""
    from pipeline.compartments import return_enclosed

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    carcass = _open_box()
    door = _grid(0.4, 0.7, (0.32, -0.42, -0.35), x, z)  # hinged at the front, swung 90 deg
    inner = _grid(0.4, 0.3, (-0.28, -0.2, -0.1), y, z)  # 2 cm in front of the back wall
    strays = np.array([[0.6, -0.41, 0.0], [0.62, -0.41, 0.02], [0.64, -0.41, 0.04]])
    shut = _grid(0.34, 0.3, (0.29, 0.02, -0.36), y, z)  # flush with the opening
    shelf = _grid(0.56, 0.6, (-0.28, -0.3, 0.2), x, y)  # from the opening to the back
    cloud = np.concatenate([carcass, door, inner, strays, shut, shelf])
    n = np.cumsum([0, len(carcass), len(door), len(inner), len(strays), len(shut), len(shelf)])
    labels = np.ones(len(cloud), int)
    labels[n[1]:n[2]], labels[n[2]:n[4]], labels[n[4]:n[5]], labels[n[5]:] = 2, 3, 4, 5
    assert len(inner) > 0.03 * len(carcass) and len(shut) > 0.03 * len(carcass)
    out, moved = return_enclosed(cloud, labels, voxel=0.02)
    assert (out[n[2]:n[3]] == 1).all()  # the inside, deep behind the front
    assert (out[n[3]:n[4]] == out[n[1]]).all()  # its strays: the door's
    assert len(np.unique(out[n[4]:n[5]])) == 1 and out[n[4]] not in (1, out[n[1]])
    assert (out[n[5]:] == 1).all()  # the shelf, reaching through the box
    assert [m["part"] for m in moved] == [3, 5] and moved[0]["deep_m"] > 0.5
    assert moved[1]["through"]
    # with no part standing out there is no open face: nothing is deep
    closed = np.concatenate([carcass, inner, shut])
    kept = np.concatenate([np.ones(len(carcass), int), np.full(len(inner), 2),
                           np.full(len(shut), 3)])
    assert return_enclosed(closed, kept, voxel=0.02)[1] == []


def test_a_strip_of_the_carcass_holding_a_few_points_of_a_drawer_beside_it_goes_back():
    """A strip of the carcass's side, front to back (7 % of the carcass, thin across the
    box), in a label of its own that also took a few points (3 %) of the drawer pulled out
    beside it, past the face the drawer stands out of: those points are the masks' border
    with the drawer, not the strip standing out; the strip goes back to the carcass and
    they go to the drawer. A drawer pulled out a little, its front past the face touching
    no other part, stays."""
    from pipeline.compartments import return_enclosed

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    carcass = _open_box()
    drawer = np.concatenate([_grid(0.7, 0.3, (0.45, -0.36, -0.3), y, z),  # its front
                             _grid(0.55, 0.3, (-0.1, -0.36, -0.3), x, z),  # its side
                             _grid(0.55, 0.7, (-0.1, -0.36, -0.3), x, y)])  # its bottom
    strip = _grid(0.56, 0.3, (-0.28, -0.38, 0.02), x, z)  # a liner of the side wall
    border = _grid(0.1, 0.04, (0.34, -0.365, -0.04), x, z)  # the drawer's, past the face
    shut = _grid(0.3, 0.3, (0.301, 0.05, 0.05), y, z)  # a drawer seen shut, out 1 mm
    cloud = np.concatenate([carcass, drawer, strip, border, shut])
    n = np.cumsum([0, len(carcass), len(drawer), len(strip), len(border), len(shut)])
    labels = np.ones(len(cloud), int)
    labels[n[1]:n[2]], labels[n[2]:n[4]], labels[n[4]:] = 2, 3, 4
    share = len(border) / (len(strip) + len(border))
    assert 0.02 < share < 0.05 and len(strip) > 0.03 * len(carcass)
    out, moved = return_enclosed(cloud, labels, voxel=0.02)
    assert (out[n[2]:n[3]] == 1).all()  # the strip: the carcass's
    assert (out[n[3]:n[4]] == out[n[1]]).all()  # its border points: the drawer's
    assert [m["part"] for m in moved] == [3]
    assert len(np.unique(out[n[4]:])) == 1 and out[n[4]] not in (1, out[n[1]])


def test_settling_takes_back_a_deep_patch_but_not_a_small_drawer_seen_shut():
    """Once the other rules have run, a patch of the carcass's inside deep behind the open
    face goes back to it, as in the first pass; a small drawer front flush with the opening
    (under 3 % of the carcass's points: the first pass takes it by size) stays, since after
    the merges a drawer seen shut lies wholly in the box too."""
    from pipeline.compartments import return_enclosed, settle

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    carcass = _open_box()
    door = _grid(0.4, 0.7, (0.32, -0.42, -0.35), x, z)  # swung 90 degrees past the front
    inner = _grid(0.2, 0.2, (-0.28, -0.2, -0.1), y, z)  # 2 cm in front of the back wall
    shut = _grid(0.14, 0.1, (0.29, 0.02, -0.36), y, z)  # a small front, flush
    cloud = np.concatenate([carcass, door, inner, shut])
    n = np.cumsum([0, len(carcass), len(door), len(inner), len(shut)])
    labels = np.ones(len(cloud), int)
    labels[n[1]:n[2]], labels[n[2]:n[3]], labels[n[3]:] = 2, 3, 4
    assert len(shut) < 0.03 * len(carcass)
    first = return_enclosed(cloud, labels, voxel=0.02)[0]
    assert (first[n[2]:] == 1).all()  # the first pass: the patch, and the front by size
    out, moved = settle(cloud, labels, voxel=0.02)
    assert (out[n[2]:n[3]] == 1).all() and moved[0]["deep_m"] > 0.5
    assert len(np.unique(out[n[3]:])) == 1 and out[n[3]] not in (1, out[n[1]])
    assert len(moved) == 1
    assert settle(cloud, out, voxel=0.02)[1] == []  # settled: nothing moves again


def test_a_drawers_body_behind_its_pulled_out_front_is_one_part_again():
    """A drawer pulled 15 cm out of a carcass, its body (bottom and side, in the box behind
    the front's outline) in a label of its own: merged into the front. A drawer seen shut
    beside it, out of that outline, keeps its label."""
    from pipeline.compartments import merge_behind

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    carcass = _open_box()
    front = _grid(0.3, 0.2, (0.45, 0.05, -0.3), y, z)
    body = np.concatenate([_grid(0.45, 0.3, (-0.1, 0.05, -0.3), x, y),
                           _grid(0.45, 0.18, (-0.1, 0.05, -0.28), x, z)])
    shut = _grid(0.3, 0.2, (0.29, -0.35, -0.3), y, z)
    cloud = np.concatenate([carcass, front, body, shut])
    n = np.cumsum([0, len(carcass), len(front), len(body), len(shut)])
    labels = np.ones(len(cloud), int)
    labels[n[1]:n[2]], labels[n[2]:n[3]], labels[n[3]:] = 3, 2, 4
    out, moved = merge_behind(cloud, labels, 0.02)
    assert (out[n[1]:n[3]] == out[n[1]]).all() and len(np.unique(out)) == 3
    assert (out[n[3]:] != out[n[1]]).all() and (out[:n[1]] == 1).all()
    assert moved == [{"part": 2, "points": len(body), "behind": 3}]
    # pushed shut, the front stands out no more: nothing to merge into
    pushed = cloud.copy()
    pushed[n[1]:n[3], 0] -= 0.16
    assert merge_behind(pushed, labels, 0.02)[1] == []



def test_a_few_stray_points_do_not_move_the_carcass_box():
    """Ten points of a drawer's front edge the masks gave the carcass, 30 cm in front of
    it, linked to none of its surfaces: its box is the shell's. A bracket on its back,
    linked to the back wall, is its own surface and stays in the box."""
    from pipeline.compartments import carcass_box

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    shell = _open_box()
    stray = _grid(0.0, 0.18, (0.6, 0.1, 0.0), y, z)[:10]
    box = carcass_box(np.concatenate([shell, stray]), 0.02)
    assert np.allclose(sorted(2 * box.extent), [0.6, 0.8, 0.8], atol=1e-6)
    assert abs(box.center[0]) < 1e-6
    bracket = _grid(0.1, 0.3, (-0.4, -0.15, -0.15), x, y)  # 10 cm behind the back wall
    box = carcass_box(np.concatenate([shell, bracket]), 0.02)
    assert np.isclose(2 * box.extent[np.argmax(np.abs(box.R[0]))], 0.7, atol=1e-6)


def test_a_drawer_pulled_out_past_half_its_depth_is_one_part_again():
    """Pulled out 35 cm of its 45, a drawer's body has most of its points out of the carcass's
    box; still deeper in it than its front, within the front's outline: merged into it."""
    from pipeline.compartments import merge_behind

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    carcass = _open_box()
    front = _grid(0.3, 0.2, (0.65, 0.05, -0.3), y, z)
    body = np.concatenate([_grid(0.45, 0.3, (0.2, 0.05, -0.3), x, y),
                           _grid(0.45, 0.18, (0.2, 0.05, -0.28), x, z)])
    cloud = np.concatenate([carcass, front, body])
    n = np.cumsum([0, len(carcass), len(front), len(body)])
    labels = np.ones(len(cloud), int)
    labels[n[1]:n[2]], labels[n[2]:n[3]] = 3, 2
    assert np.mean(cloud[n[2]:n[3], 0] <= 0.32) < 0.5
    out, moved = merge_behind(cloud, labels, 0.02)
    assert (out[n[1]:] == out[n[1]]).all() and (out[:n[1]] == 1).all()
    assert moved == [{"part": 2, "points": len(body), "behind": 3}]

def test_one_label_inside_two_stacked_drawers_goes_to_both():
    """Two drawers stacked, both pulled 20 cm out of a carcass, each front (with its body's
    foremost 15 cm) in a label of its own and the rest of both bodies (the lower one's floor
    and sides, the upper one's) in one label, no face of its own facing out: no one front's
    outline holds it, the two together do, so each of its points goes to the drawer whose
    outline it lies in. Each body in its own label: nothing merges."""
    from pipeline.compartments import merge_behind

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)

    def drawer(bottom, top, lo, hi):  # floor and two sides between depths lo and hi
        return [(_grid(hi - lo, 0.6, (lo, -0.3, bottom), x, y), z),
                (_grid(hi - lo, top - bottom, (lo, -0.3, bottom), x, z), y),
                (_grid(hi - lo, top - bottom, (lo, 0.3, bottom), x, z), y)]

    shell, shell_n = _facing((_open_box(), x))
    fronts = [_facing((_grid(0.6, 0.28, (0.5, -0.3, b), y, z), x), *drawer(b, b + 0.28, 0.36, 0.48))
              for b in (-0.38, -0.06)]
    inner = _facing(*drawer(-0.38, -0.1, 0.0, 0.34), *drawer(-0.06, 0.22, 0.0, 0.34))
    pieces = [(shell, shell_n), *fronts, inner]
    cloud = np.concatenate([p for p, _ in pieces])
    normals = np.concatenate([n for _, n in pieces])
    n = np.cumsum([0, *(len(p) for p, _ in pieces)])
    labels = np.ones(len(cloud), int)
    labels[n[1]:n[2]], labels[n[2]:n[3]], labels[n[3]:] = 2, 3, 4
    out, moved = merge_behind(cloud, labels, 0.02, normals=normals)
    lower = cloud[:, 2] <= -0.08
    assert len(np.unique(out)) == 3 and (out[:n[1]] == 1).all()
    assert (out[n[1]:][lower[n[1]:]] == out[n[1]]).all()
    assert (out[n[1]:][~lower[n[1]:]] == out[n[2]]).all() and out[n[1]] != out[n[2]]
    assert moved[0]["part"] == 4 and sorted(moved[0]["behind"]) == [2, 3]
    # each body in its own front's label: nothing to merge
    labels[n[3]:][cloud[n[3]:, 2] <= -0.09], labels[n[3]:][cloud[n[3]:, 2] > -0.09] = 2, 3
    assert merge_behind(cloud, labels, 0.02, normals=normals)[1] == []


def test_a_frontless_piece_in_a_drawers_outline_goes_back():
    """A drawer pulled 20 cm out (front and body in one label) and a label of a piece of its
    side past the carcass's face with a piece of a divider inside the box behind it, no
    front of its own: the side's points go to the drawer, the divider's to the carcass. A
    door swung square beside the opening has no front on that face either, but lies out of
    the drawer's outline: it stays; so does everything without measured normals."""
    from pipeline.compartments import return_frontless_pieces

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    shell = _facing((_open_box(), x), (_grid(0.4, 0.8, (-0.3, 0.3, -0.4), x, z), y))
    drawer = _facing((_grid(0.3, 0.2, (0.5, -0.1, -0.3), y, z), x),
                     (_grid(0.5, 0.3, (0.0, -0.1, -0.3), x, y), z),
                     (_grid(0.5, 0.2, (0.0, -0.1, -0.3), x, z), y),
                     (_grid(0.28, 0.2, (0.0, 0.2, -0.3), x, z), y))
    side = _facing((_grid(0.12, 0.1, (0.32, 0.2, -0.3), x, z), y))
    divider = _facing((_grid(0.08, 0.1, (0.12, 0.3, -0.3), x, z), y))
    door = _facing((_grid(0.4, 0.7, (0.32, -0.42, -0.35), x, z), y))
    pieces = [shell, drawer, side, divider, door]
    cloud = np.concatenate([p for p, _ in pieces])
    normals = np.concatenate([n for _, n in pieces])
    n = np.cumsum([0, *(len(p) for p, _ in pieces)])
    labels = np.ones(len(cloud), int)
    labels[n[1]:n[2]], labels[n[2]:n[4]], labels[n[4]:] = 2, 4, 3
    out, moved = return_frontless_pieces(cloud, labels, 0.02, normals=normals)
    assert (out[n[1]:n[3]] == out[n[1]]).all() and out[n[1]] != 1
    assert (out[n[3]:n[4]] == 1).all() and (out[:n[1]] == 1).all()
    assert (out[n[4]:] != out[n[1]]).all() and len(np.unique(out)) == 3
    assert moved == [{"part": 4, "points": n[4] - n[2], "frontless_piece_of": [2]}]
    assert return_frontless_pieces(cloud, labels, 0.02)[1] == []
    # the same label beside a drawer seen at a quarter of the points (a hand-held path's
    # few views of it): more than a tenth of the part it lies in, a part of its own whose
    # front the views missed, not a scrap: it stays
    keep = np.ones(len(cloud), bool)
    keep[n[1]:n[2]] = np.arange(n[2] - n[1]) % 4 == 0
    sparse, sparse_normals, sparse_labels = cloud[keep], normals[keep], labels[keep]
    assert np.count_nonzero(sparse_labels == 4) > 0.1 * np.count_nonzero(sparse_labels == 2)
    assert return_frontless_pieces(sparse, sparse_labels, 0.02,
                                   normals=sparse_normals)[1] == []


def test_a_body_in_two_labels_under_a_lid_is_one_part():
    """A box's lid swung open past upright (hinged at the back of the top, 29 cm wide),
    the largest label and one panel, its lowest point at the box's top; the body in two
    labels, each of walls and half the floor, both standing on the foot: they join, the
    lid stays. A drawer's label lower down off the foot stays a part; nothing joins where
    the views give no up; and where the panel stands on the foot (a door swung open) no
    body lies under a lid: nothing joins."""
    from pipeline.compartments import join_body_under_lid

    x, y, z = np.eye(3)
    lean = np.radians(20)
    back, out = np.array((-np.sin(lean), 0, np.cos(lean))), np.array((np.cos(lean), 0, np.sin(lean)))
    lid = (_grid(0.6, 0.8, (-0.3, -0.4, 0.0), back, y, step=0.01), out)
    half = [(_grid(0.8, 0.4, (-0.3, -0.4, -0.4), y, z), x),  # back wall
            (_grid(0.6, 0.4, (-0.3, -0.4, -0.4), x, z), y),  # left side
            (_grid(0.6, 0.4, (-0.3, -0.4, -0.4), x, y), z)]  # floor, y <= 0
    other = [(_grid(0.8, 0.4, (0.3, -0.4, -0.4), y, z), x),  # front wall
             (_grid(0.6, 0.4, (-0.3, 0.4, -0.4), x, z), y),  # right side
             (_grid(0.6, 0.36, (-0.3, 0.04, -0.4), x, y), z)]  # floor, y > 0
    drawer = [(_grid(0.3, 0.1, (0.45, -0.15, -0.3), y, z), x),
              (_grid(0.4, 0.3, (0.05, -0.15, -0.3), x, y), z)]
    cloud, normals = _facing(lid, *half, *other, *drawer)
    n = np.cumsum([0, len(lid[0]), sum(len(p) for p, _ in half),
                   sum(len(p) for p, _ in other), sum(len(p) for p, _ in drawer)])
    labels = np.repeat([1, 2, 3, 4], np.diff(n))
    assert n[1] > n[2] - n[1] > n[3] - n[2] > n[4] - n[3]  # numbered by size
    joined, moved = join_body_under_lid(cloud, labels, 0.02, normals=normals, up=z)
    assert moved == [{"part": 3, "points": int(n[3] - n[2]), "body_under_lid": 2}]
    assert (joined[:n[1]] == 1).all() and (joined[n[1]:n[3]] == 2).all()
    assert (joined[n[3]:] == 3).all()  # the drawer, off the foot
    assert join_body_under_lid(cloud, labels, 0.02, normals=normals)[1] == []  # no up
    assert join_body_under_lid(cloud, labels, 0.02, up=z)[1] == []  # no normals
    # the panel reaching the foot: a door swung open beside the body, no lid
    door = (_grid(0.6, 0.4, (0.3, 0.4, -0.4), np.array((np.cos(lean), np.sin(lean), 0)), z,
                  step=0.005), np.array((-np.sin(lean), np.cos(lean), 0)))
    cloud, normals = _facing(door, *half, *other)
    labels = np.repeat([1, 2, 3], [len(door[0]), n[2] - n[1], n[3] - n[2]])
    assert len(door[0]) > n[2] - n[1]
    assert join_body_under_lid(cloud, labels, 0.02, normals=normals, up=z)[1] == []


def _facing(*pieces):
    """Points and their normals: (points, normal) pieces concatenated."""
    return (np.concatenate([p for p, _ in pieces]),
            np.concatenate([np.tile(n, (len(p), 1)) for p, n in pieces]).astype(float))


def test_two_drawers_pulled_out_by_different_lengths_in_one_label_are_two_parts():
    """Two drawers, one above the other, pulled 15 and 30 cm out of a carcass, in one label:
    their fronts lie at two depths, apart on the face, so the label is split between them
    (each drawer's bottom with its front). A drawer whose back panel is seen past its front
    (another depth, within the front's outline) and two drawers pulled out alike stay one
    label."""
    from pipeline.compartments import split_fronts

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    carcass = _open_box()
    low = [(_grid(0.3, 0.2, (0.45, 0.05, -0.3), y, z), x),
           (_grid(0.45, 0.3, (0.0, 0.05, -0.3), x, y), z)]
    high = [(_grid(0.3, 0.2, (0.6, 0.05, 0.05), y, z), x),
            (_grid(0.6, 0.3, (0.0, 0.05, 0.05), x, y), z)]
    cloud, normals = _facing((carcass, x), *low, *high)
    n = np.cumsum([0, len(carcass), sum(len(p) for p, _ in low)])
    labels = np.ones(len(cloud), int)
    labels[n[1]:] = 2
    out, moved = split_fronts(cloud, labels, 0.02, normals=normals)
    assert len(np.unique(out[n[1]:n[2]])) == 1 and len(np.unique(out[n[2]:])) == 1
    assert len(np.unique(out)) == 3 and (out[:n[1]] == 1).all()
    assert moved[0]["fronts"] == 2 and moved[0]["split_m"][0] < moved[0]["split_m"][1]
    # one drawer and its back panel, seen past the front from above: one part
    back = _grid(0.3, 0.15, (0.05, 0.05, -0.28), y, z)
    one, one_normals = _facing((carcass, x), *low, (back, x))
    assert split_fronts(one, labels[:len(one)], 0.02, normals=one_normals)[1] == []
    # both pulled out alike: one front, nothing to tell them apart by
    alike = cloud.copy()
    alike[n[2]:, 0] -= 0.15
    assert split_fronts(alike, labels, 0.02, normals=normals)[1] == []


def test_three_drawers_pulled_out_by_different_lengths_in_one_label_are_three_parts():
    """Three drawers stacked, pulled 30, 15 and 5 cm out of a carcass, in one label. The
    smallest front is less than ``front_share`` of the label's facing points, so the first
    split leaves it with its neighbour; judged again as the label those two share, its
    front is a front: three parts, each drawer's bottom with its front."""
    from pipeline.compartments import split_fronts

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    carcass = _open_box()
    drawers = [[(_grid(0.3, 0.3, (0.6, 0.05, 0.05), y, z), x),
                (_grid(0.6, 0.3, (0.0, 0.05, 0.05), x, y), z)],
               [(_grid(0.3, 0.1, (0.45, 0.05, -0.12), y, z), x),
                (_grid(0.45, 0.3, (0.0, 0.05, -0.12), x, y), z)],
               [(_grid(0.2, 0.08, (0.35, 0.05, -0.32), y, z), x),
                (_grid(0.35, 0.2, (0.0, 0.05, -0.32), x, y), z)]]
    cloud, normals = _facing((carcass, x), *drawers[0], *drawers[1], *drawers[2])
    n = np.cumsum([0, len(carcass)] + [sum(len(p) for p, _ in d) for d in drawers])
    fronts = [len(d[0][0]) for d in drawers]
    assert fronts[2] < 0.15 * sum(fronts) and fronts[2] >= 30
    labels = np.ones(len(cloud), int)
    labels[n[1]:] = 2
    out, moved = split_fronts(cloud, labels, 0.02, normals=normals)
    assert (out[:n[1]] == 1).all()
    assert all(len(np.unique(out[n[i]:n[i + 1]])) == 1 for i in (1, 2, 3))
    assert len(np.unique(out)) == 4
    assert [m["fronts"] for m in moved] == [2, 2]


def test_a_strip_along_the_seam_of_two_drawers_goes_to_them():
    """Two drawers stacked, pulled 15 cm out, and the masks' label along the seam between
    their fronts (a row of each, 2 cm either side of it): every point of that strip lies
    within two spacings of the drawers' points, so each goes to the drawer nearest it. The
    drawers, fronts 30 by 20 cm with their bottoms, have points well inside them and stay;
    so does a small drawer's front 16 by 10 cm standing alone."""
    from pipeline.compartments import return_seam_strips

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    carcass = _open_box()
    low = np.concatenate([_grid(0.3, 0.18, (0.45, 0.05, -0.3), y, z),
                          _grid(0.45, 0.3, (0.0, 0.05, -0.3), x, y)])
    high = np.concatenate([_grid(0.3, 0.18, (0.45, 0.05, -0.1), y, z),
                           _grid(0.45, 0.3, (0.0, 0.05, -0.1), x, y)])
    cloud = np.concatenate([carcass, low, high])
    truth = np.r_[np.ones(len(carcass), int), np.full(len(low), 2), np.full(len(high), 3)]
    labels = truth.copy()
    seam = (truth > 1) & (np.abs(cloud[:, 2] + 0.11) < 0.025) & (cloud[:, 0] > 0.44)
    labels[seam] = 4
    out, moved = return_seam_strips(cloud, labels, 0.02)
    assert np.array_equal(out, truth)
    assert moved == [{"part": 4, "points": int(seam.sum()), "seam_strip": True}]
    assert return_seam_strips(cloud, truth, 0.02)[1] == []
    small = np.concatenate([carcass, _grid(0.16, 0.1, (0.35, 0.05, -0.3), y, z)])
    alone = np.r_[np.ones(len(carcass), int), np.full(len(small) - len(carcass), 2)]
    assert return_seam_strips(small, alone, 0.02)[1] == []


def test_a_door_swung_square_to_the_face_is_not_split_at_its_edges():
    """A door swung 95 degrees stands out past the carcass's front, its panel facing
    sideways; its free edge and its hinge's strip face out of the face at two depths, 6 cm
    apart on it, but each is a strip a spacing wide, no front: one part."""
    from pipeline.compartments import split_fronts

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    carcass = _open_box()
    panel = _grid(0.6, 0.7, (0.32, -0.41, -0.35), x, z)
    free = _grid(0.02, 0.7, (0.92, -0.45, -0.35), y, z)
    hinge = _grid(0.02, 0.7, (0.32, -0.37, -0.35), y, z)
    cloud, normals = _facing((carcass, x), (panel, y), (free, x), (hinge, x))
    labels = np.ones(len(cloud), int)
    labels[len(carcass):] = 2
    assert split_fronts(cloud, labels, 0.02, normals=normals)[1] == []

def test_two_drawers_side_by_side_a_centimetre_and_a_half_apart_are_two_parts():
    """Two drawers side by side in one label, pulled out 10 and 11.5 cm: their fronts lie
    closer in depth than the grouping by depth parts (3 spacings), but a straight seam
    between them leaves each front on its own side, flat, 1.5 cm from the other: two
    parts. One drawer whose front has a recessed panel (a rim around a panel 1.5 cm
    deeper) is one part: its rim lies on both sides of any seam."""
    from pipeline.compartments import split_fronts

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    carcass = _open_box()

    def drawer(y0, out):
        return [(_grid(0.3, 0.2, (0.3 + out, y0, -0.3), y, z), x),
                (_grid(0.3 + out, 0.3, (0.0, y0, -0.3), x, y), z)]

    cloud, normals = _facing((carcass, x), *drawer(-0.35, 0.1), *drawer(0.05, 0.115))
    n = np.cumsum([0, len(carcass), sum(len(p) for p, _ in drawer(-0.35, 0.1))])
    labels = np.ones(len(cloud), int)
    labels[n[1]:] = 2
    out, moved = split_fronts(cloud, labels, 0.02, normals=normals)
    assert len(np.unique(out[n[1]:n[2]])) == 1 and len(np.unique(out[n[2]:])) == 1
    assert len(np.unique(out)) == 3 and (out[:n[1]] == 1).all()
    assert moved[0]["fronts"] == 2
    assert sorted(moved[0]["split_m"]) == pytest.approx([0.4, 0.415], abs=1e-6)
    # one drawer, its front a rim 4 cm wide around a panel 1.5 cm deeper: one part
    front = _grid(0.7, 0.3, (0.4, -0.35, -0.35), y, z)
    inner = (np.abs(front[:, 1]) < 0.31) & (np.abs(front[:, 2] + 0.2) < 0.11)
    front[inner, 0] -= 0.015
    one, one_normals = _facing((carcass, x), (front, x),
                               (_grid(0.4, 0.7, (0.0, -0.35, -0.35), x, y), z))
    assert split_fronts(one, np.r_[np.ones(len(carcass), int),
                                   np.full(len(one) - len(carcass), 2)], 0.02,
                        normals=one_normals)[1] == []


def test_a_body_cut_across_its_length_is_one_part_again():
    """A box's body cut by the masks into most of it and its end (the end wall and the
    walls' last stretch, standing out past the rest's box): the end spans the rest's
    cross-section and runs along its walls, so it is the carcass's. A drawer pulled out
    past the front (within the opening) stays a part."""
    from pipeline.compartments import merge_shell

    y, z = (0, 1, 0), (0, 0, 1)
    shell = _open_box()
    floor = (shell[:, 2] == -0.4) & (shell[:, 1] <= 0.34)
    end = ~floor & (shell[:, 1] > 0.2)  # the rest's box reaches y = 0.34 by its floor
    drawer = _grid(0.3, 0.2, (0.45, -0.2, -0.3), y, z)
    cloud = np.concatenate([shell, drawer])
    labels = np.concatenate([np.where(end, 2, 1), np.full(len(drawer), 3)])
    out, moved = merge_shell(cloud, labels, 0.02)
    assert (out[:len(shell)] == 1).all() and (out[len(shell):] == 2).all()
    assert [m["part"] for m in moved] == [2] and moved[0]["shell"]
    # the drawer alone, out of the whole body's box: no shell
    whole = np.concatenate([np.ones(len(shell), int), np.full(len(drawer), 2)])
    assert merge_shell(cloud, whole, 0.02)[1] == []


def test_a_drawer_left_in_the_carcass_label_beside_one_pulled_out_as_far_is_found():
    """Two drawers pulled 15 cm out of a carcass with a front rim; the masks gave one its
    own label and left the other in the carcass's (its box then reaches the drawers'
    fronts, so neither stands out of it). The carcass's points facing along the drawer's
    front, level with it and apart from it on the face, with what lies behind them as deep
    as the drawer, are a part of their own. Pushed shut, the drawers are level with the rim
    and nothing is found."""
    from pipeline.compartments import find_level_fronts

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    box = _open_box()
    rim = np.concatenate([_grid(0.8, 0.06, (0.3, -0.4, -0.4), y, z),
                          _grid(0.8, 0.06, (0.3, -0.4, 0.34), y, z),
                          _grid(0.06, 0.8, (0.3, -0.4, -0.4), y, z),
                          _grid(0.06, 0.8, (0.3, 0.34, -0.4), y, z)])
    box_normals = np.where((np.abs(box[:, 0] + 0.3) < 1e-9)[:, None], x,
                           np.where((np.abs(np.abs(box[:, 1]) - 0.4) < 1e-9)[:, None], y, z))

    def drawer(y0):  # within the opening, inside the rim
        return [(_grid(0.25, 0.2, (0.45, y0, -0.3), y, z), x),
                (_grid(0.45, 0.25, (0.0, y0, -0.3), x, y), z)]

    cloud, normals = _facing((rim, x), *drawer(-0.3), *drawer(0.05))
    cloud, normals = np.concatenate([box, cloud]), np.concatenate([box_normals, normals])
    n = np.cumsum([0, len(box) + len(rim), sum(len(p) for p, _ in drawer(-0.3))])
    labels = np.ones(len(cloud), int)
    labels[n[1]:n[2]] = 2
    out, moved = find_level_fronts(cloud, labels, 0.02, normals=normals)
    assert (out[n[2]:] == out[n[2]]).all() and out[n[2]] not in (1, out[n[1]])
    assert (out[n[1]:n[2]] == out[n[1]]).all() and (out[:n[1]] == 1).all()
    assert [m["level_front"] for m in moved] == [True]
    shut = cloud.copy()
    shut[n[1]:, 0] -= 0.15
    assert find_level_fronts(shut, labels, 0.02, normals=normals)[1] == []


def test_a_drawer_left_in_the_carcass_label_is_found_past_the_walls_reach():
    """Two drawers pulled 15 cm out of a carcass open at the front with no rim (a table's
    top, sides and floor; its front rail unseen); the masks left one in the carcass's
    label, whose points facing out of the front are then that drawer's front alone (their
    median is no wall). The carcass's walls facing the other ways end at the front (the
    second farthest, each on its own plane: the top overhangs 6 cm), and the drawer's
    front stands past them: the level front beside it is found. Pushed shut, level with
    the walls' ends, nothing is."""
    from pipeline.compartments import find_level_fronts

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    box = np.concatenate([_open_box(), _grid(0.06, 0.8, (0.3, -0.4, 0.4), x, y)])
    box_normals = np.where((np.abs(box[:, 0] + 0.3) < 1e-9)[:, None], x,
                           np.where((np.abs(np.abs(box[:, 1]) - 0.4) < 1e-9)[:, None], y, z))

    def drawer(y0):
        return [(_grid(0.25, 0.2, (0.45, y0, -0.3), y, z), x),
                (_grid(0.45, 0.25, (0.0, y0, -0.3), x, y), z)]

    cloud, normals = _facing(*drawer(-0.3), *drawer(0.05))
    cloud, normals = np.concatenate([box, cloud]), np.concatenate([box_normals, normals])
    n = np.cumsum([0, len(box), sum(len(p) for p, _ in drawer(-0.3))])
    labels = np.ones(len(cloud), int)
    labels[n[1]:n[2]] = 2
    out, moved = find_level_fronts(cloud, labels, 0.02, normals=normals)
    assert [m["level_front"] for m in moved] == [True]
    assert (out[n[2]:] == out[n[2]]).all() and out[n[2]] not in (1, out[n[1]])
    assert (out[:n[1]] == 1).all()
    shut = cloud.copy()
    shut[n[1]:, 0] -= 0.15
    assert find_level_fronts(shut, labels, 0.02, normals=normals)[1] == []


def test_a_stretch_of_the_carcass_apart_from_a_drawer_in_its_label_goes_back():
    """A drawer pulled 15 cm out of a carcass, its label also holding a post at the
    carcass's back corner (a table's leg: apart from the drawer, in the carcass's box,
    beside the drawer's outline seen along every axis, touching the carcass's back wall):
    the post goes to the carcass. The drawer's back panel, cut from its front (no sides
    seen) and as far from it, lies within the front's outline seen along the slide and
    stays; so does everything without the post, and a drawer's side cut from its front
    that overlaps the front's outline in part."""
    from pipeline.compartments import return_stray_pieces

    y, z = (0, 1, 0), (0, 0, 1)
    carcass = _open_box()
    front = _grid(0.3, 0.24, (0.45, 0.05, -0.3), y, z)
    back = _grid(0.26, 0.12, (0.0, 0.07, -0.28), y, z)
    post = _grid(0.04, 0.5, (-0.28, -0.36, -0.3), y, z)
    cloud = np.concatenate([carcass, front, back, post])
    n = np.cumsum([0, len(carcass), len(front), len(back), len(post)])
    labels = np.concatenate([np.ones(len(carcass), int), np.full(len(cloud) - n[1], 2)])
    out, moved = return_stray_pieces(cloud, labels, 0.02)
    assert (out[n[3]:] == 1).all() and (out[:n[1]] == 1).all()
    assert (out[n[1]:n[3]] == 2).all()  # the drawer's front and back panel
    assert moved == [{"part": 2, "points": len(post), "stray_to": 1}]
    kept = np.concatenate([np.ones(len(carcass), int), np.full(n[3] - n[1], 2)])
    assert return_stray_pieces(cloud[:n[3]], kept, 0.02)[1] == []
    # a drawer's side cut from its front, 80 % within the front's outline seen along the
    # slide (its lower end reaching the floor below the front): the drawer's, it stays
    x = (1, 0, 0)
    tall = _grid(0.3, 0.4, (0.45, 0.05, -0.3), y, z)
    side = _grid(0.2, 0.18, (0.1, 0.35, -0.38), x, z)
    cloud = np.concatenate([carcass, tall, side])
    labels = np.concatenate([np.ones(len(carcass), int), np.full(len(tall) + len(side), 2)])
    assert return_stray_pieces(cloud, labels, 0.02)[1] == []


def test_a_divider_inside_the_carcass_with_no_front_on_the_opening_goes_back():
    """A door swung 90 degrees past a carcass's front (x = 0.3); inside, a divider (facing
    sideways, as tall as the box, 40 % of its depth, flush with the opening: 8 % of the
    carcass, above the share :func:`return_enclosed` takes by size, thin across the box)
    in a label of its own: it shows no front on the opening and goes back. A drawer front
    seen shut, flush with the opening, stays; with no part standing out (no open face)
    nothing moves, and nothing without measured normals."""
    from pipeline.compartments import return_enclosed, return_frontless

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    carcass = _open_box()
    door = (_grid(0.4, 0.7, (0.32, -0.42, -0.35), x, z), y)  # swung square
    divider = (_grid(0.24, 0.8, (0.06, 0.1, -0.4), x, z), y)
    shut = (_grid(0.3, 0.3, (0.29, -0.35, -0.36), y, z), x)  # a drawer front, flush
    box_normals = np.where((np.abs(carcass[:, 0] + 0.3) < 1e-9)[:, None], x,
                           np.where((np.abs(np.abs(carcass[:, 1]) - 0.4) < 1e-9)[:, None],
                                    y, z))
    cloud, normals = _facing(door, divider, shut)
    cloud, normals = np.concatenate([carcass, cloud]), np.concatenate([box_normals, normals])
    n = np.cumsum([0, len(carcass), len(door[0]), len(divider[0]), len(shut[0])])
    labels = np.ones(len(cloud), int)
    labels[n[1]:n[2]], labels[n[2]:n[3]], labels[n[3]:] = 2, 3, 4
    assert len(divider[0]) > 0.03 * len(carcass)
    assert return_enclosed(cloud, labels, 0.02)[1] == []  # not small, thick, deep nor through
    out, moved = return_frontless(cloud, labels, 0.02, normals=normals)
    assert moved == [{"part": 3, "points": len(divider[0]), "frontless": True}]
    assert (out[:n[1]] == 1).all() and (out[n[2]:n[3]] == 1).all()
    assert len(set(out[n[1]:n[2]]) | set(out[n[3]:])) == 2 and 1 not in out[n[1]:n[2]]
    assert 1 not in out[n[3]:]  # the shut drawer's front
    assert return_frontless(cloud, labels, 0.02)[1] == []  # needs the measured normals
    closed = np.concatenate([np.arange(n[1]), np.arange(n[2], n[4])])
    assert return_frontless(cloud[closed], labels[closed] - (labels[closed] > 2),
                            0.02, normals=normals[closed])[1] == []


def test_a_dividers_label_holding_strips_of_the_face_frame_goes_back():
    """The divider of the test above in a label that also holds strips of the carcass's
    face frame and shelves' front edges at the opening (facing out of it, flush with it,
    spread over a stretch 28 cm wide and 80 cm tall: a "front" by :func:`_fronts`, its
    label's points at its depth, the divider's edge with them, filling a fifth of its
    outline): no surface, so the label goes back. A drawer front seen shut
    fills its outline and stays; so does the label with its strips when
    ``front_cover`` asks nothing of a front."""
    from pipeline.compartments import CompartmentOptions, return_frontless

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    carcass = _open_box()
    box_normals = np.where((np.abs(carcass[:, 0] + 0.3) < 1e-9)[:, None], x,
                           np.where((np.abs(np.abs(carcass[:, 1]) - 0.4) < 1e-9)[:, None],
                                    y, z))
    door = (_grid(0.4, 0.7, (0.32, -0.42, -0.35), x, z), y)  # swung square
    divider = (_grid(0.24, 0.8, (0.06, 0.1, -0.4), x, z), y)
    edges = [(_grid(0.26, 0.0, (0.29, 0.1, h), y, z), x) for h in (-0.4, -0.1, 0.2, 0.4)]
    rim = (_grid(0.0, 0.8, (0.29, 0.38, -0.4), y, z), x)  # the frame's upright
    shut = (_grid(0.3, 0.3, (0.29, -0.35, -0.36), y, z), x)  # a drawer front, flush
    cloud, normals = _facing(door, divider, *edges, rim, shut)
    cloud, normals = np.concatenate([carcass, cloud]), np.concatenate([box_normals, normals])
    n = np.cumsum([0, len(carcass), len(door[0]), len(divider[0])
                   + sum(len(p) for p, _ in edges) + len(rim[0]), len(shut[0])])
    labels = np.ones(len(cloud), int)
    labels[n[1]:n[2]], labels[n[2]:n[3]], labels[n[3]:] = 2, 3, 4
    out, moved = return_frontless(cloud, labels, 0.02, normals=normals)
    assert moved == [{"part": 3, "points": int(n[3] - n[2]), "frontless": True}]
    assert (out[n[2]:n[3]] == 1).all() and 1 not in out[n[3]:]  # the shut front stays
    loose = CompartmentOptions(front_cover=0.0)
    assert return_frontless(cloud, labels, 0.02, loose, normals)[1] == []


def test_a_stretch_of_the_carcass_face_in_a_pulled_out_drawers_label_goes_back():
    """A drawer pulled 20 cm out of a carcass, its front hidden (a door swung in front of
    it): its label holds the drawer's bottom, standing out, and a stretch of the carcass's
    face frame beside it (facing out, level with the face): that stretch, the label's one
    front, goes back. A label whose one front stands out with it (the drawer's own front
    seen) keeps everything; so does one with two fronts at two depths (a drawer shut
    beside one pulled out: :func:`split_fronts`'s)."""
    from pipeline.compartments import (
        CompartmentOptions,
        _carcass_frame,
        _fronts,
        return_face_fronts,
    )

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    carcass = _open_box()
    box_normals = np.where((np.abs(carcass[:, 0] + 0.3) < 1e-9)[:, None], x,
                           np.where((np.abs(np.abs(carcass[:, 1]) - 0.4) < 1e-9)[:, None],
                                    y, z))
    frame = (_grid(0.1, 0.3, (0.3, -0.4, 0.0), y, z), x)  # the face frame, level with it
    bottom = (_grid(0.6, 0.3, (-0.1, -0.2, -0.3), x, y), z)  # the drawer's, 20 cm out
    front = (_grid(0.3, 0.2, (0.5, -0.2, -0.3), y, z), x)  # the drawer's own front
    shut = (_grid(0.25, 0.2, (0.3, 0.1, -0.3), y, z), x)  # a sibling's, shut

    def labelled(*pieces):
        cloud, normals = _facing(*pieces)
        return (np.concatenate([carcass, cloud]), np.concatenate([box_normals, normals]),
                np.concatenate([np.ones(len(carcass), int), np.full(len(cloud), 2)]))

    cloud, normals, labels = labelled(bottom, frame)
    out, moved = return_face_fronts(cloud, labels, 0.02, normals=normals)
    assert moved == [{"part": 2, "points": len(frame[0]), "face_front": True}]
    assert (out[len(carcass) + len(bottom[0]):] == 1).all()
    assert (out[len(carcass):len(carcass) + len(bottom[0])] == 2).all()
    assert return_face_fronts(cloud, labels, 0.02)[1] == []  # needs the measured normals
    # a drawer shut, its front level with the face and its handle 7 cm out (facing out
    # as the front does), in a label with the face frame: nothing past the front but that
    handle = (_grid(0.2, 0.04, (0.37, -0.15, -0.2), y, z), x)
    cloud, normals, labels = labelled((shut[0] - (0, 0.3, 0), x), handle, frame)
    assert return_face_fronts(cloud, labels, 0.02, normals=normals)[1] == []
    for pieces in ((bottom, front), (bottom, front, shut)):
        cloud, normals, labels = labelled(*pieces)
        body, local, square = _carcass_frame(cloud, labels, 0.02, CompartmentOptions(),
                                             normals)
        fronts = _fronts(local, square, np.nonzero(labels == 2)[0], (0, 1), body.extent,
                         0.02, CompartmentOptions())
        assert len(fronts) == len(pieces) - 1
        assert return_face_fronts(cloud, labels, 0.02, normals=normals)[1] == []
def _drawers_out_of_a_table():
    """A carcass open at the front (x = 0.3) whose top overhangs the front by 6 cm, and three
    drawers pulled 35 cm out side by side, 8 cm apart: each a front facing out and a
    bottom. Points, their normals, and each piece's slice: the carcass, the drawers."""
    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    carcass = [(_grid(0.8, 0.8, (-0.3, -0.4, -0.4), y, z), x),
               (_grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, z), y),
               (_grid(0.6, 0.8, (-0.3, 0.4, -0.4), x, z), y),
               (_grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, y), z),
               (_grid(0.66, 0.8, (-0.3, -0.4, 0.4), x, y), z)]  # the top, 6 cm over
    drawers = [[(_grid(0.2, 0.2, (0.65, y0, -0.3), y, z), x),
                (_grid(0.54, 0.2, (0.1, y0, -0.3), x, y), z)] for y0 in (-0.38, -0.1, 0.18)]
    cloud, normals = _facing(*carcass, *(piece for d in drawers for piece in d))
    n = np.cumsum([0, sum(len(p) for p, _ in carcass),
                   *(sum(len(p) for p, _ in d) for d in drawers)])
    return cloud, normals, [slice(n[i], n[i + 1]) for i in range(len(n) - 1)]


def test_a_drawer_left_in_the_carcass_label_does_not_stretch_its_box_past_the_walls():
    """Of three drawers pulled out of a table, the masks left one in the carcass's label: its
    box reaches the drawers' fronts, 35 cm past the table's walls, so no drawer stands out
    of it. Drawn in to its walls (the second wall out: the sides and floor end at the
    front, the top 6 cm past it), the box leaves the other two standing out, and the
    drawer's points past the walls become a part of their own; the top's overhang, on the
    top's plane, stays. With no drawer in a label of its own standing out there, without
    measured normals, with a front rim facing out, or with much of the label past the walls
    (its own surface, the walls seen short of it), the box is the label's."""
    from pipeline.compartments import (
        CompartmentOptions,
        carcass_box,
        give_past_walls,
        within_walls,
    )

    def walled(cloud, labels, normals, options=None):
        options = options or CompartmentOptions()
        return within_walls(carcass_box(cloud[labels == 1], 0.02, options), cloud[labels == 1],
                            normals[labels == 1], cloud[labels > 1], 0.02, options)

    cloud, normals, (carcass, a, b, c) = _drawers_out_of_a_table()
    labels = np.ones(len(cloud), int)
    labels[a], labels[b] = 2, 3
    whole = carcass_box(cloud[labels == 1], 0.02)
    assert np.isclose(whole.center[0] + whole.extent[0], 0.65, atol=1e-6)
    body = walled(cloud, labels, normals)
    assert np.isclose(body.center[0] + body.extent[0], 0.32, atol=1e-6)
    assert np.allclose([body.center[0] - body.extent[0], *body.extent[1:]],
                       [-0.3, *whole.extent[1:]], atol=1e-6)
    out, moved = give_past_walls(cloud, labels, 0.02, normals=normals)
    past = np.zeros(len(cloud), bool)
    past[c] = cloud[c, 0] > 0.32
    assert len(set(out[past])) == 1 and out[past][0] not in (1, out[a][0], out[b][0])
    assert (out[~past & (labels == 1)] == 1).all()  # the top's overhang too
    assert moved == [{"part": int(out[past][0]), "points": int(past.sum()),
                      "past_walls": True, "own": True}]
    assert np.all(cloud[carcass][:, 0] <= 0.36 + 1e-9)
    # a piece past the walls smaller than enclosed_share of the carcass (the drawer's front
    # alone, its bottom unseen) touching no part stays: no part is made of it
    seen = np.ones(len(cloud), bool)
    seen[c] = ~(past[c] & (cloud[c, 0] < 0.65 - 1e-9))
    assert np.count_nonzero(past & seen) < 0.03 * np.count_nonzero((labels == 1) & seen)
    assert give_past_walls(cloud[seen], labels[seen], 0.02, normals=normals[seen])[1] == []
    # a piece past the walls going on from the carcass (its floor 8 cm further out, its
    # normals not square) stays, at any size (here enclosed_share 1 %): most of it touches
    # the carcass; taken only where past_walls_held lets it
    ledge = _grid(0.06, 0.8, (0.32, -0.4, -0.4), (1, 0, 0), (0, 1, 0))
    more = np.concatenate([cloud, ledge])
    more_normals = np.concatenate([normals, np.zeros((len(ledge), 3))])
    more_labels = np.r_[labels, np.ones(len(ledge), int)]
    small = CompartmentOptions(enclosed_share=0.01)
    out, moved = give_past_walls(more, more_labels, 0.02, small, more_normals)
    assert (out[len(cloud):] == 1).all() and [m["points"] for m in moved] == [past.sum()]
    loose = CompartmentOptions(enclosed_share=0.01, past_walls_held=1.0)
    out = give_past_walls(more, more_labels, 0.02, loose, more_normals)[0]
    assert (out[len(cloud):][ledge[:, 0] > 0.33] != 1).all()
    # nothing stands out: the box is the label's, nothing moves
    alone = np.ones(len(cloud), int)
    assert np.allclose(walled(cloud, alone, normals).extent,
                       carcass_box(cloud, 0.02).extent)
    assert give_past_walls(cloud, alone, 0.02, normals=normals)[1] == []
    assert give_past_walls(cloud, labels, 0.02)[1] == []
    # a front rim facing out is the front, however short of it the other walls are seen
    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    short = [(_grid(0.8, 0.8, (-0.3, -0.4, -0.4), y, z), x),
             (_grid(0.48, 0.8, (-0.3, -0.4, -0.4), x, z), y),
             (_grid(0.48, 0.8, (-0.3, 0.4, -0.4), x, z), y),
             (_grid(0.48, 0.8, (-0.3, -0.4, -0.4), x, y), z),
             (_grid(0.48, 0.8, (-0.3, -0.4, 0.4), x, y), z),
             (_grid(0.8, 0.8, (0.3, -0.4, -0.4), y, z)[::3], x)]  # the rim, 12 cm proud
    rimmed, rimmed_normals = _facing(*short)
    rimmed = np.concatenate([rimmed, cloud[a], cloud[b]])
    rimmed_normals = np.concatenate([rimmed_normals, normals[a], normals[b]])
    kept = np.r_[np.ones(len(rimmed) - len(cloud[a]) - len(cloud[b]), int),
                 np.full(len(cloud[a]), 2), np.full(len(cloud[b]), 3)]
    assert np.allclose(walled(rimmed, kept, rimmed_normals).extent,
                       carcass_box(rimmed[kept == 1], 0.02).extent)
    # more of the label past its walls than past_walls_share (here 2 %; the drawer and
    # the overhang are 6 % of it): its own surface, the walls seen short of it
    strict = CompartmentOptions(past_walls_share=0.02)
    assert np.allclose(walled(cloud, labels, normals, strict).extent, whole.extent)


def test_a_level_front_is_a_sibling_only_apart_from_the_part_and_as_tall_as_a_front():
    """The two guards of :func:`find_level_fronts`: a level piece of the carcass's label
    that is the part's own front (most of it next to the front, across its whole width) or
    a strip no taller than a table top's edge (3 cm against a drawer front's 25) finds no
    sibling; a sibling touching the part along one edge only (across the gap between two
    drawers) is still one (:func:`_on_own_front`)."""
    from scipy.spatial import cKDTree

    from pipeline.compartments import _on_own_front, find_level_fronts

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    own = _grid(0.25, 0.2, (0.0, -0.3, -0.3), y, z)[:, 1:]  # a drawer's front on the face
    tree, apart = cKDTree(own), 0.04
    assert _on_own_front(own + [0.01, 0.0], tree, apart)  # its own front, a cm aside
    sibling = _grid(0.25, 0.2, (0.0, -0.045, -0.3), y, z)[:, 1:]  # 1.5 cm beside it
    assert not _on_own_front(sibling, tree, apart)  # touches along one edge strip only
    assert not _on_own_front(sibling + [0.5, 0.0], tree, apart)  # far away

    # a drawer pulled 15 cm out (its own label); level with its front, in the carcass's
    # label, a strip 3 cm tall with a thin lip behind it: no drawer front
    box = _open_box()
    box_normals = np.where((np.abs(box[:, 0] + 0.3) < 1e-9)[:, None], x,
                           np.where((np.abs(np.abs(box[:, 1]) - 0.4) < 1e-9)[:, None], y, z))
    rim = np.concatenate([_grid(0.8, 0.06, (0.3, -0.4, -0.4), y, z),
                          _grid(0.8, 0.06, (0.3, -0.4, 0.34), y, z)])
    strip = _grid(0.3, 0.03, (0.45, 0.05, 0.3), y, z)
    lip = _grid(0.15, 0.3, (0.3, 0.05, 0.3), x, y)
    drawer = [(_grid(0.25, 0.2, (0.45, -0.3, -0.3), y, z), x),
              (_grid(0.45, 0.25, (0.0, -0.3, -0.3), x, y), z)]
    cloud, normals = _facing((rim, x), (strip, x), (lip, z), *drawer)
    cloud, normals = np.concatenate([box, cloud]), np.concatenate([box_normals, normals])
    labels = np.ones(len(cloud), int)
    labels[len(box) + len(rim) + len(strip) + len(lip):] = 2
    assert find_level_fronts(cloud, labels, 0.02, normals=normals)[1] == []
    # the same strip 25 cm tall (a sibling drawer's front) is found
    tall = _grid(0.3, 0.25, (0.45, 0.05, -0.3), y, z)
    cloud2, normals2 = _facing((rim, x), (tall, x), *drawer)
    cloud2 = np.concatenate([box, cloud2])
    normals2 = np.concatenate([box_normals, normals2])
    labels2 = np.ones(len(cloud2), int)
    labels2[len(box) + len(rim) + len(tall):] = 2
    assert [m["level_front"] for m in find_level_fronts(cloud2, labels2, 0.02,
                                                        normals=normals2)[1]] == [True]


def test_a_turned_panel_is_found_the_same_every_time():
    """The plane of a noisy door swung 40 degrees is found, and found identically on a
    second call (open3d's segment_plane, seeded, returned other planes run to run)."""
    from pipeline.compartments import turned_panel
    from pipeline.obb import part_obb

    x, y, z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    body = part_obb(np.concatenate([_grid(0.6, 0.8, (-0.3, -0.4, -0.4), x, z),
                                    _grid(0.8, 0.8, (-0.3, -0.4, -0.4), y, z)]))
    a = np.radians(40)
    door = _grid(0.8, 0.8, (0.3, -0.4, -0.4), (np.sin(a), np.cos(a), 0), z)
    door = door + np.random.default_rng(1).normal(0, 0.004, door.shape)
    first, second = (turned_panel(door, body, 0.02) for _ in range(2))
    assert abs(first[3] - 40.0) < 1.0
    for one, two in zip(first, second, strict=True):
        assert np.array_equal(one, two)


def test_the_network_sees_the_object_on_its_training_background():
    """A room's colours around the object (no depth there after isolation) become the
    renders' background; a hole inside the object (a sensor's missing pixel) keeps its
    colour; a render of the object alone is passed on as it is."""
    from pipeline.render import background_rgb8
    from pipeline.segment.features import object_rgb

    depth = np.zeros((20, 30), np.float32)
    depth[5:15, 8:20] = 1.5
    depth[9, 12] = 0.0  # a missing pixel inside the object
    rgb = np.full((20, 30, 3), 90, np.uint8)  # the floor
    rgb[5:15, 8:20] = 200
    out = object_rgb(rgb, depth)
    assert (out[depth == 0][:, :3] == background_rgb8()).all(axis=1).sum() == 20 * 30 - 120
    assert (out[9, 12] == 200).all() and (out[5:15, 8:20] == 200).all()
    alone = render_object(generate("storage_furniture", 2, 1), views=2, seed=0, width=64,
                          height=64)
    for f in alone.frames:
        assert object_rgb(f.rgb, f.depth) is f.rgb
