"""Scan-to-scan odometry refinement: point-to-line ICP (Censi 2008, simplified).

Wheel odometry drifts in heading; the scans of two successive updates usually
pin the increment down much better. :func:`match_increment` starts from the
odometry increment and minimises ``Σ (nᵢ · (R pᵢ + t - qᵢ))²`` over the rigid
motion, where ``qᵢ`` is the previous scan's point nearest the moved point
``pᵢ`` and ``nᵢ`` the normal of the previous scan's surface there (Gauss-Newton,
small-angle linearisation, a trimmed and shrinking correspondence gate). It
reports failure (and the caller keeps the odometry) when too few points pair up
or the fit does not settle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from slam_core.geometry import transform_points, wrap_angle


@dataclass(frozen=True)
class IcpConfig:
    max_range: float = 10.0  # ignore points further away
    stride: int = 2  # use every stride-th beam of the new scan
    iterations: int = 20
    gate_start: float = 0.6  # correspondence gate (m) of the first iteration ...
    gate_end: float = 0.15  # ... shrinking to this
    trim: float = 0.8  # keep this fraction of the best pairs
    min_pairs: int = 40
    normal_max_gap: float = 0.25  # a normal needs its scan neighbours this close to each other (m)
    normal_span: int = 1  # a normal from the neighbours this many beams away on either side
    max_step_change: float = 0.5  # refuse results further than this (m) from the odometry
    max_turn_change: float = np.radians(15.0)
    residual_floor: float = 0.01  # the residual std (m) used is at least this
    # Hessian covariance times this: a sensor calibration. 100 from mit-csail relations (real scans:
    # correlated residuals, wrong correspondences); the simulated lidar needs 1 (tests/test_ekf_house.py)
    covariance_scale: float = 100.0


@dataclass(frozen=True)
class IcpResult:
    """The refined increment, its covariance ``(3, 3)`` (x, y, θ) and whether the match converged."""

    increment: np.ndarray
    covariance: np.ndarray
    converged: bool
    pairs: int = 0
    rms: float = np.inf


def surface_normals(points: np.ndarray, max_gap: float, span: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals ``(n, 2)`` from the chord between each point's ``span``-th scan-order neighbours
    on either side, and a mask of usable ones (every step along the chord within ``max_gap``).
    A wider span averages out range noise, which otherwise tilts the normals of a wall seen at a
    grazing angle and invents information along a corridor."""
    n = len(points)
    normals = np.zeros((n, 2))
    ok = np.zeros(n, dtype=bool)
    if n < 2 * span + 1:
        return normals, ok
    chord = points[2 * span:] - points[:-2 * span]
    step = np.hypot(*np.diff(points, axis=0).T) < max_gap
    # all 2·span steps between the chord's ends are short
    window = np.convolve(step.astype(int), np.ones(2 * span, dtype=int), mode="valid") == 2 * span
    length = np.maximum(np.hypot(chord[:, 0], chord[:, 1]), 1e-12)
    normals[span:-span, 0] = -chord[:, 1] / length
    normals[span:-span, 1] = chord[:, 0] / length
    ok[span:-span] = window
    return normals, ok


def _points(ranges, angles, valid, max_range):
    keep = valid & (ranges < max_range)
    r, a = ranges[keep], angles[keep]
    return np.column_stack([r * np.cos(a), r * np.sin(a)])


def match_increment(prev_scan, scan, guess, config: IcpConfig | None = None) -> tuple[np.ndarray, bool]:
    """The sensor motion from ``prev_scan`` to ``scan`` (both in their sensor frames), refined from
    ``guess``; returns ``(increment, converged)``."""
    result = match_scans(prev_scan, scan, guess, config)
    return result.increment, result.converged


def match_scans(prev_scan, scan, guess, config: IcpConfig | None = None) -> IcpResult:
    """:func:`match_increment` with the Hessian covariance of the result (see the module docstring)."""
    cfg = config or IcpConfig()
    guess = np.asarray(guess, dtype=float)
    failed = IcpResult(guess, np.full((3, 3), np.nan), False)
    ref = _points(prev_scan.ranges, prev_scan.angles, prev_scan.valid, cfg.max_range)
    new = _points(scan.ranges, scan.angles, scan.valid, cfg.max_range)[::cfg.stride]
    if len(ref) < cfg.min_pairs or len(new) < cfg.min_pairs:
        return failed
    normals, flat = surface_normals(ref, cfg.normal_max_gap, cfg.normal_span)
    ref, normals = ref[flat], normals[flat]
    if len(ref) < cfg.min_pairs:
        return failed
    tree = cKDTree(ref)
    pose = guess.copy()
    for it in range(cfg.iterations):
        gate = cfg.gate_start + (cfg.gate_end - cfg.gate_start) * it / max(cfg.iterations - 1, 1)
        moved = transform_points(pose, new)
        dist, nearest = tree.query(moved, distance_upper_bound=gate)
        pair = dist < gate
        if pair.sum() < cfg.min_pairs:
            return failed
        idx = np.flatnonzero(pair)
        idx = idx[np.argsort(dist[idx])[:max(cfg.min_pairs, int(cfg.trim * len(idx)))]]
        p, q, nrm = moved[idx], ref[nearest[idx]], normals[nearest[idx]]
        # residual n·(p - q); d/d(tx, ty, dθ) about the current moved points
        rel = p - pose[:2]
        jac = np.column_stack([nrm[:, 0], nrm[:, 1], nrm[:, 0] * -rel[:, 1] + nrm[:, 1] * rel[:, 0]])
        res = np.einsum("ij,ij->i", nrm, p - q)
        step, *_ = np.linalg.lstsq(jac, -res, rcond=None)
        # R(θ+δ)p = R(δ)R(θ)p: the same small rotation of rel, so the step adds component-wise
        pose = np.array([pose[0] + step[0], pose[1] + step[1], float(wrap_angle(pose[2] + step[2]))])
        if np.hypot(step[0], step[1]) < 1e-4 and abs(step[2]) < 1e-5:
            break
    if (np.hypot(*(pose[:2] - guess[:2])) > cfg.max_step_change
            or abs(wrap_angle(pose[2] - guess[2])) > cfg.max_turn_change):
        return failed
    # the residuals after the last step: res + jac·step to first order
    after = res + jac @ step
    dof = max(len(after) - 3, 1)
    sigma2 = max(float(after @ after) / dof, cfg.residual_floor ** 2)
    info = jac.T @ jac / (sigma2 * cfg.covariance_scale)
    cov = np.linalg.pinv(info + 1e-9 * np.eye(3))
    return IcpResult(pose, 0.5 * (cov + cov.T), True, len(idx), float(np.sqrt(sigma2)))


def fuse_increments(u_odom, q_odom, u_scan, q_scan, gate: float) -> tuple[np.ndarray, np.ndarray, bool]:
    """Information-weighted fusion of two estimates of one robot-frame increment.

    Returns ``(u, Q, agreed)``. When the scan's estimate lies further than the chi-square
    ``gate`` (3 dof, Mahalanobis under ``Q_odom + Q_scan``) from the odometry's, the two
    disagree (a wrong match, or a wheel slipping) and the odometry is kept as it is.
    """
    u_odom, u_scan = np.asarray(u_odom, float), np.asarray(u_scan, float)
    diff = u_scan - u_odom
    diff[2] = wrap_angle(diff[2])
    if not np.isfinite(q_scan).all() or diff @ np.linalg.solve(q_odom + q_scan, diff) > gate:
        return u_odom, q_odom, False
    # u = u_odom + K (u_scan - u_odom), K = Q_odom (Q_odom + Q_scan)^-1: the Kalman form of
    # (Q_odom^-1 + Q_scan^-1)^-1 (Q_odom^-1 u_odom + Q_scan^-1 u_scan), stable when one Q is singular
    gain = np.linalg.solve((q_odom + q_scan).T, q_odom.T).T
    u = u_odom + gain @ diff
    u[2] = wrap_angle(u[2])
    q = q_odom - gain @ q_odom
    return u, 0.5 * (q + q.T), True
