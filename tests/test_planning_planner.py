import itertools
import threading
import time

import numpy as np
import pytest

from slam_core.occupancy_grid import OccupancyGrid
from slam_core.planning import (
    MAP_CHANGED,
    OFF_PATH,
    CostmapConfig,
    PlanCancelled,
    Planner,
    PlannerConfig,
    PlanningError,
    costmap_from_trinary,
)
from tests.naive_planning import supercover_reference

RES = 0.05
ORIGIN = (-1.0, -0.5)


def house():
    """4 m x 3 m: outer walls, an inner wall with a door, a sealed closet, an unknown corner."""
    t = np.zeros((60, 80), np.int8)
    t[0, :] = t[-1, :] = t[:, 0] = t[:, -1] = 100
    t[:, 40] = 100
    t[25:35, 40] = 0  # a 0.5 m door
    t[45:, 60] = t[45, 60:] = 100  # closet in the top-right corner, no door
    t[1:12, 65:79] = -1  # unexplored corner (bottom right)
    return t


def world(ix, iy):
    return np.array(ORIGIN) + (np.array([ix, iy]) + 0.5) * RES


def cm_of(t, **cfg):
    return costmap_from_trinary(t, RES, ORIGIN, CostmapConfig(**cfg))


def assert_path_is_safe(path, costmap):
    cells = costmap.world_to_cell(path.vertices[path.escape:])
    for a, b in itertools.pairwise(cells):
        for ix, iy in supercover_reference(*a, *b):
            assert np.isfinite(costmap.weights[iy, ix])
    gaps = np.linalg.norm(np.diff(path.waypoints, axis=0), axis=1)
    assert gaps.max() <= PlannerConfig().waypoint_spacing + 1e-9


def test_plans_through_the_door():
    cm = cm_of(house())
    start, goal = world(10, 10), world(70, 30)
    path = Planner().plan(cm, (*start, 0.3), goal)
    assert_path_is_safe(path, cm)
    np.testing.assert_allclose(path.waypoints[0], start)
    np.testing.assert_allclose(path.waypoints[-1], goal)
    assert not path.snapped and path.escape == 0
    door = np.abs(path.waypoints[:, 0] - world(40, 0)[0]) < RES
    assert np.all((path.waypoints[door, 1] > world(0, 25)[1]) & (path.waypoints[door, 1] < world(0, 35)[1]))
    assert path.cost >= np.linalg.norm(goal - start)
    assert path.length >= np.linalg.norm(goal - start)


def test_goal_in_wall_snaps_to_reachable_side():
    cm = cm_of(house())
    # Inside the closet's wall, nearer the closet's sealed inside than the room.
    goal = world(60, 50) + np.array([0.03, 0.0])
    path = Planner(PlannerConfig(goal_tolerance=0.6)).plan(cm, world(10, 10), goal)
    assert path.snapped
    gx, gy = cm.world_to_cell(path.goal)
    assert np.isfinite(cm.weights[gy, gx]) and gx < 60
    assert np.linalg.norm(path.goal - goal) <= 0.6


@pytest.mark.parametrize("start, goal, cfg, reason", [
    (world(10, 10), (9.0, 0.0), {}, "goal_outside_map"),
    ((-5.0, 0.0), world(10, 10), {}, "start_outside_map"),
    (world(10, 10), world(70, 52), {}, "goal_unreachable"),  # in the sealed closet
    (world(10, 10), world(40, 10), {"goal_tolerance": 0.1}, "goal_in_obstacle"),
    (world(10, 10), world(62, 52), {"goal_tolerance": 0.15}, "goal_in_obstacle"),  # only closet cells near
    (world(10, 10), world(72, 5), {"unknown": None}, "goal_in_unknown"),
])
def test_errors_name_the_reason(start, goal, cfg, reason):
    unknown = cfg.pop("unknown", CostmapConfig().unknown_cost)
    cm = cm_of(house(), unknown_cost=unknown)
    with pytest.raises(PlanningError) as err:
        Planner(PlannerConfig(**cfg)).plan(cm, start, goal)
    assert err.value.reason == reason
    assert str(err.value)


def test_unknown_space_can_be_crossed_when_priced():
    cm = cm_of(house())
    path = Planner().plan(cm, world(50, 20), world(72, 5))
    assert cm.unknown[tuple(cm.world_to_cell(path.goal)[::-1])]


def test_start_next_to_wall_plans_out():
    cm = cm_of(house())
    start = world(1, 30)  # one cell from the outer wall, well inside the robot radius
    assert cm.lethal[30, 1]
    path = Planner().plan(cm, start, world(20, 30))
    assert path.escape > 0
    np.testing.assert_allclose(path.vertices[0], start)
    d = [cm.distance[iy, ix] for ix, iy in cm.world_to_cell(path.vertices[: path.escape + 1])]
    assert np.all(np.diff(d) > 0)  # the escape climbs away from the wall
    assert_path_is_safe(path, cm)


def test_start_buried_in_obstacle_is_blocked():
    t = house()
    t[10:30, 5:25] = 100
    with pytest.raises(PlanningError) as err:
        Planner().plan(cm_of(t), world(15, 20), world(30, 40))
    assert err.value.reason == "start_blocked"


def test_replans_when_the_map_blocks_the_path():
    planner = Planner()
    t = house()
    first = planner.plan(cm_of(t), world(10, 10), world(70, 30))
    assert planner.check(cm_of(t), world(10, 10)) is None
    assert planner.update(cm_of(t), world(10, 10)) is None
    t[25:35, 40] = 100  # the door closes ...
    t[5:15, 40] = 0  # ... and another opens
    assert planner.check(cm_of(t), world(10, 10)) == MAP_CHANGED
    second = planner.update(cm_of(t), world(10, 10))
    assert second is not None and second is planner.path and planner.last_replan_reason == MAP_CHANGED
    assert not np.allclose(first.goal - second.goal, 1.0)
    assert_path_is_safe(second, cm_of(t))
    assert planner.check(cm_of(t), world(10, 10)) is None


def test_blocking_behind_the_robot_does_not_replan():
    planner = Planner()
    t = house()
    path = planner.plan(cm_of(t), world(10, 10), world(70, 30))
    far = path.waypoints[len(path.waypoints) * 3 // 4]
    ix, iy = cm_of(t).world_to_cell(path.waypoints[2])
    t[iy - 1:iy + 2, ix - 1:ix + 2] = 100
    assert planner.check(cm_of(t), far) is None


def test_replans_when_robot_strays():
    planner = Planner(PlannerConfig(stray_distance=0.3))
    planner.plan(cm_of(house()), world(10, 10), world(70, 30))
    assert planner.check(cm_of(house()), world(10, 10) + np.array([0.2, 0.0])) is None
    stray = world(10, 50)
    assert planner.check(cm_of(house()), stray) == OFF_PATH
    path = planner.update(cm_of(house()), stray)
    np.testing.assert_allclose(path.waypoints[0], stray)
    assert planner.last_replan_reason == OFF_PATH


def test_check_survives_grid_growth():
    grid = OccupancyGrid(resolution=RES, origin=ORIGIN, shape=(60, 80))
    t = house()
    grid.data[t == 100] = 3.0
    grid.data[t == 0] = -3.0
    planner = Planner()
    planner.plan(grid, world(10, 10), world(70, 30))
    grid.ensure_contains(-4.0, -3.0, 1.0, 1.0)  # grows left and down: the origin moves
    assert not np.allclose(grid.origin, ORIGIN)
    assert planner.check(grid, world(10, 10)) is None


def test_planner_cancel_from_another_thread():
    t = np.zeros((1500, 1500), np.int8)
    t[:, 1300] = 100  # the goal side is walled off: the search would scan ~2M cells
    cm = costmap_from_trinary(t, RES)
    planner = Planner()
    planner.plan(costmap_from_trinary(np.zeros((20, 20), np.int8), RES), (0.3, 0.3), (0.6, 0.6))
    out = {}

    def run():
        try:
            planner.plan(cm, (1.0, 1.0), (70.0, 70.0))
        except PlanningError as e:
            out["error"] = e

    worker = threading.Thread(target=run)
    worker.start()
    time.sleep(0.05)
    planner.cancel()
    worker.join(timeout=30)
    assert isinstance(out.get("error"), PlanCancelled) and out["error"].reason == "cancelled"
    assert planner.path is None and planner.goal is None


def test_goal_in_start_cell_is_a_one_point_path():
    cm = cm_of(house())
    planner = Planner()
    path = planner.plan(cm, world(10, 10), world(10, 10) + 0.01)
    assert path.waypoints.shape == (1, 2) and path.cost == 0.0
    assert planner.check(cm, world(10, 10)) is None
