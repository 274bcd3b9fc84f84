"""Motion / observation models of the landmark EKF: Jacobians against finite differences."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from slam_core.ekf.models import (
    inverse_observation,
    motion,
    motion_jacobians,
    observe,
    observe_many,
    odometry_increment,
)
from slam_core.geometry import compose, relative, wrap_angle
from slam_core.motion_model import OdometryMotionModel

EPS = 1e-6
coord = st.floats(-20, 20)
angle = st.floats(-np.pi, np.pi)


def numeric_jacobian(f, x, wrap_rows=()):
    x = np.asarray(x, float)
    f0 = f(x)
    out = np.empty((len(f0), len(x)))
    for k in range(len(x)):
        dx = np.zeros_like(x)
        dx[k] = EPS
        diff = f(x + dx) - f(x - dx)
        for row in wrap_rows:
            diff[row] = wrap_angle(diff[row])
        out[:, k] = diff / (2 * EPS)
    return out


@settings(max_examples=60, deadline=None)
@given(coord, coord, angle, st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1))
def test_motion_jacobians_match_finite_differences(x, y, th, ux, uy, uth):
    pose, u = np.array([x, y, th]), np.array([ux, uy, uth])
    f, g = motion_jacobians(pose, u)
    np.testing.assert_allclose(f, numeric_jacobian(lambda p: motion(p, u), pose, [2]), atol=1e-5)
    np.testing.assert_allclose(g, numeric_jacobian(lambda v: motion(pose, v), u, [2]), atol=1e-5)
    np.testing.assert_allclose(motion(pose, u), compose(pose, u), atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(coord, coord, angle, coord, coord)
def test_observation_jacobians_match_finite_differences(x, y, th, lx, ly):
    pose, lm = np.array([x, y, th]), np.array([lx, ly])
    if np.hypot(lx - x, ly - y) < 0.5:
        return
    z, h_pose, h_lm = observe(pose, lm)
    np.testing.assert_allclose(h_pose, numeric_jacobian(lambda p: observe(p, lm)[0], pose, [1]), atol=1e-5)
    np.testing.assert_allclose(h_lm, numeric_jacobian(lambda q: observe(pose, q)[0], lm, [1]), atol=1e-5)
    zs, hps, hls = observe_many(pose, lm[None])
    np.testing.assert_allclose(zs[0], z, atol=1e-12)
    np.testing.assert_allclose(hps[0], h_pose, atol=1e-12)
    np.testing.assert_allclose(hls[0], h_lm, atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(coord, coord, angle, st.floats(0.5, 15), angle)
def test_inverse_observation_inverts_and_its_jacobians_match(x, y, th, r, b):
    pose, z = np.array([x, y, th]), np.array([r, b])
    lm, g_pose, g_z = inverse_observation(pose, z)
    back = observe(pose, lm)[0]
    assert abs(back[0] - r) < 1e-9 and abs(wrap_angle(back[1] - b)) < 1e-9
    g_pose_numeric = numeric_jacobian(lambda p: inverse_observation(p, z)[0], pose)
    np.testing.assert_allclose(g_pose, g_pose_numeric, atol=1e-5)
    np.testing.assert_allclose(g_z, numeric_jacobian(lambda v: inverse_observation(pose, v)[0], z), atol=1e-5)


def test_odometry_increment_is_the_relative_pose_and_its_covariance_matches_sampling():
    model = OdometryMotionModel()
    o0, o1 = np.array([1.0, 2.0, 0.3]), np.array([1.4, 2.3, 0.6])
    u, q = odometry_increment(o0, o1, model)
    np.testing.assert_allclose(u, relative(o0, o1), atol=1e-12)
    samples = model.sample(np.zeros((40000, 3)), o0, o1, np.random.default_rng(0))
    np.testing.assert_allclose(samples.mean(axis=0), u, atol=3e-3)
    # the linearised covariance agrees with the sampled one to a few percent
    np.testing.assert_allclose(np.cov(samples.T), q, rtol=0.1, atol=2e-5)
