"""Run the particle filter SLAM over a log and recover a pose for every scan."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from slam_core.geometry import compose, relative
from slam_core.io.carmen import TruncatedLogError, laser_records
from slam_core.io.trajectory import Trajectory
from slam_core.rbpf import RBPFConfig, RBPFSlam


@dataclass
class SlamRun:
    slam: RBPFSlam
    trajectory: Trajectory
    wall_time: float
    log_duration: float
    warnings: list[str] = field(default_factory=list)


def per_scan_poses(update_of_scan: np.ndarray, scan_odometry: np.ndarray,
                   update_odometry: np.ndarray, update_poses: np.ndarray) -> np.ndarray:
    """A pose for every scan: the pose of its last filter update moved by the odometry since."""
    base_pose = update_poses[update_of_scan]
    base_odom = update_odometry[update_of_scan]
    return compose(base_pose, relative(base_odom, scan_odometry))


def slam_from_log(log_path, config: RBPFConfig | None = None, seed: int = 0,
                  on_scan=None) -> SlamRun:
    """Feed every laser record of a log to a fresh filter; ``on_scan()`` is called per record."""
    stamps: list[str] = []
    times: list[float] = []
    odometry: list[np.ndarray] = []
    update_of_scan: list[int] = []
    slam: RBPFSlam | None = None
    warnings: list[str] = []
    started = time.perf_counter()
    try:
        for record in laser_records(log_path):
            if slam is None:
                slam = RBPFSlam(config, seed=seed, initial_pose=record.odom)
            slam.step(record.odom, record.scan)
            stamps.append(record.stamp.ipc_text)
            times.append(record.stamp.ipc_time)
            odometry.append(record.odom)
            update_of_scan.append(slam.stats.updates - 1)
            if on_scan is not None:
                on_scan()
    except TruncatedLogError as exc:
        warnings.append(str(exc))
    if slam is None:
        raise ValueError(f"{log_path}: no laser records")
    wall = time.perf_counter() - started
    updates, poses = slam.best_path()
    update_poses = np.empty((slam.stats.updates, 3))
    update_poses[updates] = poses
    per_scan = per_scan_poses(np.array(update_of_scan), np.array(odometry),
                              np.array(slam.update_odometry), update_poses)
    duration = float(np.max(times) - np.min(times))
    return SlamRun(slam, Trajectory(stamps, per_scan), wall, duration, warnings)
