"""Adapters from the navigator to the planner (``slam_core.planning``) and the path follower."""

from __future__ import annotations

import numpy as np

from app.core.config import Settings
from slam_core.control.pure_pursuit import PurePursuit, PursuitConfig
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.planning import planner
from slam_core.planning.costmap import Costmap, CostmapConfig, build_costmap
from slam_core.planning.errors import PlanningError
from slam_core.planning.zones import Restrictions, check_goal, exit_point, restricted_costmap

__all__ = ["PlanningError", "costmap_config", "follower_for", "navigable_costmap", "plan_path"]


#: A cell the robot has seen to be more likely free than not is mapped free space (the dashboard
#: draws it lighter than unknown grey); one never seen, or seen more occupied than free, is unknown.
MAPPED_FREE_BELOW = 0.5


def costmap_config(robot_radius: float, explore: bool) -> CostmapConfig:
    """The costmap of a robot of ``robot_radius``: unknown cells are forbidden unless the goal
    explores; then they cost the planner's default extra."""
    if explore:
        return CostmapConfig(robot_radius=robot_radius, free_thresh=MAPPED_FREE_BELOW)
    return CostmapConfig(robot_radius=robot_radius, unknown_cost=None, free_thresh=MAPPED_FREE_BELOW)


def navigable_costmap(grid: OccupancyGrid, restrictions: Restrictions | None, *,
                      robot_radius: float) -> Costmap:
    """The costmap a goal that does not explore is planned on: mapped free space, with the no-go
    zones and virtual walls lethal."""
    config = costmap_config(robot_radius, explore=False)
    costmap = build_costmap(grid, config)
    return restricted_costmap(costmap, restrictions, config.robot_radius) if restrictions else costmap


def plan_path(grid: OccupancyGrid, pose: np.ndarray, goal, restrictions: Restrictions | None = None,
              *, robot_radius: float, explore: bool = False) -> np.ndarray:
    """Waypoints ``(n, 2)`` from the pose to the goal for a robot of ``robot_radius`` (m); raises
    ``PlanningError`` with a ``reason``.

    Without ``explore`` a goal in unknown space fails with ``goal_in_unknown`` and the path stays
    in mapped free space. With ``restrictions`` (no-go zones, virtual walls) the path keeps the
    robot out of them; a robot inside one first leaves it by the nearest way out.
    """
    config = costmap_config(robot_radius, explore)
    costmap = build_costmap(grid, config)
    start = np.asarray(pose, float)[:2]
    way_out = None
    if restrictions:
        check_goal(restrictions, goal)
        unrestricted = costmap
        costmap = restricted_costmap(costmap, restrictions, config.robot_radius)
        way_out = exit_point(costmap, start, unrestricted)
    path = planner.plan_path(costmap, start if way_out is None else way_out, np.asarray(goal, float))
    waypoints = np.asarray(path.waypoints, float)
    if not path.snapped:  # the search ends at the goal cell's centre: end at the goal itself
        waypoints[-1] = path.requested_goal
    return waypoints if way_out is None else np.vstack([start, waypoints])


def follower_for(waypoints: np.ndarray, settings: Settings) -> PurePursuit:
    """The simulator branch's pure-pursuit controller for the server's robot, within the server's
    speed limits and the robot's."""
    config = PursuitConfig.for_robot(settings.robot_config(), v_max=settings.max_speed,
                                     w_max=settings.max_turn_rate, goal_tolerance=settings.goal_tolerance)
    return PurePursuit(waypoints, config)
