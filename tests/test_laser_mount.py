"""A laser mounted off the robot's centre: the filter, the back end and ``homebot slam`` map
with the laser's pose and report the robot's, against the synthetic room's ground truth."""

import itertools
import json

import numpy as np
import pytest

from app.cli import main
from slam_core.geometry import compose, relative, wrap_angle
from slam_core.graph.config import LoopClosureConfig
from slam_core.graph.loop_closure import close_loops
from slam_core.io.carmen import flaser_angles, laser_mount_of
from slam_core.io.trajectory import Trajectory
from slam_core.rbpf import RBPFConfig, RBPFSlam
from slam_core.rbpf.laser_mount import LaserMount
from slam_core.scan import Scan
from tests.synthetic_room import cast, room_scan

#: Behind the centre, a little to the left, turned: every part of the mount matters.
MOUNT = (-0.25, 0.06, 0.3)


def tour(n_steps=220, laps=1, seed=5):
    """True robot poses on laps through the room, and odometry that drifts from them."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 2 * np.pi * laps, n_steps)
    x, y = 0.5 + 1.8 * np.cos(t), 0.4 + 1.1 * np.sin(t)
    th = np.arctan2(np.gradient(y), np.gradient(x))
    truth = np.column_stack([x, y, th])
    odom = [truth[0].copy()]
    for a, b in itertools.pairwise(truth):
        step = relative(a, b) * np.array([1.04, 1.04, 1.05]) + rng.normal(0, [0.003, 0.003, 0.003])
        odom.append(compose(odom[-1], step))
    return truth, np.array(odom)


def position_error(truth, poses):
    return np.hypot(*(truth[:, :2] - poses[:, :2]).T)


def run_filter(truth, odom, mount):
    """The filter's estimate at its updates, and the true poses there."""
    rng = np.random.default_rng(1)
    laser = compose(truth, np.array(MOUNT))
    slam = RBPFSlam(RBPFConfig(particles=8), seed=0, initial_pose=truth[0], laser_mount=mount)
    estimates, at = [], []
    for k in range(len(truth)):
        if slam.step(odom[k], room_scan(laser[k], 180, noise=0.01, rng=rng)):
            estimates.append(slam.estimate().pose)
            at.append(k)
    return slam, truth[at], np.array(estimates)


def test_mount_moves_poses_between_the_frames_and_a_centred_one_changes_nothing():
    poses = np.random.default_rng(0).uniform(-3, 3, (20, 3))
    mount = LaserMount(*MOUNT)
    laser = mount.laser_poses(poses)
    np.testing.assert_allclose(np.hypot(*(laser - poses)[:, :2].T), np.hypot(*MOUNT[:2]))
    back = mount.robot_poses(laser)
    np.testing.assert_allclose(back[:, :2], poses[:, :2], atol=1e-12)
    np.testing.assert_allclose(wrap_angle(back[:, 2] - poses[:, 2]), 0.0, atol=1e-12)
    assert LaserMount.of(None) == LaserMount() and LaserMount.of(mount) is mount
    assert np.array_equal(LaserMount.of((0, 0, 0)).robot_poses(poses), poses)
    with pytest.raises(ValueError, match="x, y, theta"):
        LaserMount.of((1.0, 2.0))
    with pytest.raises(ValueError, match="finite"):
        LaserMount.of((0.0, np.nan, 0.0))


def test_the_filter_tracks_the_robot_when_told_where_the_laser_sits():
    truth, odom = tour()
    slam, at_updates, estimates = run_filter(truth, odom, MOUNT)
    err = position_error(at_updates, estimates)
    heading = np.degrees(np.abs(wrap_angle(at_updates[:, 2] - estimates[:, 2])))
    assert len(estimates) > 20
    assert err.mean() < 0.03 and err.max() < 0.08, (err.mean(), err.max())
    assert heading.max() < 2.0, heading.max()
    _, path = slam.best_path()
    assert position_error(at_updates, path).mean() < 0.04  # the robot's poses, not the laser's
    assert position_error(truth, odom).max() > 0.3  # the odometry alone drifts away
    # told nothing, the filter tracks the laser and is off by the mount (and worse)
    _, blind_truth, blind = run_filter(truth, odom, (0.0, 0.0, 0.0))
    assert position_error(blind_truth, blind).mean() > 0.2


def test_the_back_end_closes_loops_with_an_off_centre_laser():
    truth, _ = tour(160, laps=2)
    laser = compose(truth, np.array(MOUNT))
    rng = np.random.default_rng(2)
    scans = [room_scan(p, 360, noise=0.01, rng=rng) for p in laser]
    steps = relative(truth[:-1], truth[1:]) * np.array([1.01, 1.01, 1.0]) + np.array([0, 0, 0.003])
    bent = [truth[0]]
    for s in steps:
        bent.append(compose(bent[-1], s))
    bent = np.array(bent)
    config = LoopClosureConfig(submap_updates=10, min_loop_path=4.0)
    result, _ = close_loops(bent, scans, config, laser_mount=MOUNT)
    assert position_error(truth, bent).max() > 0.4
    after = position_error(truth, result.poses)
    assert result.loop_edges > 5
    assert after.mean() < 0.05 and after.max() < 0.1, (after.mean(), after.max())


def write_flaser_log(path, truth, odom, mount, seed=3):
    """A CARMEN log of 181-beam FLASER lines cast from the laser's true pose; the line's
    laser pose is the odometry moved by the mount, as a robot logs it."""
    rng = np.random.default_rng(seed)
    angles = flaser_angles(181)
    laser_odom = compose(odom, np.array(mount))
    with open(path, "w") as f:
        for k, (pose, od, lo) in enumerate(zip(truth, odom, laser_odom, strict=True)):
            ranges = cast(compose(pose, np.array(mount)), angles) + rng.normal(0, 0.01, len(angles))
            numbers = [*ranges, *lo, *od]
            f.write(f"FLASER 181 {' '.join(f'{v:.6f}' for v in numbers)} {k * 0.2:.3f} sim {k * 0.2:.3f}\n")


def test_homebot_slam_reads_the_mount_from_the_log_and_writes_the_robots_trajectory(tmp_path):
    truth, odom = tour()
    log = tmp_path / "mounted.clf"
    write_flaser_log(log, truth, odom, MOUNT)
    np.testing.assert_allclose(laser_mount_of(log), MOUNT, atol=1e-5)
    out = tmp_path / "out"
    assert main(["slam", str(log), "--out", str(out), "--particles", "8"]) == 0
    stats = json.loads((out / "stats.json").read_text())
    np.testing.assert_allclose(stats["laser_mount"], MOUNT, atol=1e-5)
    assert stats["warnings"] == []
    final = Trajectory.load(out / "trajectory.txt").poses
    assert position_error(truth, final).mean() < 0.03
    # the mount given by hand wins over the log's
    wrong = tmp_path / "wrong"
    centred = ["--laser-mount", "0", "0", "0"]
    assert main(["slam", str(log), "--out", str(wrong), "--particles", "8", *centred]) == 0
    assert position_error(truth, Trajectory.load(wrong / "trajectory.txt").poses).mean() > 0.2


def test_laser_poses_that_wander_from_the_odometry_are_no_mount(tmp_path):
    truth, odom = tour(60)
    log = tmp_path / "corrected.clf"
    with open(log, "w") as f:  # the laser pose is the truth (a corrected log), not odometry + mount
        for k, (pose, od) in enumerate(zip(truth, odom, strict=True)):
            ranges = cast(pose, flaser_angles(181))
            numbers = [*ranges, *pose, *od]
            f.write(f"FLASER 181 {' '.join(f'{v:.6f}' for v in numbers)} {k * 0.2:.3f} sim {k * 0.2:.3f}\n")
    assert laser_mount_of(log) is None
    out = tmp_path / "out"
    assert main(["slam", str(log), "--out", str(out), "--particles", "4", "--no-loop-closure"]) == 0
    stats = json.loads((out / "stats.json").read_text())
    assert stats["laser_mount"] == [0.0, 0.0, 0.0]
    assert any("laser mount" in w for w in stats["warnings"])


def test_a_blind_scan_with_a_mount_falls_back_to_the_motion_model():
    slam = RBPFSlam(RBPFConfig(particles=3), seed=0, laser_mount=MOUNT)
    slam.step(np.zeros(3), room_scan(compose(np.zeros(3), np.array(MOUNT))))
    blind = Scan(np.linspace(-1, 1, 30), np.full(30, 80.0), 0.1, 80.0)
    assert slam.step(np.array([0.6, 0.0, 0.0]), blind)
    assert slam.stats.fallbacks == 3
    assert abs(slam.estimate().pose[0] - 0.6) < 0.2  # the robot's pose follows the robot's odometry
