"""From a map, a start pose and a goal point to waypoints in metres; replanning and cancel.

``plan_path`` does one plan: snap the goal, let a start inside the inflated
zone escape, run A* (:mod:`.astar`), shortcut (:mod:`.smoothing`) and space
waypoints. :class:`Planner` keeps the current goal and path, tells when the
path must be replanned (the map now blocks it, or the robot strayed from it)
and can cancel a search running in another thread.
"""

from __future__ import annotations

import itertools
import threading
from dataclasses import dataclass, field

import numpy as np

from slam_core.occupancy_grid import OccupancyGrid
from slam_core.planning.astar import astar, new_cancel_flag
from slam_core.planning.costmap import Costmap, CostmapConfig, build_costmap
from slam_core.planning.errors import (
    GoalInObstacle,
    GoalInUnknown,
    GoalOutsideMap,
    GoalUnreachable,
    PlanCancelled,
    StartBlocked,
    StartOutsideMap,
)
from slam_core.planning.line import segment_clear
from slam_core.planning.smoothing import SHORTCUT_TOLERANCE, resample, shortcut_path

#: Default radius (m) within which a goal inside an obstacle snaps to a free cell.
GOAL_TOLERANCE = 0.5
#: Default spacing (m) of the controller's waypoints.
WAYPOINT_SPACING = 0.25
#: Default distance (m) from the path beyond which the robot has strayed.
STRAY_DISTANCE = 0.4
#: Default longest climb (m) out of the inflated zone for a start next to a wall.
ESCAPE_DISTANCE = 0.5

#: ``Planner.check`` reasons.
MAP_CHANGED = "map_changed"
OFF_PATH = "off_path"


@dataclass(frozen=True)
class PlannerConfig:
    costmap: CostmapConfig = field(default_factory=CostmapConfig)
    goal_tolerance: float = GOAL_TOLERANCE
    waypoint_spacing: float = WAYPOINT_SPACING
    shortcut_tolerance: float = SHORTCUT_TOLERANCE
    stray_distance: float = STRAY_DISTANCE
    escape_distance: float = ESCAPE_DISTANCE


@dataclass
class Path:
    """A plan. ``waypoints`` ``(n, 2)`` metres from the start cell to the goal cell.

    ``cost`` is the A* cost in metres times weight (``1`` per metre in open
    space), the climb out of an inflated start counted at the highest weight;
    ``vertices`` ``(m, 2)`` metres are the smoothed polyline the waypoints
    subdivide (the first ``escape`` segments climb out of the inflated zone);
    ``cells`` ``(k, 2)`` the raw A* cells ``(ix, iy)`` of the costmap it was
    planned on.
    """

    waypoints: np.ndarray
    cost: float
    vertices: np.ndarray
    cells: np.ndarray
    goal: np.ndarray
    requested_goal: np.ndarray
    snapped: bool
    escape: int
    expansions: int

    @property
    def length(self) -> float:
        return float(np.linalg.norm(np.diff(self.waypoints, axis=0), axis=1).sum())


class CancelToken:
    """A flag a running search polls; ``cancel()`` from any thread stops it."""

    def __init__(self):
        self.flag = new_cancel_flag()

    def cancel(self) -> None:
        self.flag[0] = 1

    @property
    def cancelled(self) -> bool:
        return bool(self.flag[0])


def _escape(costmap: Costmap, start, max_steps: int) -> list:
    """Cells climbing the obstacle-distance field from a lethal ``start`` to a passable cell."""
    ny, nx = costmap.shape
    dist = costmap.distance
    cells = [tuple(start)]
    x, y = start
    for _ in range(max_steps):
        if np.isfinite(costmap.weights[y, x]):
            return cells
        best = None
        best_d = dist[y, x]
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                u, v = x + dx, y + dy
                if (dx or dy) and 0 <= u < nx and 0 <= v < ny and dist[v, u] > best_d:
                    best, best_d = (u, v), dist[v, u]
        if best is None:
            break
        x, y = best
        cells.append(best)
    if np.isfinite(costmap.weights[y, x]):
        return cells
    raise StartBlocked(f"start cell {tuple(start)} is inside an obstacle's inflated zone and no free "
                       f"cell is within {max_steps} cells uphill of it")


def _snap_candidates(costmap: Costmap, goal, radius_cells: float) -> np.ndarray:
    """Passable cells within ``radius_cells`` of ``goal``, nearest first."""
    ny, nx = costmap.shape
    r = int(np.ceil(radius_cells))
    x0, x1 = max(0, goal[0] - r), min(nx, goal[0] + r + 1)
    y0, y1 = max(0, goal[1] - r), min(ny, goal[1] + r + 1)
    ys, xs = np.mgrid[y0:y1, x0:x1]
    d2 = (xs - goal[0]) ** 2 + (ys - goal[1]) ** 2
    ok = (d2 <= radius_cells ** 2) & np.isfinite(costmap.weights[y0:y1, x0:x1])
    order = np.argsort(d2[ok], kind="stable")
    return np.stack((xs[ok], ys[ok]), axis=1)[order]


def _fmt(xy) -> str:
    return f"({xy[0]:.2f}, {xy[1]:.2f})"


def plan_path(costmap: Costmap, start_xy, goal_xy, config: PlannerConfig | None = None,
              cancel: CancelToken | None = None) -> Path:
    """Plan from world point ``start_xy`` to ``goal_xy`` (metres); raises a ``PlanningError``."""
    config = config or PlannerConfig()
    res = costmap.resolution
    start_xy = np.asarray(start_xy, float)[:2]
    goal_xy = np.asarray(goal_xy, float)[:2]
    if not (np.all(np.isfinite(start_xy)) and np.all(np.isfinite(goal_xy))):
        raise ValueError(f"start {start_xy} and goal {goal_xy} must be finite")
    ny, nx = costmap.shape
    x0, y0 = costmap.origin
    extent = f"[{x0:.2f}, {x0 + nx * res:.2f}] x [{y0:.2f}, {y0 + ny * res:.2f}] m"
    start = costmap.world_to_cell(start_xy)
    goal = costmap.world_to_cell(goal_xy)
    if not costmap.contains_cell(*start):
        raise StartOutsideMap(f"start {_fmt(start_xy)} is outside the map {extent}")
    if not costmap.contains_cell(*goal):
        raise GoalOutsideMap(f"goal {_fmt(goal_xy)} is outside the map {extent}")

    escape = [tuple(start)]
    if costmap.lethal[start[1], start[0]]:
        escape = _escape(costmap, tuple(start), int(np.ceil(config.escape_distance / res)))
    search_start = escape[-1]

    if np.isfinite(costmap.weights[goal[1], goal[0]]):
        candidates = goal[None, :]
    elif costmap.unknown[goal[1], goal[0]]:
        raise GoalInUnknown(f"goal {_fmt(goal_xy)} is in unexplored space and unknown space is forbidden")
    else:
        candidates = _snap_candidates(costmap, goal, config.goal_tolerance / res)
        if len(candidates) == 0:
            raise GoalInObstacle(f"goal {_fmt(goal_xy)} is inside an obstacle (or closer to one than the "
                                 f"robot radius) with no free cell within {config.goal_tolerance} m")
    cancel = cancel or CancelToken()
    result = astar(costmap, search_start, candidates[0], cancel=cancel.flag)
    if result.cancelled:
        raise PlanCancelled("planning was cancelled")
    if not result.found:
        reachable = result.reachable()
        usable = candidates[reachable[candidates[:, 1], candidates[:, 0]]] if len(candidates) > 1 else []
        if len(usable) == 0:
            if len(candidates) > 1:
                raise GoalInObstacle(f"goal {_fmt(goal_xy)} is inside an obstacle and no free cell within "
                                     f"{config.goal_tolerance} m of it is reachable from the start")
            raise GoalUnreachable(f"goal {_fmt(goal_xy)} is blocked: no passable route from the start "
                                  f"{_fmt(start_xy)} reaches it")
        result = astar(costmap, search_start, usable[0], cancel=cancel.flag)
        if result.cancelled:
            raise PlanCancelled("planning was cancelled")
    end = result.cells[-1]

    escape_cells = np.array(escape[:-1], np.int64).reshape(-1, 2)
    climb = np.linalg.norm(np.diff(np.array(escape, float), axis=0), axis=1).sum() if len(escape) > 1 else 0.0
    smoothed = shortcut_path(costmap.weights, result.cells, config.shortcut_tolerance)
    vertices = costmap.cell_to_world(np.concatenate((escape_cells, smoothed)))
    waypoints = resample(vertices, config.waypoint_spacing)
    return Path(
        waypoints=waypoints,
        cost=(result.cost + climb * (1.0 + config.costmap.max_cost)) * res,
        vertices=vertices,
        cells=np.concatenate((escape_cells, result.cells)),
        goal=costmap.cell_to_world(end),
        requested_goal=goal_xy,
        snapped=bool(end[0] != goal[0] or end[1] != goal[1]),
        escape=len(escape_cells),
        expansions=result.expansions,
    )


def distance_to_polyline(point, vertices: np.ndarray) -> float:
    """Euclidean distance from ``point`` to the polyline through ``vertices``."""
    p = np.asarray(point, float)[:2]
    v = np.asarray(vertices, float)
    if len(v) == 1:
        return float(np.linalg.norm(p - v[0]))
    a, b = v[:-1], v[1:]
    ab = b - a
    denom = np.maximum((ab * ab).sum(axis=1), 1e-300)
    t = np.clip(((p - a) * ab).sum(axis=1) / denom, 0.0, 1.0)
    return float(np.min(np.linalg.norm(a + t[:, None] * ab - p, axis=1)))


class Planner:
    """Plans to a goal, keeps the path, replans when needed, cancels on request.

    ``plan(map, start_pose, goal_xy) -> Path`` (``map`` an ``OccupancyGrid`` or a
    ``Costmap``); ``update(map, pose)`` replans to the same goal when
    ``check`` finds the path blocked on the new map or the robot off it;
    ``cancel()`` stops a ``plan`` running in another thread (it raises
    ``PlanCancelled``).
    """

    def __init__(self, config: PlannerConfig | None = None):
        self.config = config or PlannerConfig()
        self.path: Path | None = None
        self.goal: np.ndarray | None = None
        self.last_replan_reason: str | None = None
        self._token = CancelToken()
        self._lock = threading.Lock()

    def costmap(self, grid) -> Costmap:
        if isinstance(grid, Costmap):
            return grid
        if isinstance(grid, OccupancyGrid):
            return build_costmap(grid, self.config.costmap)
        raise TypeError(f"expected an OccupancyGrid or a Costmap, got {type(grid).__name__}")

    def plan(self, grid, start_pose, goal_xy) -> Path:
        """Plan from ``start_pose`` (x, y[, theta]) to ``goal_xy``; the path becomes current."""
        token = CancelToken()
        with self._lock:
            self._token = token
        costmap = self.costmap(grid)
        path = plan_path(costmap, start_pose, goal_xy, self.config, token)
        with self._lock:
            if token.cancelled:
                raise PlanCancelled("planning was cancelled")
            self.goal = np.asarray(goal_xy, float)[:2].copy()
            self.path = path
        return path

    def cancel(self) -> None:
        """Abandon the search in progress (if any) and forget the current goal."""
        with self._lock:
            self._token.cancel()
            self.goal = None
            self.path = None

    def check(self, grid, pose) -> str | None:
        """Why the current path must be replanned (``MAP_CHANGED``, ``OFF_PATH``), or ``None``."""
        if self.path is None:
            return None
        path = self.path
        if distance_to_polyline(pose, path.waypoints) > self.config.stray_distance:
            return OFF_PATH
        costmap = self.costmap(grid)
        ahead = path.vertices[path.escape:]
        # Only the part of the path from the segment nearest the robot on.
        if len(ahead) > 1:
            seg = [distance_to_polyline(pose, ahead[i:i + 2]) for i in range(len(ahead) - 1)]
            ahead = ahead[int(np.argmin(seg)):]
        cells = costmap.world_to_cell(ahead)
        ny, nx = costmap.shape
        if np.any((cells < 0) | (cells >= (nx, ny))):
            return MAP_CHANGED
        if len(cells) == 1:
            return None if np.isfinite(costmap.weights[cells[0, 1], cells[0, 0]]) else MAP_CHANGED
        for a, b in itertools.pairwise(cells):
            if not segment_clear(costmap.weights, a[0], a[1], b[0], b[1]):
                return MAP_CHANGED
        return None

    def update(self, grid, pose) -> Path | None:
        """Replan to the current goal if ``check`` says so; the new path, or ``None`` if kept."""
        if self.goal is None:
            return None
        costmap = self.costmap(grid)
        reason = self.check(costmap, pose)
        if reason is None:
            return None
        self.last_replan_reason = reason
        return self.plan(costmap, pose, self.goal)
