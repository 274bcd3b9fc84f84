"""The closed-form proposal against brute-force integration, and the motion covariance by sampling."""

import numpy as np
import pytest

from slam_core.motion_model import OdometryMotionModel, decompose
from slam_core.rbpf.proposal import gaussian_product, inverse3, motion_covariance


def _random_spd(rng, scales):
    a = np.diag(scales) @ (np.eye(3) + 0.4 * rng.normal(size=(3, 3)))
    return a @ a.T + np.diag(scales ** 2) * 0.2


@pytest.mark.parametrize("seed", range(5))
def test_product_matches_numerical_integration(seed):
    rng = np.random.default_rng(seed)
    scales = np.array([0.03, 0.03, 0.02])
    info = inverse3(_random_spd(rng, scales))  # likelihood exp(-(x - x*)^T H (x - x*) / 2)
    motion_cov = _random_spd(rng, scales)
    x_star = np.array([1.0, 2.0, 0.3])
    x_pred = x_star + rng.normal(0, scales)
    mean, cov, log_eta = gaussian_product(x_star, info, x_pred, motion_cov)

    # brute force on a grid wide enough to hold both Gaussians
    half = 6 * scales
    axes = [np.linspace(c - h, c + h, 71) for c, h in zip(x_star, half, strict=True)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    d_l = grid - x_star
    d_m = grid - x_pred
    s_inv = np.linalg.inv(motion_cov)
    log_f = (-0.5 * np.einsum("ni,ij,nj->n", d_l, info, d_l)
             - 0.5 * np.einsum("ni,ij,nj->n", d_m, s_inv, d_m))
    f = np.exp(log_f)
    cell = np.prod([a[1] - a[0] for a in axes])
    integral = f.sum() * cell
    # eta integrates the likelihood against the normalised motion density
    expected = np.log(integral) - 0.5 * np.log(np.linalg.det(motion_cov)) - 1.5 * np.log(2 * np.pi)
    assert log_eta == pytest.approx(expected, abs=1e-2)
    w = f / f.sum()
    brute_mean = w @ grid
    assert np.allclose(mean, brute_mean, atol=1e-4)
    centred = grid - brute_mean
    assert np.allclose(cov, (centred * w[:, None]).T @ centred, rtol=1e-2, atol=1e-8)


def test_motion_covariance_matches_sampled_moments():
    model = OdometryMotionModel()
    start = np.array([0.5, -0.2, 0.7])
    odom0, odom1 = np.array([0.0, 0.0, 0.0]), np.array([0.3, 0.05, 0.2])
    rot1, trans, rot2 = decompose(*odom0, *odom1)
    rng = np.random.default_rng(3)
    samples = model.sample(np.tile(start, (200_000, 1)), odom0, odom1, rng)
    d = samples - samples.mean(axis=0)
    sampled = d.T @ d / len(d)
    cov = motion_covariance(start[2], rot1, trans, rot2, model.alphas, np.zeros(3))
    assert np.allclose(cov, sampled, rtol=0.05, atol=2e-6)
