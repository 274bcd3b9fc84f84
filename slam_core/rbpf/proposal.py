"""The improved proposal of Grisetti, Stachniss & Burgard (2007), compiled with numba.

For each particle ``i`` with pose ``x_{t-1}`` and map ``m``:

1. predict ``x' = x_{t-1} (+) u_t`` from odometry (corrected by the error the
   coarse search found, :mod:`slam_core.rbpf.correlative`) and scan-match it
   against ``m`` to ``x*`` (hill climbing, :mod:`slam_core.rbpf.scan_matcher`);
2. evaluate ``tau_j = p(z_t | m, x_j) p(x_j | x_{t-1}, u_t)`` at the 3 x 3 x 3
   poses ``x_j`` around ``x*``;
3. fit a Gaussian: ``mu = sum tau_j x_j / eta``, ``Sigma = sum tau_j (x_j - mu)(x_j - mu)^T / eta``
   with ``eta = sum tau_j``, and draw ``x_t ~ N(mu, Sigma)``;
4. multiply the weight by ``eta``.

When too few beams match (an unmapped area, a failed match) the particle is
drawn from the motion model instead and weighted by its observation likelihood.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from slam_core.geometry import wrap_scalar
from slam_core.jit import njit
from slam_core.motion_model import apply_motion, log_likelihood_one, noise_stds
from slam_core.rbpf.scan_matcher import evaluate_pose, hill_climb

#: Variance floor of the fitted proposal (m^2, m^2, rad^2).
MIN_VARIANCE = np.array([1e-6, 1e-6, 1e-7])


@njit
def _cholesky3(a):
    lower = np.zeros((3, 3))
    for i in range(3):
        for j in range(i + 1):
            s = a[i, j]
            for k in range(j):
                s -= lower[i, k] * lower[j, k]
            if i == j:
                lower[i, i] = np.sqrt(max(s, 1e-18))
            else:
                lower[i, j] = s / lower[j, j]
    return lower


@njit
def _fit_and_draw(points, log_tau, noise, min_variance):
    """Gaussian fit of weighted points ``(k, 3)``; returns ``(draw (3,), log eta)``."""
    top = log_tau.max()
    w = np.exp(log_tau - top)
    eta = w.sum()
    mean = np.zeros(3)
    for k in range(points.shape[0]):
        mean += w[k] * points[k]
    mean /= eta
    cov = np.zeros((3, 3))
    for k in range(points.shape[0]):
        d = points[k] - mean
        for i in range(3):
            for j in range(3):
                cov[i, j] += w[k] * d[i] * d[j]
    cov /= eta
    for i in range(3):
        cov[i, i] += min_variance[i]
    draw = mean + _cholesky3(cov) @ noise
    return draw, top + np.log(eta)


@njit(parallel=True)
def improved_proposal(tables, lo, hits, origin_x, origin_y, resolution, prev, starts, motion, alphas,
                      beams, params, search, min_variance, noise, out_pose, out_logw, out_matched):
    """Draw every particle's new pose; fills ``out_pose``, ``out_logw`` (log eta), ``out_matched``.

    ``starts`` are the poses the matching starts from, ``motion`` is
    ``(rot1, trans, rot2)`` of the odometry; ``search`` is
    ``(linear_step, angular_step, refinements, sample_linear, sample_angular, min_matched_beams)``.
    """
    rot1, trans, rot2 = motion[0], motion[1], motion[2]
    a1, a2, a3, a4 = alphas[0], alphas[1], alphas[2], alphas[3]
    for p in prange(prev.shape[0]):
        table = tables[p]
        x0, y0, th0 = prev[p, 0], prev[p, 1], prev[p, 2]
        mx, my, mth, _ = hill_climb(table, lo, hits, origin_x, origin_y, resolution,
                                    starts[p, 0], starts[p, 1], starts[p, 2],
                                    beams, params, search[0], search[1], int(search[2]))
        _, _, matched = evaluate_pose(table, lo, hits, origin_x, origin_y, resolution, mx, my, mth,
                                      beams, params)
        if matched < search[5]:
            s1, st, s2 = noise_stds(rot1, trans, rot2, a1, a2, a3, a4)
            x, y, th = apply_motion(x0, y0, th0, rot1 + s1 * noise[p, 0], trans + st * noise[p, 1],
                                    rot2 + s2 * noise[p, 2])
            _, ll, _ = evaluate_pose(table, lo, hits, origin_x, origin_y, resolution, x, y, th,
                                     beams, params)
            out_pose[p, 0] = x
            out_pose[p, 1] = y
            out_pose[p, 2] = th
            out_logw[p] = ll
            out_matched[p] = False
            continue
        points = np.empty((27, 3))
        log_tau = np.empty(27)
        k = 0
        for i in range(-1, 2):
            for j in range(-1, 2):
                for a in range(-1, 2):
                    x = mx + i * search[3]
                    y = my + j * search[3]
                    th = mth + a * search[4]
                    _, ll, _ = evaluate_pose(table, lo, hits, origin_x, origin_y, resolution,
                                             x, y, th, beams, params)
                    lm = log_likelihood_one(x0, y0, th0, x, y, th, rot1, trans, rot2, a1, a2, a3, a4)
                    points[k, 0] = x
                    points[k, 1] = y
                    points[k, 2] = th - mth
                    log_tau[k] = ll + lm
                    k += 1
        draw, log_eta = _fit_and_draw(points, log_tau, noise[p], min_variance)
        out_pose[p, 0] = draw[0]
        out_pose[p, 1] = draw[1]
        out_pose[p, 2] = wrap_scalar(draw[2] + mth)
        out_logw[p] = log_eta
        out_matched[p] = True
