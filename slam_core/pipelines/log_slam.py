"""Run the particle filter SLAM over a log, close its loops, and recover a pose for every scan."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from slam_core.geometry import compose, relative
from slam_core.graph.loop_closure import LoopClosureResult, close_loops, per_scan_poses, scan_poses
from slam_core.io.carmen import TruncatedLogError, laser_mount_of, laser_records
from slam_core.io.trajectory import Trajectory
from slam_core.map_bands import MapBands
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.rbpf import RBPFConfig, RBPFSlam, RBPFStats
from slam_core.rbpf.laser_mount import LaserMount
from slam_core.session import MappingSession, SessionError


@dataclass
class SlamRun:
    """What the filter did, its best particle's trajectory for every scan
    (``particle_trajectory``) and the result: the trajectory and map after loop closing
    (the particle's own when the back end is off). Trajectories are the robot's; the
    laser sat at ``laser_mount``. ``map`` is the back end's by row bands (the map files are
    written from it without the whole map in memory) or the particle's grid; ``grid`` is it whole."""

    stats: RBPFStats
    map_bytes: int
    tiles_in_use: int
    particle_trajectory: Trajectory
    trajectory: Trajectory
    map: OccupancyGrid | MapBands
    wall_time: float
    filter_time: float
    log_duration: float
    loop_closure: LoopClosureResult | None = None
    warnings: list[str] = field(default_factory=list)
    laser_mount: LaserMount = field(default_factory=LaserMount)
    #: Every update so far (a resumed session's first), to be saved and continued later.
    session: MappingSession | None = None

    @property
    def grid(self) -> OccupancyGrid:
        return self.map if isinstance(self.map, OccupancyGrid) else self.map.grid()


def slam_from_log(log_path, config: RBPFConfig | None = None, seed: int = 0,
                  progress=None, laser_mount=None, resume: MappingSession | None = None) -> SlamRun:
    """Feed every laser record of a log to a fresh filter, then close its loops;
    ``progress(fraction)`` is told how much of the log file was read. ``laser_mount`` (the
    laser's pose in the robot frame) defaults to the offset between the laser and odometry
    poses of the log's lines.

    With ``resume`` the log continues that session: the filter starts on its map at its end
    pose (the log must begin where the session ended), and the back end closes loops over the
    session's updates and the log's together; trajectories and map are in the session's frame."""
    config = config or RBPFConfig()
    warnings: list[str] = []
    if laser_mount is None:
        laser_mount = resume.laser_mount.as_tuple() if resume is not None else laser_mount_of(log_path)
        if laser_mount is None:
            warnings.append("the log's laser poses are no fixed offset from its odometry: "
                            "laser mount taken as (0, 0, 0)")
    mount = LaserMount.of(laser_mount)
    if resume is not None and not np.allclose(mount.as_tuple(), resume.laser_mount.as_tuple(), atol=1e-6):
        raise SessionError(f"the session's laser mount {resume.laser_mount.as_tuple()} is not this log's "
                           f"{mount.as_tuple()}")
    anchor = None  # (the log's first odometry, the session's end pose)
    stamps: list[str] = []
    times: list[float] = []
    odometry: list[np.ndarray] = []
    scans = []
    update_of_scan: list[int] = []
    is_update: list[bool] = []
    slam: RBPFSlam | None = None
    started = time.perf_counter()
    try:
        for record in laser_records(log_path, progress):
            odom = record.odom
            if resume is not None:
                anchor = anchor or (odom.copy(), resume.end_pose)
                odom = compose(anchor[1], relative(anchor[0], odom))
            if slam is None:
                slam = RBPFSlam(config, seed=seed, initial_pose=odom, laser_mount=mount)
                if resume is not None:  # the session's map with its endpoints, as the server resumes it
                    grid = resume.grid()
                    slam.maps.seed_from_grid(grid, resume.hit_sums(grid).dense())
            is_update.append(slam.step(odom, record.scan))
            stamps.append(record.stamp.ipc_text)
            times.append(record.stamp.ipc_time)
            odometry.append(odom)
            scans.append(record.scan)
            update_of_scan.append(slam.stats.updates - 1)
    except TruncatedLogError as exc:
        warnings.append(str(exc))
    if slam is None:
        raise ValueError(f"{log_path}: no laser records")
    filter_time = time.perf_counter() - started
    update_of_scan = np.array(update_of_scan)
    is_update = np.array(is_update)
    odometry = np.array(odometry)
    best = best_updates(slam)
    particle = Trajectory(stamps, per_scan_poses(update_of_scan, odometry, best.odometry, best.poses))
    duration = float(np.max(times) - np.min(times))
    filtered = (slam.stats, slam.map_bytes(), slam.maps.tiles_in_use)
    update_scans = [scans[k] for k in np.flatnonzero(is_update)]
    if not config.loop_closure.enabled:
        session = _session_after(resume, config, mount, best.poses, best.odometry, update_scans,
                                 particle.poses[-1])
        return SlamRun(*filtered, particle, particle, slam.occupancy_map(), filter_time, filter_time,
                       duration, None, warnings, mount, session)
    del slam  # the particles' maps: the back end renders its own
    final, bands, closed, updates = close_filter_loops(config, mount, best, update_of_scan, is_update,
                                                       odometry, scans, resume)
    session = _session_after(None, config, mount, updates.poses, updates.odometry,
                             (resume.scans if resume else []) + update_scans, final[-1])
    wall = time.perf_counter() - started
    return SlamRun(*filtered, particle, Trajectory(stamps, final), bands, wall, filter_time, duration,
                   closed, warnings, mount, session)


def _session_after(resumed: MappingSession | None, config: RBPFConfig, mount: LaserMount, poses: np.ndarray,
                   odometry: np.ndarray, scans: list, end_pose: np.ndarray) -> MappingSession:
    """The session to continue from: the resumed one's updates (if any) then these."""
    if resumed is not None:
        poses, odometry = np.vstack([resumed.poses, poses]), np.vstack([resumed.odometry, odometry])
        scans = resumed.scans + scans
    return MappingSession(config, mount, poses, odometry, scans, end_pose)


@dataclass(frozen=True)
class BestUpdates:
    """The best particle's pose at every filter update and the odometry of those updates."""

    poses: np.ndarray
    odometry: np.ndarray


def best_updates(slam: RBPFSlam) -> BestUpdates:
    updates, poses = slam.best_path()
    update_poses = np.empty((slam.stats.updates, 3))
    update_poses[updates] = poses
    return BestUpdates(update_poses, np.array(slam.update_odometry))


def close_filter_loops(config: RBPFConfig, mount: LaserMount, best: BestUpdates, update_of_scan: np.ndarray,
                       is_update: np.ndarray, odometry: np.ndarray, scans: list,
                       prior: MappingSession | None = None,
                       ) -> tuple[np.ndarray, MapBands, LoopClosureResult, BestUpdates]:
    """The back end after the filter: close the best particle's loops, give every scan a robot pose
    (``update_of_scan``: each scan's last update; ``is_update``: the scans the filter updated
    with) and the map of the optimised poses of the updates by row bands (the laser at ``mount``;
    clamped after the sum, :mod:`slam_core.count_map`, as the live back end renders it).
    A ``prior`` session's updates come first in the graph (the filter went on from its end).
    Also returns every update's final pose and odometry (the prior's first)."""
    lc = config.loop_closure
    update_scans = [scans[k] for k in np.flatnonzero(is_update)]
    first = 0
    if prior is not None:
        first = len(prior.scans)
        best = BestUpdates(np.vstack([prior.poses, best.poses]), np.vstack([prior.odometry, best.odometry]))
        update_scans = prior.scans + update_scans
        update_of_scan = update_of_scan + first
    closed, submaps = close_loops(best.poses, update_scans, lc, config.matcher, config.resolution,
                                  config.sensor, mount, odometry=best.odometry)
    final = scan_poses(submaps, closed.poses, update_of_scan, odometry, best.odometry, scans, lc,
                       config.matcher, config.sensor, mount)
    del submaps
    update_poses = np.vstack([closed.poses[:first], final[is_update]])
    bands = MapBands(mount.laser_poses(update_poses), update_scans, config.resolution, config.sensor,
                     lc.submap_updates)
    return final, bands, closed, BestUpdates(update_poses, best.odometry)
