"""Record a scripted tour as a CARMEN log plus its ground truth (``homebot sim record``).

Writes into the output folder:

- ``sim.clf`` — per sensing instant an ``ODOM`` line and a ``ROBOTLASER1`` line
  whose robot pose is the **odometry** pose and whose laser pose is the robot's laser
  mount on it (what a real robot logs), readable by :class:`slam_core.io.carmen.CarmenReader`. Depth-camera
  scans are resampled to evenly spaced bearings first (ROBOTLASER1 needs them).
- ``groundtruth.txt`` — the true pose of every scan, ``ipc_timestamp x y theta``
  with the same timestamp text as the log (:class:`slam_core.io.trajectory.Trajectory`).
- ``groundtruth.relations`` — relations (Kümmerle et al. 2009) between true poses 1 s
  apart and between revisits of the same place (loop relations), for
  ``homebot eval TRAJECTORY groundtruth.relations``.
- ``groundtruth_map.pgm`` / ``.yaml`` (ROS map_server) and ``groundtruth_map.png``
  (with the true path), rasterised from the geometry at least as tall as the sensor's
  mounting height (what the scan plane sees).
- ``world.txt`` — a copy of the world file, so the recording is self-contained.
- ``robot.yaml`` — the simulated robot's description (``homebot serve --robot`` reads it).
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from slam_core.geometry import relative, wrap_angle
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
RELATIONS_NAME = "groundtruth.relations"
#: Scans between the two poses of a ground-truth relation (1 s at 20 Hz).
RELATION_SPACING = 20
#: Loop relations: poses sampled every LOOP_SAMPLE scans, at least LOOP_MIN_GAP scans apart,
#: no further apart than LOOP_RADIUS metres.
LOOP_SAMPLE = 100
LOOP_MIN_GAP = 600
LOOP_RADIUS = 3.0
MAP_STEM = "groundtruth_map"


@dataclass(frozen=True)
class Recording:
    log: Path
    ground_truth: Path
    relations: Path
    map_yaml: Path
    map_pgm: Path
    map_png: Path
    robot: Path
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
        log.write("# robot poses are wheel odometry, laser poses the robot's laser mount on them; "
                  "ground truth in groundtruth.txt\n")
        log.write(f"PARAM robot_wheel_base {config.robot.wheels.wheel_base} sim 0\n")
        for frame in sim.tour(duration=duration):
            scan = frame.scan if config.sensor == "lidar" else resample_uniform(frame.scan)
            stamp = f"{frame.time:.6f}"
            tv, rv = frame.velocity
            log.write(odom_line(frame.odometry_pose, tv, rv, frame.time))
            laser_pose = config.robot.laser.mount.laser_poses(frame.odometry_pose)
            log.write(robotlaser_line(scan, laser_pose, frame.odometry_pose, frame.time, tv, rv))
            stamps.append(stamp)
            truth.append(frame.true_pose)
            if progress is not None:
                done = sim.controller.target / max(n_way, 1)
                if duration:
                    done = max(done, frame.time / duration)
                progress(min(done, 1.0))
    traj = Trajectory(stamps, np.array(truth).reshape(-1, 3))
    gt_path = traj.save(out / GROUND_TRUTH_NAME)
    rel_path = write_relations(traj, out / RELATIONS_NAME)
    seen_from = config.robot.laser.height if config.sensor == "lidar" else config.depth.mount_height
    grid = ground_truth_map(world, resolution, seen_from)
    pgm, yml = save_map(grid, out / MAP_STEM)
    png = save_png(grid, out / f"{MAP_STEM}.png", traj.poses,
                   caption=f"{world.name}: ground truth ({len(stamps)} scans)")
    if world.source and Path(world.source).is_file():
        shutil.copyfile(world.source, out / "world.txt")
    robot = out / "robot.yaml"
    robot.write_text(config.robot.to_yaml())
    err = frame.odometry_pose - frame.true_pose
    err[2] = float(wrap_angle(err[2]))
    return Recording(out / LOG_NAME, gt_path, rel_path, yml, pgm, png, robot, len(stamps), frame.time,
                     bool(sim.controller.done), err)


def write_relations(truth: Trajectory, path, spacing: int = RELATION_SPACING) -> Path:
    """Relations ``t1 t2 x y z roll pitch yaw`` between true poses, as Kümmerle et al. pick them.

    Local relations join poses ``spacing`` scans apart; loop relations join poses
    sampled every ``LOOP_SAMPLE`` scans that are at least ``LOOP_MIN_GAP`` scans apart
    in time but within ``LOOP_RADIUS`` metres (the same place revisited), so that
    drift and failed loop closures show in the score.
    """
    poses = truth.poses
    i = np.arange(0, len(poses) - spacing, spacing)
    pairs = list(zip(i.tolist(), (i + spacing).tolist(), strict=True))
    samples = np.arange(0, len(poses), LOOP_SAMPLE)
    for k, a in enumerate(samples):
        for b in samples[k + 1:]:
            if b - a >= LOOP_MIN_GAP and np.hypot(*(poses[b, :2] - poses[a, :2])) <= LOOP_RADIUS:
                pairs.append((int(a), int(b)))
    with open(path, "w") as f:
        for a, b in pairs:
            dx, dy, dth = relative(poses[a], poses[b])
            f.write(f"{truth.stamps[a]} {truth.stamps[b]} {dx:.6f} {dy:.6f} 0.000000 "
                    f"0.000000 0.000000 {dth:.6f}\n")
    return Path(path)
