"""No-go zones and virtual walls: no planned path enters a zone or crosses a virtual wall, and the
simulated robot following it never does either (hypothesis: random worlds, zones, walls, goals)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from app.navigation.planning import costmap_config, plan_path
from slam_core.control.pure_pursuit import PurePursuit, PursuitConfig
from slam_core.planning.costmap import build_costmap
from slam_core.planning.errors import PlanningError
from slam_core.planning.zones import (
    GoalInNoGoZone,
    NoGoZone,
    Restrictions,
    VirtualWall,
    exit_point,
    restricted_costmap,
)
from slam_core.robot_config import robot_from
from slam_core.sim.ground_truth import ground_truth_map
from slam_core.sim.robot import SimRobot, WheelNoise
from slam_core.sim.world import parse_world

ROBOT = robot_from(None)
RADIUS = ROBOT.footprint_radius
RES = 0.05
W, H = 7.0, 5.0


def _world(rng: np.random.Generator):
    """A 7 x 5 m room with one or two inner walls (each with a gap), the start in free space."""
    lines = [f"polygon 0 0 {W} 0 {W} {H} 0 {H}"]
    for _ in range(rng.integers(1, 3)):
        if rng.random() < 0.5:
            x = round(float(rng.uniform(1.5, W - 1.5)), 2)
            gap = float(rng.uniform(0.8, H - 1.8))
            lines.append(f"wall {x} 0 {x} {gap:.2f}")
            lines.append(f"wall {x} {gap + 1.0:.2f} {x} {H}")
        else:
            y = round(float(rng.uniform(1.5, H - 1.5)), 2)
            gap = float(rng.uniform(0.8, W - 1.8))
            lines.append(f"wall 0 {y} {gap:.2f} {y}")
            lines.append(f"wall {gap + 1.0:.2f} {y} {W} {y}")
    return lines


def _restrictions(rng: np.random.Generator) -> Restrictions:
    zones = []
    for _ in range(rng.integers(1, 3)):
        cx, cy = rng.uniform(0.5, W - 0.5), rng.uniform(0.5, H - 0.5)
        n = int(rng.integers(3, 7))
        angles = np.sort(rng.uniform(0, 2 * np.pi, n))
        radii = rng.uniform(0.3, 1.2, n)
        zones.append(NoGoZone(tuple((float(cx + r * np.cos(a)), float(cy + r * np.sin(a)))
                                    for a, r in zip(angles, radii, strict=True))))
    walls = []
    for _ in range(rng.integers(0, 3)):
        a = rng.uniform([0.3, 0.3], [W - 0.3, H - 0.3])
        b = a + rng.uniform(-2.5, 2.5, 2)
        walls.append(VirtualWall((float(a[0]), float(a[1])), (float(b[0]), float(b[1]))))
    return Restrictions(tuple(zones), tuple(walls))


def _segment_distance(p, a, b) -> np.ndarray:
    """Distance from points ``p`` (n, 2) to segment a-b."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    d = b - a
    t = np.clip(((p - a) @ d) / max(d @ d, 1e-12), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[:, None] * d), axis=1)


def _crosses(p, q, a, b) -> bool:
    """Whether segments p-q and a-b intersect."""
    def side(o, u, v):
        return np.sign((u[0] - o[0]) * (v[1] - o[1]) - (u[1] - o[1]) * (v[0] - o[0]))
    return side(p, q, a) != side(p, q, b) and side(a, b, p) != side(a, b, q)


def _dense(waypoints: np.ndarray, step: float = 0.01) -> np.ndarray:
    out = [waypoints[:1]]
    for a, b in itertools.pairwise(waypoints):
        n = max(int(np.ceil(np.linalg.norm(b - a) / step)), 1)
        out.append(a + np.linspace(0, 1, n + 1)[1:, None] * (b - a))
    return np.vstack(out)


def _clearance_to_restrictions(points: np.ndarray, r: Restrictions) -> float:
    best = np.inf
    for zone in r.zones:
        assert not zone.contains(points).any(), "a point lies inside a no-go zone"
        poly = np.asarray(zone.points)
        for a, b in zip(poly, np.roll(poly, -1, axis=0), strict=True):
            best = min(best, float(_segment_distance(points, a, b).min()))
    for wall in r.walls:
        best = min(best, float(_segment_distance(points, wall.a, wall.b).min()))
    return best


def _scenario(seed: int):
    rng = np.random.default_rng(seed)
    lines = _world(rng)
    restrictions = _restrictions(rng)
    probe = parse_world("\n".join(["start 0.5 0.5 0", *lines]), source="probe")
    base = build_costmap(ground_truth_map(probe, RES))
    costmap = restricted_costmap(base, restrictions, RADIUS)
    free = np.argwhere(np.isfinite(costmap.weights) & (costmap.distance > 0.3))
    if len(free) == 0:
        return None
    iy, ix = free[rng.integers(len(free))]
    start = costmap.cell_to_world([ix, iy])
    world = parse_world("\n".join([f"start {start[0]:.3f} {start[1]:.3f} 0", *lines]), source="random")
    grid = ground_truth_map(world, RES)
    goal = rng.uniform([0.2, 0.2], [W - 0.2, H - 0.2])
    return world, grid, restrictions, start, goal


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**32 - 1))
def test_no_planned_path_enters_a_zone_or_crosses_a_virtual_wall(seed):
    scenario = _scenario(seed)
    assume(scenario is not None)
    _, grid, restrictions, start, goal = scenario
    in_zone = any(z.contains(goal) for z in restrictions.zones)
    try:
        path = plan_path(grid, np.array([*start, 0.0]), goal, restrictions, robot_radius=RADIUS)
    except GoalInNoGoZone:
        assert in_zone
        return
    except PlanningError as exc:
        assert not in_zone and exc.reason != "goal_in_no_go_zone"
        return
    assert not in_zone
    points = _dense(path)
    assert _clearance_to_restrictions(points, restrictions) >= RADIUS - 2 * RES
    for wall in restrictions.walls:
        for p, q in itertools.pairwise(path):
            assert not _crosses(p, q, wall.a, wall.b)


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**32 - 1))
def test_the_simulated_robot_never_enters_a_zone_or_crosses_a_virtual_wall(seed):
    scenario = _scenario(seed)
    assume(scenario is not None)
    world, grid, restrictions, start, goal = scenario
    try:
        path = plan_path(grid, np.array([*start, 0.0]), goal, restrictions, robot_radius=RADIUS)
    except PlanningError:
        assume(False)
        return
    heading = np.arctan2(*(path[1] - path[0])[::-1]) if len(path) > 1 else 0.0
    robot = SimRobot(world, np.array([*start, heading]), noise=WheelNoise.none())
    follower = PurePursuit(path, PursuitConfig.for_robot(ROBOT, v_max=0.4, w_max=1.2))
    dt, previous = 0.05, robot.true_pose[:2].copy()
    for _ in range(int(120 / dt)):
        robot.set_velocity(*follower.command(robot.true_pose))
        robot.step(dt)
        here = robot.true_pose[:2].copy()
        # The robot's body, not only its centre, stays out (within the two cells the path may).
        assert _clearance_to_restrictions(here[None], restrictions) >= RADIUS - 2 * RES
        for wall in restrictions.walls:
            assert not _crosses(previous, here, wall.a, wall.b), "the robot crossed a virtual wall"
        previous = here
        if follower.done:
            break
    assert follower.done


def test_a_robot_inside_a_zone_leaves_by_the_nearest_way_out():
    world = parse_world("start 1 1 0\npolygon 0 0 6 0 6 4 0 4", source="box")
    grid = ground_truth_map(world, RES)
    zone = NoGoZone(((2.0, 1.0), (4.0, 1.0), (4.0, 3.0), (2.0, 3.0)))
    path = plan_path(grid, np.array([2.3, 2.0, 0.0]), (5.0, 2.0), Restrictions((zone,)), robot_radius=RADIUS)
    assert np.allclose(path[0], [2.3, 2.0])
    way_out = path[1]
    # The nearest way out of the zone (grown by the robot's radius) is west, through x = 2 - radius.
    assert way_out[0] < 2.0 - RADIUS + RES and abs(way_out[1] - 2.0) < 2 * RES
    assert _clearance_to_restrictions(_dense(path[1:]), Restrictions((zone,))) >= RADIUS - 2 * RES


def test_the_way_out_of_a_zone_never_leads_through_a_real_wall():
    # Two rooms split by a wall at x = 4 (a gap at its top); the zone ends 0.1 m short of that wall.
    world = parse_world("start 1 1 0\npolygon 0 0 8 0 8 4 0 4\nwall 4 0 4 3.2", source="two rooms")
    grid = ground_truth_map(world, RES)
    zone = NoGoZone(((2.5, 0.0), (3.9, 0.0), (3.9, 2.5), (2.5, 2.5)))
    start = np.array([3.6, 1.5, 0.0])
    costmap = build_costmap(grid, costmap_config(RADIUS, explore=False))
    restricted = restricted_costmap(costmap, Restrictions((zone,)), RADIUS)
    # In a straight line the nearest free cell lies in the other room, behind the wall ...
    assert exit_point(restricted, start)[0] > 4.0
    # ... but the robot leaves on its own side: north, above the zone grown by its radius.
    path = plan_path(grid, start, (1.0, 3.5), Restrictions((zone,)), robot_radius=RADIUS)
    way_out = path[1]
    assert way_out[0] < 4.0 - RADIUS and way_out[1] > 2.5 + RADIUS - RES, way_out
    assert np.all(_dense(path)[:, 0] < 4.0)  # no part of the drive crosses the wall


def test_a_zone_or_a_virtual_wall_across_the_direct_route_forces_a_detour():
    world = parse_world("start 1 1 0\npolygon 0 0 6 0 6 4 0 4", source="box")
    grid = ground_truth_map(world, RES)
    start, goal = np.array([1.0, 1.0, 0.0]), (5.0, 1.0)
    direct = plan_path(grid, start, goal, robot_radius=RADIUS)
    assert np.abs(direct[:, 1] - 1.0).max() < 0.1  # straight along y = 1
    zone = Restrictions((NoGoZone(((2.0, 0.0), (4.0, 0.0), (4.0, 3.0), (2.0, 3.0))),))
    wall = Restrictions(walls=(VirtualWall((3.0, 0.0), (3.0, 3.0)),))
    for restriction in (zone, wall):
        detour = plan_path(grid, start, goal, restriction, robot_radius=RADIUS)
        assert detour[:, 1].max() > 3.0 + RADIUS - RES  # over the top, clear of the zone or wall's end
        assert _clearance_to_restrictions(_dense(detour), restriction) >= RADIUS - 2 * RES
    with pytest.raises(GoalInNoGoZone, match="inside no-go zone 1"):
        plan_path(grid, start, (3.0, 1.0), zone, robot_radius=RADIUS)


@pytest.mark.parametrize(("make", "message"), [
    (lambda: NoGoZone(((0, 0), (1, 1))), "3 to"),
    (lambda: NoGoZone(((0, 0), (1, 1), (2, 2))), "enclose an area"),
    (lambda: NoGoZone(((0, 0), (1, float("nan")), (2, 0))), "finite"),
    (lambda: VirtualWall((1, 1), (1, 1)), "distinct"),
])
def test_bad_zones_and_walls_are_refused(make, message):
    with pytest.raises(ValueError, match=message):
        make()
