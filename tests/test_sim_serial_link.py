"""The simulated robot behind the virtual microcontroller, read by the odometry grabber over a pty."""

import time

import numpy as np

from app.grabbers.odometry_grabber import OdometryGrabber
from app.robot_link.virtual_mcu import VirtualMCU
from slam_core.geometry import compose, wrap_angle
from slam_core.sim.robot import SimRobot
from slam_core.sim.world import load_world

DT = 0.01


def test_grabber_odometry_follows_the_simulated_robot():
    robot = SimRobot(load_world("flat"), rng=np.random.default_rng(0))
    mcu = VirtualMCU(robot, rate_hz=50.0, clock=lambda: robot.time).start()
    grabber = OdometryGrabber(mcu.path).start()
    try:
        assert grabber.wait_connected(5.0)
        # drive by serial commands only: forward and turning, in (about) real time
        deadline = time.monotonic() + 2.0
        while time.monotonic() < deadline:
            grabber.send_velocity(0.3, 0.4)
            for _ in range(5):
                robot.step(DT)
                time.sleep(DT)
        grabber.send_velocity(0.0, 0.0)
        for _ in range(100):  # let the robot stop and the last frames arrive
            robot.step(DT)
            time.sleep(DT)
        _, odo = grabber.odometry.get()
    finally:
        grabber.stop()
        mcu.stop()
    assert mcu.stats.commands_applied > 10
    assert odo is not None and odo.ticks == robot.ticks()
    moved = np.hypot(*(robot.true_pose[:2] - robot.world.start[:2]))
    assert moved > 0.2
    # the grabber's odometry frame starts at (0, 0, 0), the robot's at the world's start pose;
    # the grabber integrates 50 Hz samples, the robot every physics step: arcs differ only slightly
    pose = compose(robot.world.start, odo.pose)
    assert np.allclose(pose[:2], robot.odometry_pose[:2], atol=0.005)
    assert abs(wrap_angle(pose[2] - robot.odometry_pose[2])) < 0.005
