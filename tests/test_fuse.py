"""Fusion: normals measured per depth map land on the surfaces' own normals, a panel's two
faces agree on one axis however they are mixed, and the part clouds carry them."""

from __future__ import annotations

import numpy as np
import trimesh

from pipeline.fuse import axis_mean, normal_map, oriented_part_clouds, part_clouds, point_map
from pipeline.obb import Surface, alignment
from pipeline.procedural import generate
from pipeline.render import render_object
from real2code_export.kinematics import world_part_meshes


def _angle_to(normals: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Sign-free angle in degrees between matching rows."""
    cos = np.abs(np.sum(normals * reference, axis=1))
    return np.degrees(np.arccos(np.clip(cos, 0.0, 1.0)))


def test_depth_map_normals_are_the_surfaces_normals():
    obj = generate("storage_furniture", 4, 5)
    cap = render_object(obj, views=3, width=160, height=160, seed=1)
    meshes = {n: m.to_trimesh() for n, m in world_part_meshes(obj).items()}
    frame = cap.frames[0]
    normals = normal_map(frame)
    pts, valid = point_map(frame)
    known = valid & (np.linalg.norm(normals, axis=-1) > 0.5)
    assert known.sum() > 0.5 * valid.sum()
    rows, cols = np.nonzero(known)
    pick = np.random.default_rng(0).choice(len(rows), 400, replace=False)
    errors = []
    for r, c in zip(rows[pick], cols[pick], strict=True):
        mesh = meshes[cap.parts[frame.mask[r, c] - 1]]
        _, _, face = trimesh.proximity.closest_point(mesh, pts[r, c][None])
        errors.append(_angle_to(normals[r, c][None], mesh.face_normals[face])[0])
    # exact on flat panels; off only where the 3x3 stencil straddles an edge
    assert np.median(errors) < 0.1 and np.mean(np.array(errors) < 2.0) > 0.9


def test_a_panels_two_faces_agree_on_one_axis():
    """Normals measured from either side of a thin panel point opposite ways: their
    sign-free mean is the panel's axis, with full agreement; normals pointing every way
    agree little."""
    rng = np.random.default_rng(0)
    axis = np.array([0.6, 0.0, 0.8])
    points = rng.uniform(-1, 1, (400, 3)) * [0.3, 0.3, 0.01]
    normals = np.where(rng.random(400)[:, None] < 0.5, axis, -axis)
    mean = axis_mean(points[:50], points, normals)
    assert np.allclose(np.abs(mean @ axis), 1.0)
    scattered = rng.normal(size=(400, 3))
    scattered /= np.linalg.norm(scattered, axis=1, keepdims=True)
    weak = np.linalg.norm(axis_mean(points[:50], points, scattered, neighbours=64), axis=1)
    assert weak.max() < 0.7
    # normals of 0 (where a depth map could not tell) are ignored
    unknown = np.where(rng.random(400)[:, None] < 0.3, 0.0, normals)
    assert np.allclose(np.abs(axis_mean(points[:50], points, unknown) @ axis), 1.0)


def test_part_clouds_carry_their_measured_normals():
    obj = generate("storage_furniture", 4, 5)
    cap = render_object(obj, views=6, width=128, height=128, seed=2)
    oriented = oriented_part_clouds(cap)
    plain = part_clouds(cap)
    assert sorted(oriented) == sorted(plain)
    for k, (points, normals) in oriented.items():
        assert np.array_equal(points, plain[k]) and normals.shape == points.shape
        surface = Surface.of((points, normals))
        assert len(surface.weights) > 0.5 * len(points)  # most points: views agree
        # procedural parts are boxes: the measured normals are square to the part's frame
        name = cap.parts[k - 1]
        part = world_part_meshes(obj)[name].to_trimesh()
        frame = trimesh.bounds.oriented_bounds(part)[0][:3, :3].T
        assert alignment(surface, frame) > 0.9, name
