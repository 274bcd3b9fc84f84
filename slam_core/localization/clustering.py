"""The main cluster of a particle set and its weighted mean and covariance.

Particles are binned on a coarse ``(x, y, theta)`` grid; occupied bins that touch
(26-neighbourhood, heading wrapping round) form clusters (connected components,
as AMCL groups its k-d tree leaves), and the cluster with the most weight is the
published hypothesis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam_core.geometry import circular_mean, wrap_angle
from slam_core.jit import njit


@dataclass(frozen=True)
class Cluster:
    """A cluster's weighted mean pose, covariance (heading about its circular mean), mass and members."""

    pose: np.ndarray
    covariance: np.ndarray
    weight: float
    members: np.ndarray


@njit
def _label(occupied, labels, stack):
    nx, ny, nt = occupied.shape
    count = 0
    for a in range(nx):
        for b in range(ny):
            for c in range(nt):
                if not occupied[a, b, c] or labels[a, b, c] >= 0:
                    continue
                labels[a, b, c] = count
                top = 0
                stack[0, 0] = a
                stack[0, 1] = b
                stack[0, 2] = c
                top = 1
                while top > 0:
                    top -= 1
                    i = stack[top, 0]
                    j = stack[top, 1]
                    k = stack[top, 2]
                    for di in range(-1, 2):
                        ii = i + di
                        if ii < 0 or ii >= nx:
                            continue
                        for dj in range(-1, 2):
                            jj = j + dj
                            if jj < 0 or jj >= ny:
                                continue
                            for dk in range(-1, 2):
                                kk = (k + dk) % nt
                                if occupied[ii, jj, kk] and labels[ii, jj, kk] < 0:
                                    labels[ii, jj, kk] = count
                                    stack[top, 0] = ii
                                    stack[top, 1] = jj
                                    stack[top, 2] = kk
                                    top += 1
                count += 1
    return count


def cluster_labels(poses: np.ndarray, xy_size: float, theta_bins: int) -> np.ndarray:
    """Connected-component label of each pose's coarse bin (labels ``0 .. m-1``)."""
    poses = np.asarray(poses, dtype=np.float64)
    lo = poses[:, :2].min(axis=0)
    cell = np.floor((poses[:, :2] - lo) / xy_size).astype(np.int64)
    tb = np.floor(np.mod(poses[:, 2], 2 * np.pi) / (2 * np.pi / theta_bins)).astype(np.int64)
    tb = np.minimum(tb, theta_bins - 1)
    nx, ny = cell.max(axis=0) + 1
    occupied = np.zeros((nx, ny, theta_bins), np.bool_)
    occupied[cell[:, 0], cell[:, 1], tb] = True
    labels = np.full(occupied.shape, -1, np.int64)
    stack = np.empty((int(occupied.sum()) + 1, 3), np.int64)
    _label(occupied, labels, stack)
    return labels[cell[:, 0], cell[:, 1], tb]


def weighted_pose_stats(poses: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weighted mean (circular for the heading) and covariance of poses."""
    w = np.asarray(weights, dtype=np.float64)
    w = w / w.sum()
    mean = np.array([w @ poses[:, 0], w @ poses[:, 1], circular_mean(poses[:, 2], w)])
    dev = poses - mean
    dev[:, 2] = wrap_angle(dev[:, 2])
    cov = (dev * w[:, None]).T @ dev
    return mean, cov


def main_cluster(poses: np.ndarray, weights: np.ndarray, xy_size: float, theta_bins: int) -> Cluster:
    """The heaviest connected cluster of the weighted particle set."""
    poses = np.asarray(poses, dtype=np.float64)
    weights = np.asarray(weights, dtype=np.float64)
    labels = cluster_labels(poses, xy_size, theta_bins)
    mass = np.bincount(labels, weights=weights)
    best = int(np.argmax(mass))
    members = np.flatnonzero(labels == best)
    mean, cov = weighted_pose_stats(poses[members], weights[members])
    return Cluster(mean, cov, float(mass[best] / weights.sum()), members)
