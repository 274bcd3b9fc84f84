import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slam_core.robot_config import RobotLimits, robot_from
from slam_core.sensors.wheel_odometry import DiffDriveGeometry, integrate_ticks
from slam_core.sim.robot import SimRobot, WheelNoise
from slam_core.sim.world import load_world, parse_world
from tests import naive_sim

BOX = parse_world("start 1 1.5 0\nroom box 0 0 4 3\nleg 3 0.5 0.05 1.0\n", source="box")
QUIET = WheelNoise.none()
ROBOT = robot_from(None)


def drive(robot, v, w, seconds, dt=0.01):
    robot.set_velocity(v, w)
    for _ in range(round(seconds / dt)):
        robot.step(dt)


def test_interface_types():
    r = SimRobot(BOX, noise=QUIET)
    left, right = r.ticks()
    assert type(left) is int and type(right) is int and (left, right) == (0, 0)
    assert r.true_pose.shape == (3,) and r.odometry_pose.shape == (3,)
    with pytest.raises(ValueError, match="finite"):
        r.set_velocity(float("nan"), 0.0)
    with pytest.raises(ValueError, match="dt"):
        r.step(0.0)
    with pytest.raises(ValueError, match="finite"):
        SimRobot(BOX, pose=[1.0, 1.0])
    with pytest.raises(ValueError, match="inside an obstacle"):
        SimRobot(BOX, pose=[0.05, 1.0, 0.0])


def test_limits_clip_speed_and_acceleration():
    lim = RobotLimits(v_max=0.3, w_max=1.0, a_max=0.5, alpha_max=2.0)
    r = SimRobot(BOX, pose=[0.5, 1.5, 0.0], noise=QUIET, robot=replace(ROBOT, limits=lim))
    r.set_velocity(5.0, 0.0)
    r.step(0.1)
    assert r.velocity[0] == pytest.approx(0.05)  # a_max * dt
    drive(r, 5.0, 0.0, 1.0)
    assert r.velocity[0] == pytest.approx(0.3)
    drive(r, 0.0, -9.0, 1.0)
    assert r.velocity[1] == pytest.approx(-1.0)


def test_noise_free_odometry_follows_truth_up_to_quantisation():
    r = SimRobot(BOX, pose=[1.0, 1.5, 0.0], noise=QUIET)
    drive(r, 0.3, 0.4, 4.0)
    drive(r, 0.2, -0.5, 3.0)
    # one tick is 0.15 mm of travel: the only error left is encoder quantisation
    assert np.allclose(r.odometry_pose[:2], r.true_pose[:2], atol=2e-3)
    assert abs(r.odometry_pose[2] - r.true_pose[2]) < 0.01


def test_odometry_pose_is_integrate_ticks_over_the_tick_increments():
    """What the odometry grabber will compute from the same ticks."""
    r = SimRobot(load_world("flat"), noise=WheelNoise(0.01, 0.02, 0.3), rng=np.random.default_rng(7))
    pose, last = r.odometry_pose, r.ticks()
    for v, w in ((0.3, 0.0), (0.2, 0.8), (0.0, -1.0), (0.25, -0.3)):
        r.set_velocity(v, w)
        for _ in range(50):
            r.step(0.02)
            now = r.ticks()
            pose = integrate_ticks(pose, now[0] - last[0], now[1] - last[1], r.geometry)
            last = now
    assert np.allclose(pose, r.odometry_pose, atol=1e-12)
    assert not np.allclose(pose, r.true_pose, atol=1e-3)  # slip made it drift


def test_encoder_quantisation():
    geo = DiffDriveGeometry(wheel_radius=0.05, wheel_base=0.3, ticks_per_rev=100)
    r = SimRobot(BOX, pose=[0.5, 1.5, 0.0], noise=QUIET,
                 robot=replace(ROBOT, wheels=geo, limits=replace(ROBOT.limits, a_max=1e9, alpha_max=1e9)))
    # 0.5 wheel revolutions (0.05 * pi m) exactly -> 50 ticks; just below -> 49
    dist = 0.5 * 2 * math.pi * geo.wheel_radius
    r.set_velocity(dist * 0.999 / 0.5, 0.0)
    for _ in range(5):
        r.step(0.1)
    assert r.ticks() == (49, 49)
    r.set_velocity(dist * 0.002 / 0.1, 0.0)
    r.step(0.1)
    assert r.ticks() == (50, 50)
    # backwards: floor rounds toward -inf
    r2 = SimRobot(BOX, pose=[2.0, 1.5, 0.0], noise=QUIET,
                  robot=replace(ROBOT, wheels=geo, limits=replace(ROBOT.limits, a_max=1e9)))
    r2.set_velocity(-0.001, 0.0)
    r2.step(0.1)
    assert r2.ticks() == (-1, -1)


def test_odometry_drifts_while_truth_is_exact():
    """With slip the odometry wanders off; the truth stays consistent with the geometry (straight walls)."""
    w = load_world("house")
    errors = []
    for seed in range(3):
        r = SimRobot(w, pose=[3.75, 3.75, 0.0], noise=WheelNoise(0.003, 0.02, 0.3),
                     rng=np.random.default_rng(seed))
        drive(r, 0.4, 0.0, 25.0, dt=0.02)  # east along the south corridor, ~10 m
        errors.append(r.odometry_pose - r.true_pose)
        # whatever the slip, the true robot never left the 1.5 m corridor
        assert 3.0 + r.radius <= r.true_pose[1] <= 4.5 - r.radius
    errors = np.array(errors)
    assert np.all(np.hypot(errors[:, 0], errors[:, 1]) > 0.005)
    assert len({round(e, 6) for e in errors[:, 2]}) == 3  # different seeds drift differently


def test_collision_stops_at_the_wall():
    r = SimRobot(BOX, pose=[1.0, 2.0, 0.0], noise=QUIET)
    drive(r, 0.5, 0.0, 10.0)
    assert r.bumped
    assert r.true_pose[0] == pytest.approx(4.0 - r.radius, abs=1e-3)
    assert r.clearance() >= r.radius
    # the wheels stopped with the robot, so odometry agrees with the truth
    assert r.odometry_pose[0] == pytest.approx(r.true_pose[0], abs=2e-3)
    # a new command clears the bump: turning around and driving away works
    drive(r, 0.0, 1.0, math.pi)
    drive(r, 0.3, 0.0, 1.0)
    assert not r.bumped and r.true_pose[0] < 3.6


def test_collision_with_a_leg():
    r = SimRobot(BOX, pose=[1.5, 0.5, 0.0], noise=QUIET)
    drive(r, 0.5, 0.0, 8.0)
    assert r.bumped and r.true_pose[0] == pytest.approx(3.0 - 0.05 - r.radius, abs=1e-3)


commands = st.lists(st.tuples(st.floats(-1.0, 1.0), st.floats(-2.0, 2.0), st.integers(1, 40)),
                    min_size=1, max_size=8)


@settings(max_examples=25, deadline=None)
@given(commands, st.integers(0, 2**16))
def test_never_passes_through_walls(cmds, seed):
    w = load_world("flat")
    r = SimRobot(w, noise=WheelNoise(0.01, 0.05, 0.2), rng=np.random.default_rng(seed),
                 robot=replace(ROBOT, limits=RobotLimits(v_max=1.0, w_max=2.0, a_max=5.0, alpha_max=10.0)))
    walls = w.segments
    for v, om, steps in cmds:
        r.set_velocity(v, om)
        for _ in range(steps):
            before = r.true_pose
            r.step(0.05)
            after = r.true_pose
            assert r.clearance() >= r.radius - 1e-9
            assert not any(naive_sim.segments_cross(before[:2], after[:2], s) for s in walls)
