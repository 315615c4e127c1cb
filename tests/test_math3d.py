"""tumble.math3d: the star matrix (ERRATA 1), quaternions and re-orthonormalisation,
compared with NumPy's cross product and SciPy's Rotation (independent implementations)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from tumble import math3d

finite = st.floats(min_value=-1e3, max_value=1e3, allow_nan=False)
vec3 = st.tuples(finite, finite, finite).map(np.array)


@settings(max_examples=200, deadline=None, derandomize=True)  # the same examples every run: CI stays reproducible
@given(vec3, vec3)
def test_star_is_the_cross_product(w, a):
    # ERRATA 1: w* a = w x a. Each component is a difference of two products, each side
    # rounded at most twice (NumPy may fuse a multiply-add): equal within 2 eps |w| |a|.
    scale = max(1.0, np.linalg.norm(w) * np.linalg.norm(a))
    np.testing.assert_allclose(math3d.star(w) @ a, np.cross(w, a), rtol=0, atol=2 * 2.3e-16 * scale)


def test_star_is_skew_and_the_slide_matrix_is_not():
    w = np.array([0.3, -1.2, 2.5])
    S = math3d.star(w)
    np.testing.assert_array_equal(S, -S.T)
    slide = np.array([[0, -w[2], -w[1]], [-w[2], 0, -w[0]], [-w[1], -w[0], 0]])
    a = np.array([1.0, 2.0, 3.0])
    assert not np.allclose(slide @ a, np.cross(w, a))
    assert not np.allclose(slide @ a, -np.cross(w, a))


def test_quaternion_matrix_round_trip_matches_scipy():
    rng = np.random.default_rng(1)
    q = math3d.random_quaternions(500, rng)
    for qi in q:
        R = math3d.quat_to_matrix(qi)
        ref = Rotation.from_quat([qi[1], qi[2], qi[3], qi[0]]).as_matrix()
        np.testing.assert_allclose(R, ref, atol=1e-15)
        back = math3d.matrix_to_quat(R)
        assert back[0] >= 0
        np.testing.assert_allclose(back, qi if qi[0] >= 0 else -qi, atol=1e-15)


def test_quat_multiply_composes_rotations():
    rng = np.random.default_rng(2)
    a, b = math3d.random_quaternions(2, rng)
    np.testing.assert_allclose(math3d.quat_to_matrix(math3d.quat_multiply(a, b)), math3d.quat_to_matrix(a) @ math3d.quat_to_matrix(b), atol=1e-15)


def test_quat_exp_is_the_exact_rotation_about_omega():
    q = np.array([1.0, 0.0, 0.0, 0.0])
    math3d.quat_exp_multiply_inplace(q, 0.0, 0.0, 2.0, 0.25)  # 0.5 rad about z
    np.testing.assert_allclose(math3d.quat_to_matrix(q), Rotation.from_rotvec([0, 0, 0.5]).as_matrix(), atol=1e-16)
    q = np.array([1.0, 0.0, 0.0, 0.0])
    math3d.quat_exp_multiply_inplace(q, 1e-9, 0.0, 0.0, 1.0)  # tiny angle: the series branch
    np.testing.assert_allclose(q, [1.0, 5e-10, 0.0, 0.0], rtol=1e-15, atol=0)


def test_orthonormalize_returns_a_rotation_keeping_the_first_axis():
    rng = np.random.default_rng(3)
    R0 = Rotation.random(random_state=4).as_matrix()
    R = R0 + 1e-3 * rng.standard_normal((3, 3))
    math3d.orthonormalize_inplace(R)
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-15)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-15)
    first = R0[:, 0] + 0  # the first column keeps the perturbed first column's direction
    assert np.linalg.norm(R[:, 0] - first) < 1e-2


def test_euler_degrees_is_z_y_x():
    q = math3d.quat_from_euler_deg([0.0, 0.0, 90.0])  # yaw 90 degrees about z
    np.testing.assert_allclose(math3d.quat_to_matrix(q) @ [1, 0, 0], [0, 1, 0], atol=1e-15)
    q = math3d.quat_from_euler_deg([90.0, 0.0, 0.0])  # roll 90 degrees about x
    np.testing.assert_allclose(math3d.quat_to_matrix(q) @ [0, 1, 0], [0, 0, 1], atol=1e-15)


def test_argsort_stable_gives_numpys_stable_order():
    """``math3d.argsort_stable`` (the broadphase's, slabs' and ray tree's sort) against NumPy's
    stable argsort: the same permutation, ties included (keys drawn from a few values so that
    most of them tie), for float and integer keys of every length up to 300. An unstable or
    wrong merge fails on the ties."""
    from tumble.math3d import argsort_stable

    rng = np.random.default_rng(7)
    for n in list(range(0, 40)) + [127, 128, 129, 300]:
        for keys in (rng.integers(0, 5, n).astype(np.float64), rng.standard_normal(n), rng.integers(-3, 3, n)):
            np.testing.assert_array_equal(argsort_stable(keys), np.argsort(keys, kind="stable"))
