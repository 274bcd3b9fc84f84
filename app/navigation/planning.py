"""Adapters from the navigator to the planner (``slam_core.planning``) and the path follower.

TEMPORARY until the planner and the simulator's controller are merged: planning is
unavailable and every goal is refused with that reason.
"""

from __future__ import annotations

import numpy as np

from app.core.config import Settings
from slam_core.occupancy_grid import OccupancyGrid


class PlanningError(Exception):
    reason = "planning_failed"


def plan_path(grid: OccupancyGrid, pose: np.ndarray, goal) -> np.ndarray:
    raise PlanningError("the planner is not available in this build yet")


def follower_for(path: np.ndarray, settings: Settings):
    raise PlanningError("no path follower in this build yet")
