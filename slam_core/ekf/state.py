"""The EKF SLAM state: robot pose and 2D landmarks with their full joint covariance.

The mean is ``[x, y, θ, l1x, l1y, l2x, l2y, ...]`` and ``P`` its covariance; a landmark is
a point ``(x, y)`` seen at range-bearing or a line ``(ρ, α)`` seen in normal form
(:attr:`EkfState.lines` marks which)
(Thrun, Burgard & Fox, *Probabilistic Robotics*, ch. 10.2; Durrant-Whyte &
Bailey 2006). Prediction touches only the pose rows (O(k)); an update with m
observations costs O(m k²) — the quadratic growth that limits EKF SLAM.
"""

from __future__ import annotations

import numpy as np

from slam_core.ekf.models import (
    inverse_line_observation,
    inverse_observation,
    motion,
    motion_jacobians,
    observe,
    observe_line,
)
from slam_core.geometry import wrap_angle

POSE = 3


class EkfState:
    """Mean vector and covariance matrix of pose + landmarks."""

    def __init__(self, pose=(0.0, 0.0, 0.0), pose_covariance=None):
        pose = np.asarray(pose, dtype=float)
        if pose.shape != (3,) or not np.all(np.isfinite(pose)):
            raise ValueError(f"pose must be 3 finite numbers (x, y, theta), got {pose!r}")
        cov = np.zeros((3, 3)) if pose_covariance is None else np.asarray(pose_covariance, float)
        if cov.shape != (3, 3):
            raise ValueError(f"pose covariance must be 3 x 3, got {cov.shape}")
        self.mean = pose.copy()
        self.cov = cov.copy()
        self.lines = np.zeros(0, dtype=bool)  # per landmark: a line (ρ, α), else a point (x, y)
        self.anchors = np.zeros((0, 2))  # per line: the point its ρ is measured from (0 for points)

    @property
    def n_landmarks(self) -> int:
        return (len(self.mean) - POSE) // 2

    @property
    def pose(self) -> np.ndarray:
        return self.mean[:POSE].copy()

    @property
    def pose_covariance(self) -> np.ndarray:
        return self.cov[:POSE, :POSE].copy()

    @property
    def landmarks(self) -> np.ndarray:
        """Landmark positions ``(k, 2)``."""
        return self.mean[POSE:].reshape(-1, 2).copy()

    def landmark_covariances(self) -> np.ndarray:
        """Marginal covariances ``(k, 2, 2)`` of the landmarks."""
        k = self.n_landmarks
        idx = POSE + 2 * np.arange(k)
        out = np.empty((k, 2, 2))
        out[:, 0, 0] = self.cov[idx, idx]
        out[:, 0, 1] = self.cov[idx, idx + 1]
        out[:, 1, 0] = self.cov[idx + 1, idx]
        out[:, 1, 1] = self.cov[idx + 1, idx + 1]
        return out

    def predict(self, u, u_covariance) -> None:
        """Move the pose by the robot-frame increment ``u`` with covariance ``u_covariance``."""
        f, g = motion_jacobians(self.mean[:POSE], u)
        self.mean[:POSE] = motion(self.mean[:POSE], u)
        p = self.cov
        p[:POSE, :] = f @ p[:POSE, :]
        p[:, :POSE] = p[:, :POSE] @ f.T
        p[:POSE, :POSE] += g @ np.asarray(u_covariance, float) @ g.T

    def observe(self, index: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Expected observation of landmark ``index`` and its Jacobians (point or line model)."""
        j = POSE + 2 * index
        if self.lines[index]:
            return observe_line(self.mean[:POSE], self.mean[j:j + 2], self.anchors[index])
        return observe(self.mean[:POSE], self.mean[j:j + 2])

    def add_landmark(self, z, r, line: bool = False) -> int:
        """Append the landmark seen as ``z`` (noise ``r``): a point at range-bearing ``z`` or, with
        ``line``, a line at robot-frame ``(ρ, α)`` anchored at the robot's position; returns its index."""
        anchor = self.mean[:2].copy() if line else np.zeros(2)
        if line:
            lm, g_pose, g_z = inverse_line_observation(self.mean[:POSE], z, anchor)
        else:
            lm, g_pose, g_z = inverse_observation(self.mean[:POSE], z)
        n = len(self.mean)
        p = np.zeros((n + 2, n + 2))
        p[:n, :n] = self.cov
        cross = g_pose @ self.cov[:POSE, :n]
        p[n:, :n] = cross
        p[:n, n:] = cross.T
        p[n:, n:] = g_pose @ self.cov[:POSE, :POSE] @ g_pose.T + g_z @ r @ g_z.T
        self.mean = np.concatenate([self.mean, lm])
        self.cov = p
        self.lines = np.append(self.lines, bool(line))
        self.anchors = np.vstack([self.anchors, anchor])
        return self.n_landmarks - 1

    def innovation(self, index: int, z, r) -> tuple[np.ndarray, np.ndarray]:
        """Innovation ``z - h`` (bearing wrapped) and its covariance ``S`` for one landmark."""
        j = POSE + 2 * index
        zhat, h_pose, h_lm = self.observe(index)
        nu = np.asarray(z, float) - zhat
        nu[1] = wrap_angle(nu[1])
        h = np.hstack([h_pose, h_lm])
        cols = np.r_[0:POSE, j:j + 2]
        return nu, h @ self.cov[np.ix_(cols, cols)] @ h.T + r

    def update(self, indices, z, r) -> None:
        """One joint EKF update: observations ``z (m, 2)`` of landmarks ``indices``, noise ``r (m, 2, 2)``."""
        indices = np.asarray(indices, dtype=int)
        m = len(indices)
        if m == 0:
            return
        n = len(self.mean)
        ph = np.empty((n, 2 * m))  # P H^T
        nu = np.empty(2 * m)
        hs = []
        for i, (j, zi) in enumerate(zip(indices, np.asarray(z, float), strict=True)):
            a = POSE + 2 * j
            zhat, h_pose, h_lm = self.observe(j)
            nu[2 * i] = zi[0] - zhat[0]
            nu[2 * i + 1] = wrap_angle(zi[1] - zhat[1])
            ph[:, 2 * i:2 * i + 2] = self.cov[:, :POSE] @ h_pose.T + self.cov[:, a:a + 2] @ h_lm.T
            hs.append((a, h_pose, h_lm))
        s = np.empty((2 * m, 2 * m))
        for i, (a, h_pose, h_lm) in enumerate(hs):
            s[2 * i:2 * i + 2, :] = (h_pose @ ph[:POSE, :] + h_lm @ ph[a:a + 2, :])
        for i in range(m):
            s[2 * i:2 * i + 2, 2 * i:2 * i + 2] += r[i]
        s = 0.5 * (s + s.T)
        gain = np.linalg.solve(s, ph.T).T  # K = P H^T S^-1
        self.mean += gain @ nu
        self.mean[2] = wrap_angle(self.mean[2])
        self.cov -= gain @ ph.T
        self.cov = 0.5 * (self.cov + self.cov.T)
        line_alphas = POSE + 2 * np.flatnonzero(self.lines) + 1
        self.mean[line_alphas] = wrap_angle(self.mean[line_alphas])
