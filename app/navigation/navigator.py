"""The navigator: one goal at a time, planned on the live map, followed, replanned as the map grows.

Runs as an asyncio task in the server; planning runs in a thread (the A* kernel
releases the GIL), never in the event loop. The pose it follows is the server's
(``map -> odom`` composed with the newest odometry, fresh at odometry rate); velocity
commands go straight to the robot link (:mod:`app.robot_link.link`), not through the worker.
"""

from __future__ import annotations

import asyncio
import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from app.core.config import Settings
from app.navigation.planning import PlanningError, follower_for, navigable_costmap, plan_path
from app.navigation.progress import ProgressWatch, remaining_length
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.planning.costmap import Costmap
from slam_core.planning.zones import Restrictions

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Goal:
    """A point, the heading to end with (any if ``None``), and whether the path may cross unknown space."""

    x: float
    y: float
    place: str | None = None
    yaw: float | None = None
    explore: bool = False

    def dict(self) -> dict:
        return {"x": self.x, "y": self.y, "yaw": self.yaw, "place": self.place}


#: The place name tour goals carry.
TOUR = "tour"
#: A goal's heading is reached within this (rad); the robot turns on the spot until then.
HEADING_TOLERANCE = math.radians(2.0)
#: Turn rate per radian of heading error, and the slowest turn that still moves the wheels (rad/s).
HEADING_GAIN = 1.5
MIN_TURN_RATE = 0.15
#: A robot that makes no progress backs off this long at this speed (m/s), then replans; after
#: ``MAX_RECOVERIES`` such tries it stops and reports ``stuck``.
BACKOFF_S = 1.5
BACKOFF_SPEED = 0.1
MAX_RECOVERIES = 2


def heading_command(yaw: float, goal_yaw: float | None, max_rate: float) -> float:
    """The on-the-spot turn rate toward ``goal_yaw``; 0 once within :data:`HEADING_TOLERANCE`."""
    if goal_yaw is None:
        return 0.0
    error = math.atan2(math.sin(goal_yaw - yaw), math.cos(goal_yaw - yaw))
    if abs(error) <= HEADING_TOLERANCE:
        return 0.0
    rate = min(max(HEADING_GAIN * abs(error), MIN_TURN_RATE), max_rate)
    return math.copysign(rate, error)


class Navigator:
    """Goal, path and state (``idle``, ``driving``, ``arrived``, ``failed``, ``stuck``) of the robot.

    A goal ends ``arrived`` within ``goal_tolerance`` and facing its ``yaw`` (if it has one). A
    robot whose path left stops shrinking for ``stuck_after_s`` backs off and replans; after
    ``MAX_RECOVERIES`` of those it stops with state ``stuck``.

    Given ``tour`` waypoints, an idle robot drives to them in turn (from the start if
    ``touring``, else once :meth:`start_tour` is called) until a person takes over (a goal,
    teleop or a cancel from the API).
    """

    def __init__(self, settings: Settings, grid: Callable[[], OccupancyGrid | None],
                 pose: Callable[[], np.ndarray | None], send_velocity: Callable[[float, float], None],
                 tour: np.ndarray | None = None, touring: bool = True):
        self.settings = settings
        self._grid = grid
        self._pose = pose
        self._send = send_velocity
        self.goal: Goal | None = None
        self.path = np.zeros((0, 2))
        self.state = "idle"
        self.reason: str | None = None
        self._follower = None
        self._teleop: tuple[float, float] | None = None
        self._teleop_until = 0.0
        self._last_plan = 0.0
        self._replanning = False
        self._replan_task: asyncio.Task | None = None
        self._generation = 0
        self._tour = None if tour is None or len(tour) == 0 else np.asarray(tour, float)
        self._tour_next = 0
        self._touring = touring and self._tour is not None
        self._watch = ProgressWatch(settings.stuck_after_s)
        self._recoveries = 0
        self._backing_until = 0.0
        #: No-go zones and virtual walls every plan keeps out of (set by the runtime).
        self.restrictions: Callable[[], Restrictions | None] = lambda: None

    def snapshot(self) -> dict:
        return {"goal": self.goal.dict() if self.goal else None,
                "path": np.round(self.path, 3).tolist(), "state": self.state, "reason": self.reason}

    def path_length(self) -> float:
        if len(self.path) < 2:
            return 0.0
        return float(np.linalg.norm(np.diff(self.path, axis=0), axis=1).sum())

    async def _plan(self, goal: Goal) -> np.ndarray:
        grid, pose = self._grid(), self._pose()
        if grid is None or pose is None:
            raise PlanningError("the robot has no map or pose yet")
        return await asyncio.to_thread(plan_path, grid, np.asarray(pose, float), (goal.x, goal.y),
                                       self.restrictions(), explore=goal.explore,
                                       robot_radius=self.settings.robot_config().footprint_radius)

    def navigable(self) -> tuple[Costmap, np.ndarray]:
        """The costmap plain goals are planned on and the robot's pose; builds the costmap, so call
        it in a thread. ``PlanningError`` without a map or pose."""
        grid, pose = self._grid(), self._pose()
        if grid is None or pose is None:
            raise PlanningError("the robot has no map or pose yet")
        costmap = navigable_costmap(grid, self.restrictions(),
                                    robot_radius=self.settings.robot_config().footprint_radius)
        return costmap, np.asarray(pose, float)

    @property
    def touring(self) -> bool:
        return self._touring

    def take_over(self) -> None:
        """A person is in charge from now on: the tour ends."""
        self._touring = False

    def start_tour(self) -> bool:
        """Stop and drive the tour again from its first waypoint; False if there is no tour."""
        if self._tour is None:
            return False
        self._teleop = None
        self.cancel()
        self._tour_next, self._touring = 0, True
        return True

    async def set_goal(self, goal: Goal) -> dict:
        """Plan to ``goal`` and start driving; raises :class:`PlanningError` (the reason) when impossible."""
        if goal.place != TOUR:
            self.take_over()
        path = await self._plan(goal)
        if goal.place == TOUR and not self._touring:
            return self.snapshot()  # a person took over while this tour stop was being planned
        self._generation += 1
        self._teleop = None
        self.goal, self.path, self.state, self.reason = goal, path, "driving", None
        self._follower = follower_for(path, self.settings)
        self._last_plan = time.monotonic()
        self._watch.restart(self._last_plan)
        self._recoveries, self._backing_until = 0, 0.0
        return {"goal": goal.dict(), "path": np.round(path, 3).tolist(), "length": self.path_length()}

    def cancel(self, state: str = "idle", reason: str | None = None) -> None:
        self._generation += 1
        self.goal, self._follower = None, None
        self.path = np.zeros((0, 2))
        self.state, self.reason = state, reason
        self._send(0.0, 0.0)

    def teleop(self, v: float, w: float) -> None:
        """Drive by hand for ``teleop_hold_s``; cancels any goal."""
        self.take_over()
        if self.goal is not None:
            self.cancel()
        self._teleop = (float(v), float(w))
        self._teleop_until = time.monotonic() + self.settings.teleop_hold_s
        self._send(*self._teleop)

    async def run(self) -> None:
        """The control loop (until cancelled)."""
        period = 1.0 / self.settings.control_hz
        while True:
            await asyncio.sleep(period)
            try:
                await self._tick()
            except Exception:  # a control bug must not kill the loop; stop the robot
                log.exception("navigation tick failed")
                self.cancel("failed", "internal navigation error")

    async def _tick(self) -> None:
        now = time.monotonic()
        if self._teleop is not None:
            if now < self._teleop_until:
                self._send(*self._teleop)
            else:
                self._teleop = None
                self._send(0.0, 0.0)
            return
        if self.state != "driving" or self.goal is None:
            if self._touring:
                await self._next_tour_stop()
            return
        pose = self._pose()
        if pose is None:
            return
        # The planner may snap a goal inside an obstacle to a free cell: arrive at the path's end.
        tx, ty = self.path[-1] if len(self.path) else (self.goal.x, self.goal.y)
        near = math.hypot(pose[0] - tx, pose[1] - ty) <= self.settings.goal_tolerance
        if near or self._follower.done:
            turn = heading_command(pose[2], self.goal.yaw, self.settings.max_turn_rate)
            self._send(0.0, turn)
            if turn == 0.0:
                self.state, self._follower = "arrived", None
            return
        if now < self._backing_until:
            self._send(-BACKOFF_SPEED, 0.0)
            return
        if now - self._last_plan >= self.settings.replan_s and not self._replanning:
            self._last_plan = now
            self._replan_task = asyncio.create_task(self._replan(self._generation))
        v, w = self._follower.command(np.asarray(pose, float))
        if v == 0.0 and w != 0.0:
            self._watch.restart(now)  # turning on the spot toward the next leg is not a stall
        elif self._watch.stalled(now, remaining_length(self._follower, pose)):
            self._recover(now)
            return
        self._send(v, w)

    def _recover(self, now: float) -> None:
        """No progress: back off and replan, or give up with ``stuck`` after ``MAX_RECOVERIES``."""
        if self._recoveries >= MAX_RECOVERIES:
            log.info("stuck on the way to %s", self.goal)
            self.cancel("stuck", f"no progress for {self.settings.stuck_after_s:g} s after "
                                 f"{self._recoveries} back-offs and replans")
            return
        self._recoveries += 1
        self._backing_until = now + BACKOFF_S
        self._watch.restart(self._backing_until)
        self._last_plan = -math.inf  # replan as soon as the back-off ends
        self._send(-BACKOFF_SPEED, 0.0)

    async def _next_tour_stop(self) -> None:
        """Head for the tour's next waypoint; one that cannot be planned yet is skipped."""
        if self._grid() is None or self._pose() is None:
            return
        x, y = self._tour[self._tour_next % len(self._tour)]
        self._tour_next += 1
        try:
            await self.set_goal(Goal(float(x), float(y), TOUR, explore=True))
        except PlanningError as exc:
            log.info("tour stop (%.2f, %.2f) skipped: %s", x, y, exc)

    async def _replan(self, generation: int) -> None:
        """Plan again on the grown map; a goal that became impossible fails with the reason."""
        self._replanning = True
        try:
            path = await self._plan(self.goal)
        except PlanningError as exc:
            # The goal itself became impossible: give up. A transient start problem: keep the old path.
            if generation == self._generation and exc.reason.startswith("goal_"):
                log.info("replanning failed: %s", exc)
                self.cancel("failed", str(exc))
            return
        finally:
            self._replanning = False
        if generation == self._generation and self.state == "driving":
            self.path = path
            self._follower = follower_for(path, self.settings)
