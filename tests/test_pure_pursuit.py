import math
from dataclasses import replace

import numpy as np
import pytest

from slam_core.control.pure_pursuit import PurePursuit, PursuitConfig
from slam_core.rbpf.laser_mount import LaserMount
from slam_core.robot_config import robot_from
from slam_core.sim.simulator import SimConfig, Simulator
from slam_core.sim.world import parse_world

ROOMS = """
start 1 1 0
room a 0 0 5 4
room b 5 0 9 4
door 5 1.5 5 2.5
"""
ROBOT = robot_from(None)


def run(sim, controller, seconds):
    for _ in range(int(seconds * 20)):
        v, w = controller.command(sim.robot.true_pose, sim.last.scan)
        sim.advance(v, w)
        if controller.done:
            break


def test_reaches_the_goal_through_a_door_within_limits():
    world = parse_world(ROOMS, source="rooms")
    sim = Simulator(world, SimConfig(), seed=1)
    cfg = PursuitConfig.for_robot(ROBOT, v_max=0.35, w_max=1.0)
    ctl = PurePursuit([[3.5, 1.0], [3.5, 2.0], [7.5, 2.0], [7.5, 3.0]], cfg)
    seen = []
    for _ in range(60 * 20):
        v, w = ctl.command(sim.robot.true_pose, sim.last.scan)
        seen.append((v, w))
        sim.advance(v, w)
        assert not sim.robot.bumped
        if ctl.done:
            break
    assert ctl.done and not ctl.blocked
    assert np.hypot(*(sim.robot.true_pose[:2] - [7.5, 3.0])) <= cfg.goal_tolerance + 0.02
    seen = np.array(seen)
    assert np.all(np.abs(seen[:, 0]) <= cfg.v_max + 1e-12) and np.all(np.abs(seen[:, 1]) <= cfg.w_max + 1e-12)
    assert ctl.command(sim.robot.true_pose) == (0.0, 0.0)


def test_stops_before_an_obstacle_on_the_path():
    world = parse_world(ROOMS + "leg 3.0 1.0 0.1 1.0\n", source="rooms+post")
    sim = Simulator(world, SimConfig(), seed=2)
    ctl = PurePursuit([[4.5, 1.0]], PursuitConfig.for_robot(ROBOT))
    run(sim, ctl, 30)
    assert ctl.blocked and not ctl.done
    assert not sim.robot.bumped
    gap = 3.0 - 0.1 - sim.robot.true_pose[0] - sim.robot.radius
    assert 0.02 < gap <= ctl.config.stop_distance + 0.02
    assert sim.robot.velocity == (0.0, 0.0)


@pytest.mark.parametrize("told_the_mount", [True, False])
def test_a_turned_laser_behind_the_centre_still_stops_the_robot_before_an_obstacle(told_the_mount):
    """The laser sits 8 cm behind the centre, turned to face left: the controller reads the post
    ahead from its scan only through the robot file's mount (without it the robot runs into it)."""
    world = parse_world(ROOMS + "leg 3.0 1.0 0.1 1.0\n", source="rooms+post")
    mount = LaserMount(-0.08, 0.0, math.pi / 2)
    robot = replace(ROBOT, laser=replace(ROBOT.laser, mount=mount))
    sim = Simulator(world, SimConfig(robot=robot), seed=2)
    controller_robot = robot if told_the_mount else ROBOT
    ctl = PurePursuit([[4.5, 1.0]], PursuitConfig.for_robot(controller_robot))
    run(sim, ctl, 30)
    if not told_the_mount:
        assert sim.robot.bumped and not ctl.blocked
        return
    assert ctl.blocked and not ctl.done and not sim.robot.bumped
    gap = 3.0 - 0.1 - sim.robot.true_pose[0] - sim.robot.radius
    assert 0.02 < gap <= ctl.config.stop_distance + 0.02


def test_slows_for_turns_and_goal():
    cfg = PursuitConfig.for_robot(ROBOT)
    straight = PurePursuit([[2.0, 0.0], [6.0, 0.0]], cfg)
    corner = PurePursuit([[2.0, 0.0], [2.0, 3.0]], cfg)
    v_straight, _ = straight.command([1.7, 0.0, 0.0])
    v_corner, _ = corner.command([1.7, 0.0, 0.0])
    assert v_straight == pytest.approx(cfg.v_max)
    # 0.3 m before a right-angle turn: sqrt(2 decel (d - tolerance))
    assert v_corner == pytest.approx(np.sqrt(2 * cfg.decel * (0.3 - cfg.waypoint_tolerance)))
    assert v_corner < 0.9 * v_straight
    # off the line, curvature makes it slower than on it
    v_off, w_off = PurePursuit([[5.0, 0.0]], cfg).command([0.0, 0.25, 0.0])
    assert v_off < cfg.v_max and w_off < 0  # steers right, back to the line


def test_turns_on_the_spot_when_the_leg_is_behind():
    v, w = PurePursuit([[-2.0, 0.0]], PursuitConfig.for_robot(ROBOT)).command([0.0, 0.0, 0.0])
    assert v == 0.0 and abs(w) > 0


def test_bad_waypoints():
    with pytest.raises(ValueError, match="waypoints"):
        PurePursuit([], PursuitConfig.for_robot(ROBOT))
    with pytest.raises(ValueError, match="waypoints"):
        PurePursuit([[1.0, np.nan]], PursuitConfig.for_robot(ROBOT))
