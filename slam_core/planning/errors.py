"""Why a plan failed, as exceptions with a machine-readable ``reason``.

The server maps any :class:`PlanningError` to HTTP 422 with ``reason`` in the body.
"""

from __future__ import annotations


class PlanningError(Exception):
    """A goal that cannot be planned to; ``reason`` is a short stable identifier."""

    reason = "planning_failed"

    def __init__(self, message: str):
        super().__init__(message)
        self.message = message


class StartOutsideMap(PlanningError):
    reason = "start_outside_map"


class StartBlocked(PlanningError):
    reason = "start_blocked"


class GoalOutsideMap(PlanningError):
    reason = "goal_outside_map"


class GoalInObstacle(PlanningError):
    reason = "goal_in_obstacle"


class GoalInUnknown(PlanningError):
    reason = "goal_in_unknown"


class GoalUnreachable(PlanningError):
    reason = "goal_unreachable"


class PlanCancelled(PlanningError):
    reason = "cancelled"
