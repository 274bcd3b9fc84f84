"""The robot link: one owner of the serial port; its odometry reaches the ring, its commands the wheels."""

import time
from dataclasses import replace

import numpy as np
import pytest

from app.robot.odometry_ring import OdometryRing
from app.robot_link.link import RobotLink
from app.robot_link.virtual_mcu import VirtualMCU
from slam_core.geometry import compose, wrap_angle
from slam_core.robot_config import load_robot
from slam_core.sim.robot import SimRobot, WheelNoise
from slam_core.sim.world import load_world

DT = 0.01


def test_velocity_drives_the_robot_and_its_odometry_fills_the_ring():
    robot = SimRobot(load_world("flat"), rng=np.random.default_rng(0))
    mcu = VirtualMCU(robot, rate_hz=50.0, clock=lambda: robot.time).start()
    ring = OdometryRing.create()
    link = RobotLink(mcu.path, ring).start()
    try:
        assert link.grabber.wait_connected(5.0)
        deadline = time.monotonic() + 2.0
        while time.monotonic() < deadline:  # drive by the link's commands only
            link.send_velocity(0.3, -0.4)
            for _ in range(5):
                robot.step(DT)
                time.sleep(DT)
        link.send_velocity(0.0, 0.0)
        for _ in range(100):  # let the robot stop and the last frames arrive
            robot.step(DT)
            time.sleep(DT)
    finally:
        link.stop()
        mcu.stop()
    newest = ring.newest()
    count, readings = ring.read_since(0)
    assert mcu.stats.commands_applied > 10 and link.stats().commands_sent > 10
    assert np.hypot(*(robot.true_pose[:2] - robot.world.start[:2])) > 0.2
    assert newest.ticks == robot.ticks() and count == link.stats().odometry_published
    stamps = [r.stamp for r in readings]
    assert stamps == sorted(stamps) and stamps[-1] <= time.time()
    # the ring's odometry frame starts at (0, 0, 0), the robot's at the world's start pose
    pose = compose(robot.world.start, newest.pose)
    assert np.allclose(pose[:2], robot.odometry_pose[:2], atol=0.005)
    assert abs(wrap_angle(pose[2] - robot.odometry_pose[2])) < 0.005


def test_a_non_finite_command_is_refused_at_once():
    link = RobotLink("/nonexistent/tty", OdometryRing.create())
    with pytest.raises(ValueError):
        link.send_velocity(float("nan"), 0.0)


def _drive(robot: SimRobot, link: RobotLink, v: float, seconds: float) -> None:
    """Command ``v`` (m/s) straight ahead for ``seconds`` of simulated time, stepped in real time."""
    for _ in range(int(seconds / (5 * DT))):
        link.send_velocity(v, 0.0)
        for _ in range(5):
            robot.step(DT)
            time.sleep(DT)
    link.send_velocity(0.0, 0.0)
    for _ in range(50):
        robot.step(DT)
        time.sleep(DT)


@pytest.mark.parametrize("told_the_limits", [True, False])
def test_the_plausible_wheel_speed_comes_from_the_robot_files_limits(told_the_limits):
    """A robot whose limits allow 2 m/s, driven at 1.8 m/s: told its limits, the link keeps every
    reading and its odometry follows the truth; told the shipped robot's limits (at most 1.35 m/s
    per wheel), it drops the same readings as corrupt."""
    shipped = load_robot()
    fast = replace(shipped, limits=replace(shipped.limits, v_max=2.0, a_max=50.0))
    robot = SimRobot(load_world("flat"), robot=fast, noise=WheelNoise.none())
    mcu = VirtualMCU(robot, rate_hz=50.0, clock=lambda: robot.time).start()
    link = RobotLink(mcu.path, OdometryRing.create(), robot=fast if told_the_limits else shipped).start()
    try:
        assert link.grabber.wait_connected(5.0)
        _drive(robot, link, 1.8, 0.5)
    finally:
        link.stop()
        mcu.stop()
    moved = np.hypot(*(robot.true_pose[:2] - robot.world.start[:2]))
    odometry = np.hypot(*link.ring.newest().pose[:2])
    assert moved > 0.6
    if told_the_limits:
        assert link.stats().odometry_jumps_rejected == 0
        assert odometry == pytest.approx(moved, abs=0.01)
    else:
        assert link.stats().odometry_jumps_rejected > 0
        assert odometry < moved - 0.1
