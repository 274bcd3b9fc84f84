"""Build an occupancy grid from a log using the poses it carries (raw odometry)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from slam_core.io.carmen import LaserRecord, TruncatedLogError, laser_records
from slam_core.io.trajectory import Trajectory
from slam_core.occupancy_grid import OccupancyGrid, SensorModel


@dataclass
class MappingRun:
    grid: OccupancyGrid
    trajectory: Trajectory
    scans: int = 0
    warnings: list[str] = field(default_factory=list)


def map_from_odometry(log_path, resolution: float = 0.05, model: SensorModel | None = None,
                      progress=None) -> MappingRun:
    """Integrate every laser record of a log at the laser pose the log gives for it.

    A truncated last line ends the run with a warning; all records before it count.
    """
    grid = OccupancyGrid(resolution, model=model)
    stamps: list[str] = []
    poses: list[np.ndarray] = []
    run = MappingRun(grid, Trajectory(stamps, np.zeros((0, 3))))
    try:
        for record in laser_records(log_path, progress=progress):
            _integrate(grid, record)
            stamps.append(record.stamp.ipc_text)
            poses.append(record.pose)
    except TruncatedLogError as exc:
        run.warnings.append(str(exc))
    run.scans = len(stamps)
    run.trajectory = Trajectory(stamps, np.array(poses).reshape(-1, 3))
    return run


def _integrate(grid: OccupancyGrid, record: LaserRecord) -> None:
    grid.integrate(record.scan, record.pose)
