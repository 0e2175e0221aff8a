"""Shape completion, the parts that need no trained weights: partial views, the unit frame,
exact occupancy, the network's plane sampling, marching cubes, the segment-only baseline."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import torch
import trimesh

from pipeline.chamfer import chamfer_distance
from pipeline.complete import CompletionError, complete_part
from pipeline.complete.baseline import segment_only_mesh
from pipeline.complete.data import CONTEXT_POINTS, INPUT_POINTS, network_input, object_samples
from pipeline.complete.frame import MARGIN, MIN_HALF, MIN_HALF_RATIO, part_frame
from pipeline.complete.learned import mesh_from_grid
from pipeline.complete.network import PLANES, build_network, sample_planes
from pipeline.complete.occupancy import inside, piece_planes, query_points
from pipeline.complete.views import DEFAULT_VIEWS, cast_views, partial_clouds
from pipeline.procedural import generate
from pipeline.weights import WeightsError

EXACT = replace(DEFAULT_VIEWS, depth_noise=0.0, depth_step=0.0, border_swap=0.0)


def _box(size, centre):
    box = trimesh.creation.box(size)
    box.apply_translation(centre)
    return box


def test_views_see_only_what_is_in_front():
    # A cube whose +x face is covered by a plate 2 mm in front: no camera sees that face.
    cube = _box((0.4, 0.4, 0.4), (0, 0, 0.2))
    plate = _box((0.02, 0.6, 0.6), (0.212, 0, 0.2))
    points, labels = cast_views([cube, plate], np.random.default_rng(0), EXACT)
    on_cube = points[labels == 0]
    assert len(on_cube) > 1000 and (labels == 1).sum() > 1000
    x, y, z = on_cube.T
    covered = (x > 0.199) & (np.abs(y) < 0.19) & (z > 0.01) & (z < 0.39)
    assert not covered.any()  # the covered face is hidden, its edges are not
    distance = np.abs(trimesh.proximity.signed_distance(cube, on_cube[::10]))
    assert distance.max() < 1e-4  # exact depth: every point on the surface it is labelled
    again, _ = cast_views([cube, plate], np.random.default_rng(0), EXACT)
    assert np.array_equal(points, again)


def test_views_are_noisy_like_a_depth_png():
    cube = _box((0.4, 0.4, 0.4), (0, 0, 0.2))
    (points,) = partial_clouds([cube], np.random.default_rng(1))
    distance = np.abs(trimesh.proximity.signed_distance(cube, points[::20]))
    assert 0.0005 < np.median(distance) < 0.004  # 2 mm Gaussian, 1 mm steps
    assert np.allclose(np.linalg.norm(points - np.round(points, 6), axis=1), 0, atol=1e-6)


def test_unit_frame_round_trips_and_holds_a_flat_part():
    rng = np.random.default_rng(2)
    pts = rng.uniform([-0.3, -0.2, 0.0], [0.3, 0.2, 0.5], (2000, 3))
    frame = part_frame(pts)
    unit = frame.to_unit(pts)
    assert np.allclose(frame.from_unit(unit), pts)
    assert np.abs(unit).max() == pytest.approx(0.5 / MARGIN, abs=1e-6)
    flat = pts.copy()
    flat[:, 0] = 0.1  # a door seen from the front only
    half = part_frame(flat).half
    floor = max(MIN_HALF, MIN_HALF_RATIO * 0.25)  # the longest half-size is 0.25 m
    assert half.min() == pytest.approx(MARGIN * floor, rel=1e-6)


def test_occupancy_is_the_union_of_the_pieces():
    a, b = _box((0.4, 0.2, 0.2), (0, 0, 0)), _box((0.2, 0.4, 0.2), (0.1, 0.1, 0))
    rng = np.random.default_rng(3)
    q = rng.uniform(-0.4, 0.4, (5000, 3))
    got = inside(piece_planes([a, b]), q)
    assert np.array_equal(got, a.contains(q) | b.contains(q))
    queries = query_points(rng.uniform(-0.2, 0.2, (100, 3)), 1000, rng)
    assert queries.shape == (1000, 3) and np.abs(queries).max() <= 0.5


def test_training_samples_of_a_procedural_object():
    obj = generate("storage_furniture", 3, 4)
    samples = object_samples(obj, np.random.default_rng(4), n_queries=512)
    assert 1 <= len(samples) <= 3
    for s in samples:
        assert s.points.shape == (INPUT_POINTS + CONTEXT_POINTS, 4)
        assert np.all(s.points[:INPUT_POINTS, 3] == 1)
        assert np.abs(s.points[:, :3]).max() <= 0.5 + 1e-3
        assert s.queries.shape == (512, 3) and s.occupied.dtype == bool
        assert 0.03 < s.occupied.mean() < 0.7  # half the queries hug the surface


def test_context_is_flagged_and_limited_to_the_region():
    rng = np.random.default_rng(5)
    own = rng.uniform(0, 0.2, (300, 3))
    far = rng.uniform(5, 6, (300, 3))
    near = rng.uniform(0.2, 0.25, (300, 3))
    x, _ = network_input(own, np.concatenate([far, near]), rng)
    ctx = x[INPUT_POINTS:]
    assert np.all(ctx[:, 3] == 0) and np.abs(ctx[:, :3]).max() <= 0.5
    x_alone, _ = network_input(own, far, rng)  # nothing of the context is in the region
    assert np.all(x_alone[:, 3] == 1)


def test_plane_features_are_read_where_they_were_written():
    res = 8
    planes = torch.rand(1, 3, 5, res, res)
    i, j = 2, 6
    centre = -0.5 + (np.array([i, j]) + 0.5) / res
    for p, (a, b) in enumerate(PLANES):
        q = torch.zeros(1, 1, 3)
        q[0, 0, a], q[0, 0, b] = float(centre[0]), float(centre[1])
        only = torch.zeros_like(planes)
        only[:, p] = planes[:, p]
        got = sample_planes(only, q)[0, 0]
        assert torch.allclose(got, planes[0, p, :, i, j], atol=1e-6)


def test_network_shapes_and_gradients():
    net = build_network(channels=16, resolution=16, hidden=32, blocks=2)
    points = torch.rand(2, 300, 4) - 0.5
    logits = net(points, torch.zeros(2, 3), torch.rand(2, 50, 3) - 0.5)
    assert logits.shape == (2, 50)
    logits.sum().backward()
    assert all(p.grad is not None for p in net.parameters())


def test_marching_cubes_gives_a_closed_mesh_in_the_world():
    # An analytic occupancy: a box half the region's size, plus a one-cell speck to drop.
    frame = part_frame(np.random.default_rng(6).uniform(-1, 1, (500, 3)) * [0.3, 0.2, 0.1]
                       + [1.0, 2.0, 0.5])
    n = 40
    c = -0.5 + (np.arange(n) + 0.5) / n
    u = np.stack(np.meshgrid(c, c, c, indexing="ij"), axis=-1)
    grid = np.all(np.abs(u) < 0.25, axis=-1).astype(float)
    grid[2, 2, 2] = 1.0
    mesh = mesh_from_grid(grid, frame)
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    expected = np.prod(2 * frame.half) / 8  # half of each side
    assert mesh.volume == pytest.approx(expected, rel=0.08)
    assert np.allclose(mesh.centroid, frame.center, atol=0.01)
    assert mesh_from_grid(np.zeros((8, 8, 8)), frame) is None
    # a speck where points were seen stays when enough of them lie on it, not for a stray few
    corner = frame.from_unit(-0.5 + (np.array([[2, 2, 2]]) + 0.5) / n)
    cell = 2 * frame.half / n
    few = corner + np.random.default_rng(0).uniform(-0.3, 0.3, (3, 3)) * cell
    many = corner + np.random.default_rng(1).uniform(-0.3, 0.3, (20, 3)) * cell
    assert len(mesh_from_grid(grid, frame, seen=few).split(only_watertight=False)) == 1
    assert len(mesh_from_grid(grid, frame, seen=many).split(only_watertight=False)) == 2


def test_segment_only_meshes_the_points():
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.3)
    pts, _ = trimesh.sample.sample_surface(sphere, 20000, seed=0)
    mesh = segment_only_mesh(pts)
    assert chamfer_distance(mesh, sphere) < 3e-4  # about 1 cm rms: alpha shapes are rough
    with pytest.raises(CompletionError, match="unknown method 'marching'"):
        segment_only_mesh(pts, method="marching")
    with pytest.raises(CompletionError, match="3 points, at least 4"):
        segment_only_mesh(pts[:3])


def test_segment_only_meshes_a_flat_patch_and_refuses_a_line():
    # A table top voxelised to one layer: Qhull has no 3D Delaunay of coplanar points.
    rng = np.random.default_rng(0)
    rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    patch = np.c_[rng.uniform(0, 0.3, (400, 2)), np.zeros(400)] @ rotation.T
    mesh = segment_only_mesh(patch)
    plate = trimesh.creation.box((0.3, 0.3, 1e-4))
    plate.apply_translation((0.15, 0.15, 0))
    plate.apply_transform(np.block([[rotation, np.zeros((3, 1))], [np.zeros((1, 3)), 1]]))
    assert chamfer_distance(mesh, plate) < 2e-4
    line = np.c_[np.linspace(0, 1, 50), np.zeros((50, 2))]
    with pytest.raises(CompletionError, match="50 points admit no 3D triangulation"):
        segment_only_mesh(line)


def test_bad_input_is_refused_with_a_reason(tmp_path):
    with pytest.raises(CompletionError, match="part points: 10 points, at least 30"):
        complete_part(np.zeros((10, 3)))
    with pytest.raises(CompletionError, match="part points: has non-finite"):
        complete_part(np.full((50, 3), np.nan))
    with pytest.raises(CompletionError, match=r"expected an \(N, 3\) array"):
        complete_part(np.zeros((50, 2)))
    bad = tmp_path / "broken.pt"
    bad.write_bytes(b"not a checkpoint")
    with pytest.raises(WeightsError, match="broken.pt: not occupancy-network weights"):
        complete_part(np.random.default_rng(0).uniform(size=(100, 3)), model=bad)
