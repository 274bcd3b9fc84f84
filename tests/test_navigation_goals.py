"""Goals that end well, checked against the simulator's ground truth: the navigator drives a
simulated robot (``SimRobot``: real collisions) on a known map, reaches a goal's position and
heading, refuses unknown space unless told to explore, and when a wall the map does not show
blocks the way it backs off, replans, reports ``stuck`` and can still be sent elsewhere."""

from __future__ import annotations

import asyncio
import math
import time

import numpy as np
import pytest

from app.core.config import Settings
from app.navigation.navigator import Goal, Navigator
from app.navigation.planning import PlanningError, plan_path
from slam_core.robot_config import robot_from
from slam_core.sim.ground_truth import ground_truth_map
from slam_core.sim.robot import SimRobot, WheelNoise
from slam_core.sim.world import parse_world

ROOM = "start 0.6 1.5 0\nroom box 0 0 4 3\n"
#: The same room with a wall across it that the map below does not show.
WALLED = parse_world(ROOM + "wall 2 0 2 3\n", source="walled")
OPEN = parse_world(ROOM, source="open")
PHYSICS_DT = 0.01
RADIUS = robot_from(None).footprint_radius


async def drive(world, grid, goals, until_s: float, settings: Settings):
    """Run the navigator on a simulated robot in real time; ``goals`` are (Goal, state wanted) in turn."""
    robot = SimRobot(world, noise=WheelNoise.none())
    nav = Navigator(settings, lambda: grid, lambda: robot.true_pose, robot.set_velocity)

    async def physics():
        while True:
            await asyncio.sleep(PHYSICS_DT)
            robot.step(PHYSICS_DT)

    tasks = [asyncio.create_task(physics()), asyncio.create_task(nav.run())]
    outcomes = []
    try:
        for goal in goals:
            await nav.set_goal(goal)
            deadline = time.monotonic() + until_s
            while nav.state == "driving" and time.monotonic() < deadline:
                await asyncio.sleep(0.05)
            outcomes.append((nav.state, nav.reason, robot.true_pose, robot.clearance()))
    finally:
        for task in tasks:
            task.cancel()
    return outcomes


def test_a_goal_is_reached_within_10_cm_facing_its_heading(tmp_path):
    grid = ground_truth_map(OPEN)
    goals = [Goal(2.2, 2.2, yaw=-math.pi / 2)]
    outcomes = asyncio.run(drive(OPEN, grid, goals, 40.0, Settings(data_dir=tmp_path)))
    for goal, (state, reason, true, _) in zip(goals, outcomes, strict=True):
        assert state == "arrived", (state, reason)
        turn = math.atan2(math.sin(true[2] - goal.yaw), math.cos(true[2] - goal.yaw))
        assert math.hypot(true[0] - goal.x, true[1] - goal.y) <= 0.10, (true, goal)
        assert abs(math.degrees(turn)) <= 5.0, (true, goal)


def test_an_unmapped_wall_ends_in_stuck_and_the_robot_can_still_go_elsewhere(tmp_path):
    grid = ground_truth_map(OPEN)  # the map shows no wall at x = 2
    settings = Settings(data_dir=tmp_path, stuck_after_s=1.0)
    elsewhere = Goal(0.8, 2.4, yaw=math.pi)
    outcomes = asyncio.run(drive(WALLED, grid, [Goal(3.4, 1.5), elsewhere], 30.0, settings))
    (state, reason, true, clearance), (back_state, _, back, _) = outcomes
    assert state == "stuck" and "back-offs" in reason, (state, reason)
    assert true[0] < 2.0 and clearance >= 0.17 - 1e-6, (true, clearance)  # never through, never in the wall
    assert back_state == "arrived" and math.hypot(back[0] - elsewhere.x, back[1] - elsewhere.y) <= 0.10, back
    turn = math.atan2(math.sin(back[2] - elsewhere.yaw), math.cos(back[2] - elsewhere.yaw))
    assert abs(math.degrees(turn)) <= 5.0, back


def _half_known():
    """The open room with everything right of x = 2 m never seen."""
    grid = ground_truth_map(OPEN)
    xs = grid.origin[0] + (np.arange(grid.shape[1]) + 0.5) * grid.resolution
    grid.data[:, xs > 2.0] = 0.0
    return grid


def test_unknown_space_is_refused_unless_exploring():
    grid = _half_known()
    start = np.array([0.6, 1.5, 0.0])
    with pytest.raises(PlanningError) as info:
        plan_path(grid, start, (3.0, 1.5), robot_radius=RADIUS)
    assert info.value.reason == "goal_in_unknown"
    path = plan_path(grid, start, (3.0, 1.5), explore=True, robot_radius=RADIUS)
    assert np.allclose(path[-1], (3.0, 1.5), atol=0.05) and path[:, 0].max() > 2.5


def test_paths_stay_in_mapped_space_without_explore():
    grid = _half_known()
    # Between two known rooms joined only through unknown space, no path without explore.
    ys = grid.origin[1] + (np.arange(grid.shape[0]) + 0.5) * grid.resolution
    xs = grid.origin[0] + (np.arange(grid.shape[1]) + 0.5) * grid.resolution
    known_far = (xs[None, :] > 3.0) & (ys[:, None] > 0.3) & (ys[:, None] < 2.7)
    grid.data[known_far] = grid.model.l_min
    with pytest.raises(PlanningError) as info:
        plan_path(grid, np.array([0.6, 1.5, 0.0]), (3.5, 1.5), robot_radius=RADIUS)
    assert info.value.reason == "goal_unreachable"
    assert plan_path(grid, np.array([0.6, 1.5, 0.0]), (3.5, 1.5), explore=True,
                     robot_radius=RADIUS)[-1][0] > 3.4
