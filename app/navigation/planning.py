"""Adapters from the navigator to the planner (``slam_core.planning``) and the path follower."""

from __future__ import annotations

import math

import numpy as np

from app.core.config import Settings
from slam_core.geometry import wrap_angle
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.planning import planner
from slam_core.planning.costmap import build_costmap
from slam_core.planning.errors import PlanningError

__all__ = ["PlanningError", "follower_for", "plan_path"]


def plan_path(grid: OccupancyGrid, pose: np.ndarray, goal) -> np.ndarray:
    """Waypoints ``(n, 2)`` from the pose to the goal; raises ``PlanningError`` with a ``reason``."""
    path = planner.plan_path(build_costmap(grid), np.asarray(pose, float)[:2], np.asarray(goal, float))
    return np.asarray(path.waypoints, float)


class TemporaryFollower:
    """TEMPORARY path follower until the simulator branch's pure pursuit is merged.

    Heads for the first waypoint farther than ``LOOKAHEAD``; turns on the spot when
    it is more than ``TURN_IN_PLACE`` off the heading.
    """

    LOOKAHEAD = 0.35
    TURN_IN_PLACE = 0.6
    HEADING_GAIN = 2.0

    def __init__(self, waypoints: np.ndarray, settings: Settings):
        self.waypoints = np.asarray(waypoints, float)
        self.v_max, self.w_max = settings.max_speed, settings.max_turn_rate
        self.index = 0

    def command(self, pose: np.ndarray) -> tuple[float, float]:
        pts = self.waypoints
        d = np.hypot(pts[:, 0] - pose[0], pts[:, 1] - pose[1])
        ahead = np.flatnonzero((d > self.LOOKAHEAD) & (np.arange(len(pts)) >= self.index))
        self.index = int(ahead[0]) if len(ahead) else len(pts) - 1
        target = pts[self.index]
        err = float(wrap_angle(math.atan2(target[1] - pose[1], target[0] - pose[0]) - pose[2]))
        w = max(-self.w_max, min(self.w_max, self.HEADING_GAIN * err))
        if abs(err) > self.TURN_IN_PLACE:
            return 0.0, w
        v = min(self.v_max, 0.6 * float(d[-1]) + 0.05) * math.cos(err)
        return v, w


def follower_for(waypoints: np.ndarray, settings: Settings) -> TemporaryFollower:
    return TemporaryFollower(waypoints, settings)
