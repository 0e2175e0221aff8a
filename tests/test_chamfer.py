"""Chamfer distance: the paper's convention (sum of two mean squared nearest distances),
planted values recovered, parts matched optimally."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from pipeline.chamfer import (
    ChamferError,
    chamfer_distance,
    object_chamfer,
    part_chamfer,
    points_chamfer,
)


def _sphere(radius: float, centre=(0.0, 0.0, 0.0)) -> trimesh.Trimesh:
    mesh = trimesh.creation.icosphere(subdivisions=5, radius=radius)
    mesh.apply_translation(centre)
    return mesh


def test_identical_meshes_are_at_zero_and_resampling_is_close():
    box = trimesh.creation.box((0.4, 0.3, 0.2))
    assert chamfer_distance(box, box) == 0.0
    # Two different samplings of one surface: only the sampling spacing remains (< 0.1 mm^2).
    a = trimesh.sample.sample_surface(box, 10_000, seed=1)[0]
    b = trimesh.sample.sample_surface(box, 10_000, seed=2)[0]
    assert 0 < points_chamfer(a, b) < 1e-4


def test_concentric_spheres_give_twice_the_squared_gap():
    # Every nearest point is radial, so each direction contributes gap^2.
    gap = 0.1
    cd = chamfer_distance(_sphere(1.0), _sphere(1.0 + gap))
    assert cd == pytest.approx(2 * gap**2, rel=0.05)


def test_symmetric_and_quadratic_in_scale():
    a = trimesh.creation.box((0.5, 0.4, 0.3))
    b = trimesh.creation.cylinder(radius=0.2, height=0.5, sections=24)
    cd = chamfer_distance(a, b)
    assert chamfer_distance(b, a) == pytest.approx(cd, rel=1e-12)
    scaled_a, scaled_b = a.copy(), b.copy()
    scaled_a.apply_scale(3.0)
    scaled_b.apply_scale(3.0)
    # Same seed, same faces drawn, same barycentric coordinates: exactly 9 times.
    assert chamfer_distance(scaled_a, scaled_b) == pytest.approx(9.0 * cd, rel=1e-9)


def test_parts_are_matched_optimally_whatever_their_order():
    gt = [_sphere(0.2, (0, 0, 0)), trimesh.creation.box((0.3, 0.3, 0.3)),
          _sphere(0.1, (0, 2, 0))]
    gt[1].apply_translation((2, 0, 0))
    shifted = [m.copy() for m in gt]
    for k, m in enumerate(shifted):
        m.apply_translation((0.01 * (k + 1), 0, 0))
    pred = [shifted[2], shifted[0], shifted[1]]
    result = part_chamfer(pred, gt)
    assert result.matching == [(0, 1), (1, 2), (2, 0)]
    expected = [chamfer_distance(shifted[k], gt[k]) for k in range(3)]
    assert result.per_part == pytest.approx(expected, rel=1e-9)
    assert result.mean == pytest.approx(np.mean(expected), rel=1e-9)
    mean, per_part, matching = result  # the contract's tuple
    assert len(per_part) == 3 and len(matching) == 3


def test_a_missing_part_costs_its_distance_to_the_nearest_prediction():
    gt = [_sphere(0.2), _sphere(0.2, (1.0, 0, 0))]
    result = part_chamfer([gt[0].copy()], gt)
    assert result.matching == [(0, 0), (1, 0)]
    assert result.per_part[0] < 1e-4
    assert result.per_part[1] == pytest.approx(chamfer_distance(gt[0], gt[1]), rel=1e-9)
    assert result.per_part[1] > 1.0  # about 2 * (1 m)^2


def test_whole_object_concatenates_parts():
    parts = [_sphere(0.2), _sphere(0.2, (1.0, 0, 0))]
    assert object_chamfer(parts, parts) == 0.0
    assert object_chamfer(parts[:1], parts) > 0.1  # half the object is missing


def test_unscorable_meshes_are_named():
    empty = trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=int))
    with pytest.raises(ChamferError, match="predicted part 1: has no faces"):
        part_chamfer([_sphere(0.1), empty], [_sphere(0.1)])
    flat = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 1, 2]], process=False)
    with pytest.raises(ChamferError, match="second mesh: has zero surface area"):
        chamfer_distance(_sphere(0.1), flat)
    with pytest.raises(ChamferError, match="ground truth: no part meshes"):
        part_chamfer([_sphere(0.1)], [])
