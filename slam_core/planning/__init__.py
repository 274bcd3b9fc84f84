"""Path planning on the live occupancy grid: costmap -> A* -> shortcuts -> waypoints.

Goals flow browser -> server -> :class:`Planner` -> controller. Errors are
:class:`PlanningError` subclasses whose ``reason`` the server returns with 422.
"""

from slam_core.planning.astar import SearchResult, astar, new_cancel_flag
from slam_core.planning.costmap import Costmap, CostmapConfig, build_costmap, costmap_from_trinary
from slam_core.planning.errors import (
    GoalInObstacle,
    GoalInUnknown,
    GoalOutsideMap,
    GoalUnreachable,
    PlanCancelled,
    PlanningError,
    StartBlocked,
    StartOutsideMap,
)
from slam_core.planning.planner import (
    MAP_CHANGED,
    OFF_PATH,
    CancelToken,
    Path,
    Planner,
    PlannerConfig,
    plan_path,
)

__all__ = [
    "MAP_CHANGED",
    "OFF_PATH",
    "CancelToken",
    "Costmap",
    "CostmapConfig",
    "GoalInObstacle",
    "GoalInUnknown",
    "GoalOutsideMap",
    "GoalUnreachable",
    "Path",
    "PlanCancelled",
    "Planner",
    "PlannerConfig",
    "PlanningError",
    "SearchResult",
    "StartBlocked",
    "StartOutsideMap",
    "astar",
    "build_costmap",
    "costmap_from_trinary",
    "new_cancel_flag",
    "plan_path",
]
