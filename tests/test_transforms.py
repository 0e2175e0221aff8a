"""Rotation conversions every format writer uses."""

from __future__ import annotations

import numpy as np
import pytest

from real2code_export import transforms as tf


@pytest.mark.parametrize("quat", [
    (1.0, 0.0, 0.0, 0.0),  # the identity: trace > 0
    (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0), (0.0, 0.0, 0.0, 1.0),  # half turns: each
    (0.1, 0.9, 0.3, -0.2), (0.05, -0.2, 0.95, 0.1), (0.02, 0.1, -0.3, 0.9),  # diagonal largest
    (-0.7, 0.1, 0.2, 0.3),  # w < 0: the same rotation comes back with w > 0
])
def test_matrix_to_quat_inverts_quat_to_matrix_with_w_not_negative(quat):
    q = np.asarray(quat) / np.linalg.norm(quat)
    back = tf.matrix_to_quat(tf.quat_to_matrix(q))
    assert back[0] >= 0.0
    np.testing.assert_allclose(back, q if q[0] >= 0 else -q, atol=1e-12)
    assert np.linalg.norm(back) == pytest.approx(1.0, abs=1e-15)


def test_matrix_to_quat_of_many_rotations():
    rng = np.random.default_rng(7)
    for q in rng.normal(size=(500, 4)):
        r = tf.quat_to_matrix(q)
        np.testing.assert_allclose(tf.quat_to_matrix(tf.matrix_to_quat(r)), r, atol=1e-12)


def test_short_norm_is_numpys_norm_bit_for_bit():
    """transforms.short_norm: np.linalg.norm's float for quaternions and 3-vectors (the
    squares added in order, as BLAS adds so few), so matrix_to_quat and the USD writer's
    quaternions stay the same."""
    rng = np.random.default_rng(17)
    for n in (3, 4):
        vectors = rng.normal(size=(20000, n)) * 10.0 ** rng.integers(-8, 8, (20000, 1))
        vectors[::7, 0] = 0.0
        for v in vectors:
            assert tf.short_norm(v.tolist()) == np.linalg.norm(v)
    assert tf.short_norm([0.0, 0.0, 0.0, 0.0]) == 0.0


def test_is_rotation_is_allclose_to_the_identity_as_numpy_tells_it():
    """transforms.is_rotation: np.allclose(r.T @ r, I, atol=tol)'s answer (and det > 0),
    at the tolerance's edge too."""
    rng = np.random.default_rng(23)
    for k in range(3000):
        r = tf.quat_to_matrix(rng.normal(size=4))
        r = r + rng.normal(size=(3, 3)) * 10.0 ** rng.uniform(-9, -5)
        if k % 10 == 0:
            r[rng.integers(3), rng.integers(3)] = [np.inf, np.nan, 1e200][k % 3]
        want = (bool(np.all(np.isfinite(r))) and np.allclose(r.T @ r, np.eye(3), atol=1e-6)
                and np.linalg.det(r) > 0)
        assert tf.is_rotation(r) == want
    assert not tf.is_rotation(-np.eye(3)) and tf.is_rotation(np.eye(3))


def test_allclose_to_finite_is_numpys_allclose():
    """transforms.allclose_to_finite: np.allclose's answer where the second array is
    finite, a NaN or infinity in the first included."""
    rng = np.random.default_rng(29)
    for k in range(3000):
        b = rng.normal(size=(3, 3)) * 10.0 ** rng.integers(-6, 6)
        a = b + rng.normal(size=(3, 3)) * 10.0 ** rng.uniform(-12, -3)
        if k % 9 == 0:
            a[rng.integers(3), rng.integers(3)] = [np.inf, -np.inf, np.nan][k % 3]
        atol = [1e-8, 1e-9, 1e-6][k % 3]
        assert tf.allclose_to_finite(a, b, atol=atol) == np.allclose(a, b, atol=atol)
    assert tf.allclose_to_finite(np.array([0, 0, 0, 1.0]), (0.0, 0.0, 0.0, 1.0))
