"""Replay a CARMEN log against a known map with Monte Carlo localization."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from slam_core.io.carmen import TruncatedLogError, laser_records
from slam_core.io.trajectory import Trajectory
from slam_core.localization.mcl import MclConfig, MonteCarloLocalizer
from slam_core.occupancy_grid import OccupancyGrid


@dataclass
class ReplayRun:
    """The per-scan trajectory, when the filter first said "localized", and what it cost."""

    trajectory: Trajectory
    localized: np.ndarray  # (n,) flag per laser record
    particles: np.ndarray  # (n,) particle count per laser record
    updates: int = 0
    first_localized: int | None = None  # index of the first laser record with the flag set
    seconds_to_localized: float | None = None  # log time from the first record
    wall_seconds: float = 0.0
    update_seconds: list[float] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    #: The odometry's systematic error as the tracker's matches measured it (``OdometryCalibration.summary``).
    odometry: dict = field(default_factory=dict)


def replay_log(log_path, grid: OccupancyGrid, config: MclConfig | None = None, initial_pose=None,
               initial_covariance=None, seed: int = 0, progress=None) -> ReplayRun:
    """Localize every laser record of a log in ``grid``; global start unless ``initial_pose``.

    The filter is fed the laser pose the log gives (odometry frame) and estimates the
    laser's pose in the map, the pose ``homebot map`` and ``homebot eval`` use.
    """
    mcl = MonteCarloLocalizer(grid, config, rng=np.random.default_rng(seed), initial_pose=initial_pose,
                              initial_covariance=initial_covariance)
    stamps: list[str] = []
    poses: list[np.ndarray] = []
    flags: list[bool] = []
    counts: list[int] = []
    run = ReplayRun(Trajectory(stamps, np.zeros((0, 3))), np.zeros(0, bool), np.zeros(0, int))
    started = time.perf_counter()
    t0 = None
    try:
        for record in laser_records(log_path, progress=progress):
            tick = time.perf_counter()
            mcl.step(record.pose, record.scan)
            estimate = mcl.estimate()
            if mcl.filter_updated:
                run.updates += 1
                run.update_seconds.append(time.perf_counter() - tick)
            t0 = record.stamp.ipc_time if t0 is None else t0
            if estimate.localized and run.first_localized is None:
                run.first_localized = len(stamps)
                run.seconds_to_localized = record.stamp.ipc_time - t0
            stamps.append(record.stamp.ipc_text)
            poses.append(estimate.pose)
            flags.append(estimate.localized)
            counts.append(len(mcl.particles))
    except TruncatedLogError as exc:
        run.warnings.append(str(exc))
    run.wall_seconds = time.perf_counter() - started
    run.odometry = mcl.tracker.odometry.summary()
    run.trajectory = Trajectory(stamps, np.array(poses).reshape(-1, 3))
    run.localized = np.array(flags, bool)
    run.particles = np.array(counts, int)
    return run
