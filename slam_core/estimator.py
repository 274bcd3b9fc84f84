"""What every estimator (RBPF SLAM, MCL, landmark EKF) offers the server and the CLI.

An estimator is fed odometry poses (the robot's raw odometry, in the odometry
frame) with the scan taken at that pose, and publishes an :class:`Estimate` and,
where it has one, an occupancy grid.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from slam_core.occupancy_grid import OccupancyGrid
from slam_core.scan import Scan


@dataclass(frozen=True)
class Estimate:
    """The published belief: pose ``(x, y, theta)`` in the map frame and what backs it."""

    pose: np.ndarray
    covariance: np.ndarray | None = None  # (3, 3)
    particles: np.ndarray | None = None  # (n, 3)
    weights: np.ndarray | None = None  # (n,), summing to 1
    localized: bool = True
    landmarks: np.ndarray | None = None  # (k, 2) landmark positions (EKF)
    landmark_covariances: np.ndarray | None = None  # (k, 2, 2)


class Estimator(Protocol):
    def step(self, odometry: np.ndarray, scan: Scan) -> bool:
        """Take one odometry pose and its scan; True when the belief was updated."""

    def estimate(self) -> Estimate:
        """The current belief."""

    def occupancy_map(self) -> OccupancyGrid | None:
        """The map the estimator holds (built or given), if any."""
