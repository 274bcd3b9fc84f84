"""Slow, obvious references for the landmark EKF: dense-matrix Kalman formulas."""

import numpy as np

from slam_core.ekf.models import inverse_observation, observe
from slam_core.geometry import wrap_angle


def dense_update(mean, cov, indices, z, r):
    """Textbook EKF update with the full stacked Jacobian H (2m x n)."""
    n = len(mean)
    m = len(indices)
    h = np.zeros((2 * m, n))
    nu = np.zeros(2 * m)
    rr = np.zeros((2 * m, 2 * m))
    for i, j in enumerate(indices):
        a = 3 + 2 * j
        zhat, hp, hl = observe(mean[:3], mean[a:a + 2])
        h[2 * i:2 * i + 2, :3] = hp
        h[2 * i:2 * i + 2, a:a + 2] = hl
        nu[2 * i:2 * i + 2] = [z[i][0] - zhat[0], wrap_angle(z[i][1] - zhat[1])]
        rr[2 * i:2 * i + 2, 2 * i:2 * i + 2] = r[i]
    s = h @ cov @ h.T + rr
    k = cov @ h.T @ np.linalg.inv(s)
    new_mean = mean + k @ nu
    new_mean[2] = wrap_angle(new_mean[2])
    return new_mean, (np.eye(n) - k @ h) @ cov


def dense_add(mean, cov, z, r):
    """Augment with a landmark via the full Jacobian of [x; g(x, z)]."""
    n = len(mean)
    lm, gp, gz = inverse_observation(mean[:3], z)
    j = np.zeros((n + 2, n + 2))
    j[:n, :n] = np.eye(n)
    j[n:, :3] = gp
    j[n:, n:] = gz
    big = np.zeros((n + 2, n + 2))
    big[:n, :n] = cov
    big[n:, n:] = r
    return np.concatenate([mean, lm]), j @ big @ j.T


def naive_clusters(scan, lam, sigma):
    """Borges & Aldon breakpoints, the obvious way: list of index arrays."""
    runs, current = [], []
    for i in range(len(scan.ranges)):
        if not scan.valid[i]:
            if current:
                runs.append(np.array(current))
            current = []
            continue
        if current:
            j = current[-1]
            pi = scan.ranges[i] * np.array([np.cos(scan.angles[i]), np.sin(scan.angles[i])])
            pj = scan.ranges[j] * np.array([np.cos(scan.angles[j]), np.sin(scan.angles[j])])
            dphi = abs(scan.angles[i] - scan.angles[j])
            limit = scan.ranges[j] * np.sin(dphi) / max(np.sin(lam - dphi), 1e-3 * np.sin(lam))
            if np.linalg.norm(pi - pj) > limit + 3 * sigma:
                runs.append(np.array(current))
                current = []
        current.append(i)
    if current:
        runs.append(np.array(current))
    return runs
