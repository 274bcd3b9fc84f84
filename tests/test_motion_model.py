"""The odometry motion model: sampled moments match the model, the likelihood agrees."""

import numpy as np
import pytest

from slam_core.geometry import compose, relative, wrap_angle
from slam_core.motion_model import OdometryMotionModel, decompose, noise_stds

MODEL = OdometryMotionModel(alpha1=0.05, alpha2=0.01, alpha3=0.02, alpha4=0.01)


@pytest.mark.parametrize("odom1", [(1.0, 0.2, 0.3), (0.5, -0.1, -1.0), (-0.6, 0.0, 0.05)])
def test_sampled_motion_moments_match_the_model(odom1):
    odom0 = np.array([2.0, -1.0, 0.4])
    odom1 = compose(odom0, odom1)
    start = np.array([-3.0, 5.0, 2.0])
    rng = np.random.default_rng(0)
    samples = MODEL.sample(np.tile(start, (40000, 1)), odom0, odom1, rng)
    rot1, trans, rot2 = decompose(*odom0, *odom1)
    errors = np.array([decompose(*start, *s) for s in samples[:4000]])
    expected = np.array(noise_stds(rot1, trans, rot2, *MODEL.alphas))
    std = np.array([np.std(wrap_angle(errors[:, 0] - rot1)), np.std(errors[:, 1] - trans),
                    np.std(wrap_angle(errors[:, 2] - rot2))])
    np.testing.assert_allclose(std, expected, rtol=0.08)
    # The mean motion is the odometry's.
    mean_rel = relative(start, samples).mean(axis=0)
    np.testing.assert_allclose(mean_rel[:2], relative(odom0, odom1)[:2], atol=0.01)


def test_likelihood_peaks_at_the_odometry():
    odom0, odom1 = np.zeros(3), np.array([0.8, 0.1, 0.2])
    start = np.array([1.0, 1.0, 0.5])
    exact = compose(start, relative(odom0, odom1))
    rng = np.random.default_rng(1)
    nearby = exact + rng.normal(0, 0.02, (200, 3))
    ll_exact = MODEL.log_likelihood(start, exact, odom0, odom1)[0]
    ll_near = MODEL.log_likelihood(np.tile(start, (200, 1)), nearby, odom0, odom1)
    assert np.all(ll_near <= ll_exact + 1e-9)
