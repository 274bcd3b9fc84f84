"""Data association: chi-square gating on the Mahalanobis distance, then nearest neighbour.

For observation ``i`` and landmark ``j`` the innovation ``ν = z_i - h(x, l_j)``
has covariance ``S_ij = H_j P H_jᵀ + R_i``; the pair is admissible when
``νᵀ S⁻¹ ν`` is below the chi-square quantile with 2 degrees of freedom
(Bar-Shalom & Fortmann 1988). Admissible pairs are taken greedily, closest
first, each landmark and each observation at most once (nearest neighbour).
An observation that is not matched but lies inside a wider "ambiguity" gate of
some landmark is dropped: neither evidence for that landmark nor a new one,
which keeps a landmark from being duplicated when the pose is uncertain.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam_core.ekf.models import observe_lines_many, observe_many
from slam_core.ekf.state import POSE, EkfState
from slam_core.geometry import wrap_angle

#: chi-square quantiles with 2 degrees of freedom: 0.99 and 0.9999.
CHI2_2_99 = 9.2103
CHI2_2_9999 = 18.4207


@dataclass(frozen=True)
class Association:
    """``matches`` pairs ``(observation, landmark)``; ``new`` observations far from every landmark."""

    matches: np.ndarray  # (m, 2) int
    new: np.ndarray  # (q,) int observation indices
    distances: np.ndarray  # (n_obs, k) squared Mahalanobis distances


def predicted_innovation_covariances(state: EkfState) -> tuple[np.ndarray, np.ndarray]:
    """Expected observations ``(k, 2)`` and ``H P Hᵀ`` ``(k, 2, 2)`` of every landmark (without R)."""
    k = state.n_landmarks
    if k == 0:
        return np.zeros((0, 2)), np.zeros((0, 2, 2))
    pose = state.mean[:POSE]
    landmarks = state.mean[POSE:].reshape(-1, 2)
    z, h_pose, h_lm = observe_many(pose, landmarks)
    lines = state.lines
    if lines.any():
        z[lines], h_pose[lines], h_lm[lines] = observe_lines_many(pose, landmarks[lines],
                                                                       state.anchors[lines])
    p = state.cov
    idx = POSE + 2 * np.arange(k)
    p_rr = p[:POSE, :POSE]
    p_rl = np.stack([p[:POSE, idx], p[:POSE, idx + 1]], axis=-1)  # (3, k, 2)
    p_rl = np.transpose(p_rl, (1, 0, 2))  # (k, 3, 2)
    p_ll = np.empty((k, 2, 2))
    p_ll[:, 0, 0] = p[idx, idx]
    p_ll[:, 0, 1] = p[idx, idx + 1]
    p_ll[:, 1, 0] = p[idx + 1, idx]
    p_ll[:, 1, 1] = p[idx + 1, idx + 1]
    cross = h_pose @ p_rl @ np.transpose(h_lm, (0, 2, 1))
    s = h_pose @ p_rr @ np.transpose(h_pose, (0, 2, 1)) + cross + np.transpose(cross, (0, 2, 1))
    s += h_lm @ p_ll @ np.transpose(h_lm, (0, 2, 1))
    return z, s


def mahalanobis_table(z_obs: np.ndarray, r_obs: np.ndarray, z_pred: np.ndarray,
                      s_pred: np.ndarray) -> np.ndarray:
    """Squared Mahalanobis distances ``(n_obs, k)`` of every observation to every landmark."""
    nu = z_obs[:, None, :] - z_pred[None, :, :]
    nu[..., 1] = wrap_angle(nu[..., 1])
    s = s_pred[None, :, :, :] + r_obs[:, None, :, :]
    a, b, c, d = s[..., 0, 0], s[..., 0, 1], s[..., 1, 0], s[..., 1, 1]
    det = a * d - b * c
    x, y = nu[..., 0], nu[..., 1]
    return (d * x * x - (b + c) * x * y + a * y * y) / det


def associate(state: EkfState, z_obs: np.ndarray, r_obs: np.ndarray, gate: float = CHI2_2_99,
              new_gate: float = CHI2_2_9999, compatible: np.ndarray | None = None,
              reject_ambiguous: bool = True) -> Association:
    """Gate, then match nearest neighbours greedily; see the module docstring.

    ``compatible`` (``(n_obs, k)`` bool, optional) rules out pairs whose appearance differs
    (a spike is not a corner; corners facing different ways are different corners).
    With ``reject_ambiguous`` an observation with two or more landmarks inside its gate is
    not used at all (a wrong match costs far more than a missed one).
    """
    n_obs = len(z_obs)
    z_pred, s_pred = predicted_innovation_covariances(state)
    if n_obs == 0 or len(z_pred) == 0:
        d2 = np.zeros((n_obs, len(z_pred)))
        return Association(np.zeros((0, 2), dtype=int), np.arange(n_obs), d2)
    d2 = mahalanobis_table(z_obs, r_obs, z_pred, s_pred)
    if compatible is not None:
        d2 = np.where(compatible, d2, np.inf)
    usable = np.where(((d2 <= gate).sum(axis=1) > 1)[:, None], np.inf, d2) if reject_ambiguous else d2
    order = np.argsort(usable, axis=None)
    used_obs = np.zeros(n_obs, dtype=bool)
    used_lm = np.zeros(len(z_pred), dtype=bool)
    matches = []
    for flat in order:
        i, j = divmod(int(flat), len(z_pred))
        if usable[i, j] > gate:
            break
        if used_obs[i] or used_lm[j]:
            continue
        used_obs[i] = used_lm[j] = True
        matches.append((i, j))
    new = np.flatnonzero(~used_obs & (d2.min(axis=1) > new_gate))
    return Association(np.array(matches, dtype=int).reshape(-1, 2), new, d2)
