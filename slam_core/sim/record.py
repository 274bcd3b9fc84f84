"""Record a scripted tour as a CARMEN log plus its ground truth (``homebot sim record``).

Writes into the output folder:

- ``sim.clf`` — per sensing instant an ``ODOM`` line and a ``ROBOTLASER1`` line
  whose laser and robot poses are the **odometry** pose (what a real robot
  logs), readable by :class:`slam_core.io.carmen.CarmenReader`. Depth-camera
  scans are resampled to evenly spaced bearings first (ROBOTLASER1 needs them).
- ``groundtruth.txt`` — the true pose of every scan, ``ipc_timestamp x y theta``
  with the same timestamp text as the log (:class:`slam_core.io.trajectory.Trajectory`).
- ``groundtruth_map.pgm`` / ``.yaml`` (ROS map_server) and ``groundtruth_map.png``
  (with the true path), rasterised from the geometry at least as tall as the sensor's
  mounting height (what the scan plane sees).
- ``world.txt`` — a copy of the world file, so the recording is self-contained.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from slam_core.geometry import wrap_angle
from slam_core.io.carmen_writer import odom_line, robotlaser_line
from slam_core.io.render import save_png
from slam_core.io.ros_map import save_map
from slam_core.io.trajectory import Trajectory
from slam_core.sensors.depth_to_scan import resample_uniform
from slam_core.sim.ground_truth import ground_truth_map
from slam_core.sim.simulator import SimConfig, Simulator
from slam_core.sim.world import World

LOG_NAME = "sim.clf"
GROUND_TRUTH_NAME = "groundtruth.txt"
MAP_STEM = "groundtruth_map"


@dataclass(frozen=True)
class Recording:
    log: Path
    ground_truth: Path
    map_yaml: Path
    map_pgm: Path
    map_png: Path
    scans: int
    sim_time: float
    tour_completed: bool
    final_odometry_error: np.ndarray  # odometry pose minus true pose at the end (x, y, theta)


def record_tour(world: World, out_dir, seed: int = 0, sensor: str = "lidar", duration: float | None = None,
                resolution: float = 0.05, config: SimConfig | None = None, progress=None) -> Recording:
    """Drive ``world``'s tour and write the log, ground truth and map into ``out_dir``.

    ``progress`` (optional) is called with the fraction done (waypoints reached,
    or time elapsed when ``duration`` ends the tour first).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    config = config or SimConfig(sensor=sensor)
    sim = Simulator(world, config, seed=seed)
    stamps, truth = [], []
    n_way = len(world.waypoints)
    frame = sim.last
    with open(out / LOG_NAME, "w") as log:
        log.write(f"# homebot simulator: world {world.name}, sensor {config.sensor}, seed {seed}\n")
        log.write("# laser and robot poses are wheel odometry; ground truth in groundtruth.txt\n")
        log.write(f"PARAM robot_wheel_base {config.geometry.wheel_base} sim 0\n")
        for frame in sim.tour(duration=duration):
            scan = frame.scan if config.sensor == "lidar" else resample_uniform(frame.scan)
            stamp = f"{frame.time:.6f}"
            tv, rv = frame.velocity
            log.write(odom_line(frame.odometry_pose, tv, rv, frame.time))
            log.write(robotlaser_line(scan, frame.odometry_pose, frame.odometry_pose, frame.time, tv, rv))
            stamps.append(stamp)
            truth.append(frame.true_pose)
            if progress is not None:
                done = sim.controller.target / max(n_way, 1)
                if duration:
                    done = max(done, frame.time / duration)
                progress(min(done, 1.0))
    traj = Trajectory(stamps, np.array(truth).reshape(-1, 3))
    gt_path = traj.save(out / GROUND_TRUTH_NAME)
    seen_from = config.lidar.mount_height if config.sensor == "lidar" else config.depth.mount_height
    grid = ground_truth_map(world, resolution, seen_from)
    pgm, yml = save_map(grid, out / MAP_STEM)
    png = save_png(grid, out / f"{MAP_STEM}.png", traj.poses,
                   caption=f"{world.name}: ground truth ({len(stamps)} scans)")
    if world.source and Path(world.source).is_file():
        shutil.copyfile(world.source, out / "world.txt")
    err = frame.odometry_pose - frame.true_pose
    err[2] = float(wrap_angle(err[2]))
    return Recording(out / LOG_NAME, gt_path, yml, pgm, png, len(stamps), frame.time,
                     bool(sim.controller.done), err)
