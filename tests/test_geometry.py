"""SE(2) identities, angle wrapping and means, checked with hypothesis."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from slam_core.geometry import (
    circular_mean,
    compose,
    compose_scalar,
    inverse,
    mean_pose,
    relative,
    transform_points,
    wrap_angle,
    wrap_scalar,
)
from tests import naive

coord = st.floats(-1e3, 1e3, allow_nan=False)
angle = st.floats(-20.0, 20.0, allow_nan=False)
poses = st.tuples(coord, coord, angle).map(np.array)
big_angle = st.floats(-1e6, 1e6, allow_nan=False, allow_subnormal=True)


def assert_same_pose(p, q, tol=1e-6):
    assert np.allclose(p[..., :2], q[..., :2], atol=tol, rtol=0)
    assert np.all(np.abs(wrap_angle(p[..., 2] - q[..., 2])) <= tol)


@settings(deadline=None)  # the first call compiles wrap_scalar
@given(big_angle)
def test_wrap_range_and_equivalence(theta):
    w = float(wrap_angle(theta))
    assert -math.pi <= w < math.pi
    assert abs(math.remainder(w - theta, 2 * math.pi)) <= 1e-9 * max(1.0, abs(theta))
    assert wrap_scalar(theta) == w


@pytest.mark.parametrize("theta, expected", [
    (math.pi, -math.pi), (-math.pi, -math.pi), (3 * math.pi, -math.pi), (0.0, 0.0),
    (2 * math.pi + 0.5, 0.5), (-0.5, -0.5),
])
def test_wrap_known_values(theta, expected):
    assert float(wrap_angle(theta)) == pytest.approx(expected, abs=1e-12)


@pytest.mark.parametrize("theta", [np.nextafter(-np.pi, -np.inf), np.nextafter(np.pi, np.inf), -1e-300])
def test_wrap_stays_half_open_next_to_the_seam(theta):
    assert -math.pi <= float(wrap_angle(theta)) < math.pi
    assert -math.pi <= wrap_scalar(theta) < math.pi


def test_wrap_keeps_shape_and_scalar_type():
    assert wrap_angle(np.zeros((2, 3, 4))).shape == (2, 3, 4)
    assert np.ndim(wrap_angle(7.0)) == 0


@settings(deadline=None)  # timing is for benchmarks/, not tests
@given(poses)
def test_compose_with_inverse_is_identity(a):
    assert_same_pose(compose(a, inverse(a)), np.zeros(3))
    assert_same_pose(compose(inverse(a), a), np.zeros(3))


@settings(deadline=None)  # timing is for benchmarks/, not tests
@given(poses, poses, poses)
def test_compose_is_associative(a, b, c):
    assert_same_pose(compose(compose(a, b), c), compose(a, compose(b, c)), tol=1e-6)


@settings(deadline=None)  # timing is for benchmarks/, not tests
@given(poses, poses)
def test_relative_undoes_compose(a, b):
    assert_same_pose(relative(a, compose(a, b)), b)
    assert_same_pose(compose(a, relative(a, b)), b)


@settings(deadline=None)  # the first call compiles compose_scalar
@given(poses, poses)
def test_compose_matches_matrix_product(a, b):
    assert_same_pose(compose(a, b), naive.compose(a, b))
    got = compose_scalar(*a, *b)
    assert_same_pose(np.array(got), compose(a, b), tol=1e-9)


def test_compose_by_hand():
    # Robot at (1, 2) facing +y; a point 1 m ahead and 2 m to its left is at (-1, 3).
    out = compose([1.0, 2.0, math.pi / 2], [1.0, 2.0, math.pi / 2])
    assert np.allclose(out, [-1.0, 3.0, -math.pi])


@settings(deadline=None)  # timing is for benchmarks/, not tests
@given(arrays(float, (7, 3), elements=st.floats(-100, 100)),
       arrays(float, (7, 3), elements=st.floats(-100, 100)))
def test_vectorised_equals_per_pose_loop(a, b):
    stacked = compose(a, b)
    inv = inverse(a)
    rel = relative(a, b)
    for i in range(len(a)):
        assert np.array_equal(stacked[i], compose(a[i], b[i]))
        assert np.array_equal(inv[i], inverse(a[i]))
        assert np.array_equal(rel[i], relative(a[i], b[i]))
    # Broadcasting one pose against a stack.
    assert np.array_equal(compose(a[0], b), np.array([compose(a[0], q) for q in b]))


@given(poses, poses)
def test_one_pose_equals_a_stack_of_one_to_the_bit(a, b):
    """One pose (array, list or tuple) takes a path of its own: the same floats as the array path."""
    assert np.array_equal(compose(list(a), tuple(b)), compose(a[None], b[None])[0])
    assert np.array_equal(inverse(tuple(a)), inverse(a[None])[0])
    assert np.array_equal(relative(a, list(b)), relative(a[None], b[None])[0])


def test_stacks_and_poses_not_finite_go_the_array_way():
    with np.errstate(invalid="ignore"):
        assert np.all(np.isnan(compose([0.0, 0.0, math.inf], [1.0, 0.0, 0.0])))
        assert np.all(np.isnan(inverse(np.array([0.0, 0.0, math.nan]))[:2]))
    assert relative([1, 2, 3], [[1, 2, 3], [0, 0, 0]]).shape == (2, 3)


@settings(deadline=None)  # timing is for benchmarks/, not tests
@given(poses, arrays(float, (5, 2), elements=st.floats(-50, 50)))
def test_transform_points_matches_compose(pose, pts):
    out = transform_points(pose, pts)
    for p, q in zip(pts, out, strict=True):
        assert np.allclose(compose(pose, [p[0], p[1], 0.0])[:2], q, atol=1e-9)


@settings(deadline=None)  # timing is for benchmarks/, not tests
@given(st.floats(-math.pi, math.pi), st.floats(0.0, 0.5))
def test_circular_mean_near_the_seam(centre, spread):
    angles = np.array([centre - spread, centre + spread, centre])
    assert abs(wrap_angle(circular_mean(angles) - centre)) < 1e-9


def test_circular_mean_across_pi():
    m = circular_mean([math.pi - 0.1, -math.pi + 0.1])
    assert abs(abs(m) - math.pi) < 1e-12
    assert circular_mean([0.1, 0.3], weights=[3.0, 1.0]) == pytest.approx(
        math.atan2(3 * math.sin(0.1) + math.sin(0.3), 3 * math.cos(0.1) + math.cos(0.3)))


def test_mean_pose_weights_and_heading_across_pi():
    poses_ = np.array([[0.0, 0.0, math.pi - 0.05], [2.0, 4.0, -math.pi + 0.05]])
    m = mean_pose(poses_)
    assert np.allclose(m[:2], [1.0, 2.0])
    assert abs(abs(m[2]) - math.pi) < 1e-12
    w = mean_pose(poses_, weights=[3.0, 1.0])
    assert np.allclose(w[:2], [0.5, 1.0])
    assert w[2] == pytest.approx(math.pi - 0.025, abs=1e-3)
