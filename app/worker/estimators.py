"""The one place estimators are built: ``make_estimator(mode, settings, checkpoint)``.

Every estimator follows :class:`slam_core.estimator.Estimator`. The worker feeds them
odometry re-anchored so that the first reading after a (re)start equals the
checkpoint pose; the map frame is therefore continuous across worker restarts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam_core.estimator import Estimate
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.scan import Scan


class ModeUnavailable(RuntimeError):
    """The estimator for that mode cannot be built (missing map, not installed)."""


@dataclass
class Checkpoint:
    """What a restarted worker resumes from: the last map, pose and mode."""

    mode: str
    pose: np.ndarray
    grid: OccupancyGrid | None = None
    mapping: bool = True
    map_name: str | None = None


class OdometryMapper:
    """TEMPORARY mapping estimator (until ``slam_core.rbpf`` lands): scans at the odometry pose.

    No correction at all: the map drifts with the odometry. Replaced by the RBPF in
    :func:`make_estimator`.
    """

    def __init__(self, resolution: float, grid: OccupancyGrid | None = None):
        self.grid = grid if grid is not None else OccupancyGrid(resolution)
        self.pose = np.zeros(3)

    def step(self, odometry: np.ndarray, scan: Scan) -> bool:
        self.pose = np.asarray(odometry, float)
        self.grid.integrate(scan, self.pose)
        return True

    def estimate(self) -> Estimate:
        return Estimate(pose=self.pose.copy(), particles=self.pose[None, :].copy(), weights=np.ones(1))

    def occupancy_map(self) -> OccupancyGrid:
        return self.grid


class FrozenMap:
    """Mapping stopped: the map stays as it is and the pose follows the (re-anchored) odometry."""

    def __init__(self, grid: OccupancyGrid | None, pose: np.ndarray):
        self.grid = grid
        self.pose = np.asarray(pose, float)

    def step(self, odometry: np.ndarray, scan: Scan) -> bool:
        self.pose = np.asarray(odometry, float)
        return True

    def estimate(self) -> Estimate:
        return Estimate(pose=self.pose.copy(), localized=False)

    def occupancy_map(self) -> OccupancyGrid | None:
        return self.grid


def make_estimator(mode: str, settings, checkpoint: Checkpoint | None):
    """The estimator for ``mode``, resuming from ``checkpoint`` (map and pose) when given."""
    grid = checkpoint.grid if checkpoint is not None else None
    pose = checkpoint.pose if checkpoint is not None else np.zeros(3)
    if checkpoint is not None and not checkpoint.mapping:
        return FrozenMap(grid, pose)
    if mode == "mapping":
        return OdometryMapper(settings.resolution, grid)
    raise ModeUnavailable(f"mode {mode!r} is not available yet in this build")


def available_modes() -> tuple[str, ...]:
    """Modes this build can run (the server refuses the others with a reason)."""
    return ("mapping",)
