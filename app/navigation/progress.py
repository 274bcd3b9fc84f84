"""Is the robot still getting closer to its goal? The path length left, watched over a time window."""

from __future__ import annotations

import math

import numpy as np

from slam_core.control.pure_pursuit import PurePursuit

#: Less than this much shorter a path left (m) is no progress.
MIN_PROGRESS_M = 0.1


def remaining_length(follower: PurePursuit, xy) -> float:
    """Metres left along the path: to the follower's current waypoint, then waypoint to waypoint."""
    ahead = follower.waypoints[follower.target:]
    legs = float(np.linalg.norm(np.diff(ahead, axis=0), axis=1).sum()) if len(ahead) > 1 else 0.0
    return math.hypot(ahead[0][0] - xy[0], ahead[0][1] - xy[1]) + legs


class ProgressWatch:
    """Reports a stall when the path left has not shrunk by ``MIN_PROGRESS_M`` for ``window_s``."""

    def __init__(self, window_s: float):
        self.window_s = window_s
        self._best = math.inf
        self._since = 0.0

    def restart(self, now: float) -> None:
        """Watch afresh from ``now`` (a new path, or the end of a back-off)."""
        self._best, self._since = math.inf, now

    def stalled(self, now: float, remaining: float) -> bool:
        if remaining < self._best - MIN_PROGRESS_M:
            self._best, self._since = remaining, now
            return False
        return now - self._since >= self.window_s
