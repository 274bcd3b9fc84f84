"""The improved proposal of Grisetti, Stachniss & Burgard (2007), compiled with numba.

For each particle ``i`` with pose ``x_{t-1}`` and map ``m``:

1. scan-match from the odometry prediction (corrected by the error found on
   the leading map, see :meth:`RBPFSlam._odometry_error`) to ``x*``, the mode of
   the observation likelihood ``p(z_t | m, x)``; Gauss-Newton also gives its
   information matrix ``H`` (:mod:`slam_core.rbpf.scan_matcher`);
2. the motion model ``p(x | x_{t-1}, u_t)``, linearised, is a Gaussian
   ``N(x_p, S)`` around the odometry prediction ``x_p``;
3. the proposal is their product, a Gaussian with information ``L = H + S^-1``
   and mean ``mu = x* + L^-1 S^-1 (x_p - x*)``; the new pose is drawn from it;
4. the weight is multiplied by the normaliser
   ``eta = integral p(z_t | m, x) p(x | x_{t-1}, u_t) dx``, in closed form for the
   Gaussian likelihood around ``x*`` (Laplace's method):
   ``log eta = ll(x*) - log|S| / 2 - log|L| / 2 - (d^T S^-1 d - b^T L^-1 b) / 2``
   with ``d = x_p - x*`` and ``b = S^-1 d`` (constants dropped).

The paper evaluates the likelihood on a fixed set of poses around ``x*`` to fit
that Gaussian; the matcher's own information matrix gives it directly, shaped
by the scene (long along a corridor, tight across it), at no extra cost.

When too few beams match (an unmapped area, a failed match) the particle is
drawn from the motion model instead, as the matches so far calibrated it, and
weighted by its observation likelihood.
"""

from __future__ import annotations

import numpy as np

from slam_core.geometry import wrap_scalar
from slam_core.jit import njit, split
from slam_core.motion_model import apply_motion, noise_stds
from slam_core.rbpf.scan_matcher import cholesky3, match, pose_likelihood


@njit
def inverse3(a):
    """Inverse of a 3 x 3 matrix (cofactors).

    This module's kernels write small arrays element by element rather than as array expressions
    or literals, each of which numba compiles as a function of its own (cold start)."""
    out = np.empty((3, 3))
    out[0, 0] = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
    out[0, 1] = a[0, 2] * a[2, 1] - a[0, 1] * a[2, 2]
    out[0, 2] = a[0, 1] * a[1, 2] - a[0, 2] * a[1, 1]
    out[1, 0] = a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2]
    out[1, 1] = a[0, 0] * a[2, 2] - a[0, 2] * a[2, 0]
    out[1, 2] = a[0, 2] * a[1, 0] - a[0, 0] * a[1, 2]
    out[2, 0] = a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]
    out[2, 1] = a[0, 1] * a[2, 0] - a[0, 0] * a[2, 1]
    out[2, 2] = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
    det = a[0, 0] * out[0, 0] + a[0, 1] * out[1, 0] + a[0, 2] * out[2, 0]
    for i in range(3):
        for j in range(3):
            out[i, j] /= det
    return out


@njit
def _log_det(a):
    lower = cholesky3(a)
    return 2.0 * (np.log(lower[0, 0]) + np.log(lower[1, 1]) + np.log(lower[2, 2]))


@njit
def motion_covariance(th0, rot1, trans, rot2, alphas, floor):
    """Covariance of the odometry prediction from heading ``th0``, linearised at the mean motion."""
    s1, st, s2 = noise_stds(rot1, trans, rot2, alphas[0], alphas[1], alphas[2], alphas[3])
    h = th0 + rot1
    jac = np.zeros((3, 3))
    jac[0, 0] = -trans * np.sin(h)
    jac[0, 1] = np.cos(h)
    jac[1, 0] = trans * np.cos(h)
    jac[1, 1] = np.sin(h)
    jac[2, 0] = 1.0
    jac[2, 2] = 1.0
    var = np.zeros((3, 3))
    var[0, 0] = s1 * s1
    var[1, 1] = st * st
    var[2, 2] = s2 * s2
    cov = jac @ var @ jac.T
    for i in range(3):
        cov[i, i] += floor[i]
    return cov


@njit
def gaussian_product(x_star, info, x_pred, motion_cov):
    """``(mean, covariance, log eta)`` of the likelihood around ``x_star`` times the motion Gaussian."""
    s_inv = inverse3(motion_cov)
    d = np.empty(3)
    d[0] = x_pred[0] - x_star[0]
    d[1] = x_pred[1] - x_star[1]
    d[2] = wrap_scalar(x_pred[2] - x_star[2])
    b = s_inv @ d
    lam = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            lam[i, j] = info[i, j] + s_inv[i, j]
    cov = inverse3(lam)
    shift = cov @ b
    mean = np.empty(3)
    for i in range(3):
        mean[i] = x_star[i] + shift[i]
    log_eta = -0.5 * (_log_det(motion_cov) + _log_det(lam) + d @ b - b @ shift)
    return mean, cov, log_eta


def improved_proposal(tables, lo, hits, origin_x, origin_y, resolution, prev, starts, motion, alphas, beams,
                      params, iterations, wide_iterations, min_matched, motion_floor, noise, out_pose,
                      out_logw, out_matched):
    """Draw the new pose of every particle whose match fits at least ``min_matched`` beams; fills
    ``out_pose``, ``out_logw`` (log eta) and ``out_matched``, which is False for the particles
    left to :func:`motion_draws`.

    ``starts`` are the poses the matching starts from, ``motion`` is
    ``(rot1, trans, rot2)`` of the odometry, ``noise`` standard normal ``(n, 3)``. Particles are
    split over threads (:func:`slam_core.jit.split`).
    """
    split(_propose, prev.shape[0], tables, lo, hits, origin_x, origin_y, resolution, prev, starts, motion,
          alphas, beams, params, iterations, wide_iterations, min_matched, motion_floor, noise, out_pose,
          out_logw, out_matched)


@njit
def _propose(first, stop, tables, lo, hits, origin_x, origin_y, resolution, prev, starts, motion, alphas,
             beams, params, iterations, wide_iterations, min_matched, motion_floor, noise, out_pose, out_logw,
             out_matched):
    """:func:`improved_proposal` for particles ``first`` to ``stop - 1``."""
    rot1, trans, rot2 = motion[0], motion[1], motion[2]
    for p in range(first, stop):
        x0, y0, th0 = prev[p, 0], prev[p, 1], prev[p, 2]
        mx, my, mth, info, matched, ll, _ = match(tables[p], lo, hits, origin_x, origin_y, resolution,
                                                  starts[p, 0], starts[p, 1], starts[p, 2], beams, params,
                                                  iterations, wide_iterations)
        if matched < min_matched:
            out_matched[p] = False
            continue
        px, py, pth = apply_motion(x0, y0, th0, rot1, trans, rot2)
        cov_m = motion_covariance(th0, rot1, trans, rot2, alphas, motion_floor)
        x_star = np.empty(3)
        x_star[0], x_star[1], x_star[2] = mx, my, mth
        x_pred = np.empty(3)
        x_pred[0], x_pred[1], x_pred[2] = px, py, pth
        mean, cov, log_eta = gaussian_product(x_star, info, x_pred, cov_m)
        step = cholesky3(cov) @ noise[p]
        out_pose[p, 0] = mean[0] + step[0]
        out_pose[p, 1] = mean[1] + step[1]
        out_pose[p, 2] = wrap_scalar(mean[2] + step[2])
        out_logw[p] = ll + log_eta
        out_matched[p] = True


@njit
def motion_draws(tables, lo, hits, origin_x, origin_y, resolution, prev, which, motion, alphas, beams, params,
                 noise, out_pose, out_logw):
    """Draw particles ``which`` (those :func:`improved_proposal` left) from the motion model alone:
    around ``motion`` ``(rot1, trans, rot2)`` with the noise of ``alphas`` (the odometry as
    calibrated, :mod:`slam_core.odometry_calibration`), weighted by their observation likelihood."""
    for k in range(which.shape[0]):
        p = which[k]
        s1, st, s2 = noise_stds(motion[0], motion[1], motion[2], alphas[0], alphas[1], alphas[2], alphas[3])
        x, y, th = apply_motion(prev[p, 0], prev[p, 1], prev[p, 2], motion[0] + s1 * noise[p, 0],
                                motion[1] + st * noise[p, 1], motion[2] + s2 * noise[p, 2])
        ll, _ = pose_likelihood(tables[p], lo, hits, origin_x, origin_y, resolution, x, y, th, beams, params)
        out_pose[p, 0] = x
        out_pose[p, 1] = y
        out_pose[p, 2] = th
        out_logw[p] = ll


def match_starts(table, lo, hits, origin_x, origin_y, resolution, starts, beams, params, iterations,
                 wide_iterations, out_pose, out_ll, out_matched):
    """Fine matches on one map from each of ``starts``, split over threads: fills ``out_pose``,
    ``out_ll`` (log-likelihood of the result) and ``out_matched`` (beams matched in the last pass)."""
    split(_match_range, starts.shape[0], table, lo, hits, origin_x, origin_y, resolution, starts, beams,
          params, iterations, wide_iterations, out_pose, out_ll, out_matched)


@njit
def _match_range(first, stop, table, lo, hits, origin_x, origin_y, resolution, starts, beams, params,
                 iterations, wide_iterations, out_pose, out_ll, out_matched):
    """:func:`match_starts` for starts ``first`` to ``stop - 1``."""
    for i in range(first, stop):
        x, y, th, _, n, ll, _ = match(table, lo, hits, origin_x, origin_y, resolution, starts[i, 0],
                                      starts[i, 1], starts[i, 2], beams, params, iterations, wide_iterations)
        out_pose[i, 0] = x
        out_pose[i, 1] = y
        out_pose[i, 2] = th
        out_ll[i] = ll
        out_matched[i] = n
