"""No-go zones and virtual walls: a restriction layer on top of the costmap.

A no-go zone is a polygon the robot must not enter; a virtual wall is a segment it must not
cross, however free the map says the floor is. Both are drawn into the costmap's grid (zone:
the cells whose centre lies inside the polygon plus every cell its outline touches; wall: every
cell the segment touches) and then grown by the robot's radius, like real walls, so the robot's
whole body stays out: those cells become lethal. Inside the restricted area the escape field
(``Costmap.distance``) points to the nearest way out.

``restricted_costmap`` applies the layer; ``check_goal`` refuses a goal inside a zone (reason
``goal_in_no_go_zone``); ``exit_point`` is where a robot that finds itself inside the layer
(carried there) leaves it: the nearest passable cell, reached in a straight line.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from slam_core.distance_transform import distance_to_features
from slam_core.planning.costmap import Costmap
from slam_core.planning.errors import PlanningError
from slam_core.planning.line import supercover_cells

#: Vertices of one zone at most (a drawn polygon, not a map).
MAX_VERTICES = 64


class GoalInNoGoZone(PlanningError):
    reason = "goal_in_no_go_zone"


@dataclass(frozen=True)
class NoGoZone:
    """A polygon ``(n, 2)`` in metres (map frame), ``n >= 3``, simple or not (even-odd rule)."""

    points: tuple[tuple[float, float], ...]

    def __post_init__(self):
        if not 3 <= len(self.points) <= MAX_VERTICES:
            raise ValueError(f"a no-go zone needs 3 to {MAX_VERTICES} points, got {len(self.points)}")
        if not np.all(np.isfinite(np.asarray(self.points, float))):
            raise ValueError("zone points must be finite numbers")
        if abs(_area(np.asarray(self.points, float))) < 1e-4:
            raise ValueError("a no-go zone must enclose an area")

    def contains(self, xy) -> np.ndarray:
        """Whether points ``(..., 2)`` lie inside the polygon (even-odd rule)."""
        p = np.asarray(xy, float)
        x, y = p[..., 0], p[..., 1]
        poly = np.asarray(self.points, float)
        inside = np.zeros(x.shape, bool)
        for (x0, y0), (x1, y1) in zip(poly, np.roll(poly, -1, axis=0), strict=True):
            crosses = (y0 > y) != (y1 > y)
            with np.errstate(divide="ignore", invalid="ignore"):
                at = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
            inside ^= crosses & (x < at)
        return inside


@dataclass(frozen=True)
class VirtualWall:
    """A segment from ``a`` to ``b`` (metres, map frame) the robot must not cross."""

    a: tuple[float, float]
    b: tuple[float, float]

    def __post_init__(self):
        if not np.all(np.isfinite(np.asarray([self.a, self.b], float))):
            raise ValueError("virtual wall ends must be finite numbers")
        if np.hypot(self.b[0] - self.a[0], self.b[1] - self.a[1]) < 1e-3:
            raise ValueError("a virtual wall needs two distinct ends")


@dataclass(frozen=True)
class Restrictions:
    zones: tuple[NoGoZone, ...] = ()
    walls: tuple[VirtualWall, ...] = ()

    def __bool__(self) -> bool:
        return bool(self.zones or self.walls)


def _area(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _segment_cells(costmap: Costmap, a, b) -> np.ndarray:
    """Cells ``(m, 2)`` of the supercover of a world segment, clipped to the grid."""
    ca, cb = costmap.world_to_cell(np.asarray(a, float)), costmap.world_to_cell(np.asarray(b, float))
    cells = supercover_cells(int(ca[0]), int(ca[1]), int(cb[0]), int(cb[1]))
    ny, nx = costmap.shape
    ok = (cells[:, 0] >= 0) & (cells[:, 0] < nx) & (cells[:, 1] >= 0) & (cells[:, 1] < ny)
    return cells[ok]


def forbidden_cells(costmap: Costmap, restrictions: Restrictions) -> np.ndarray:
    """Cells covered by a zone or touched by a virtual wall (before growing by the robot's radius)."""
    out = np.zeros(costmap.shape, bool)
    ny, nx = costmap.shape
    for zone in restrictions.zones:
        poly = np.asarray(zone.points, float)
        lo = np.clip(costmap.world_to_cell(poly.min(0)), 0, [nx - 1, ny - 1])
        hi = np.clip(costmap.world_to_cell(poly.max(0)), 0, [nx - 1, ny - 1])
        ys, xs = np.mgrid[lo[1]:hi[1] + 1, lo[0]:hi[0] + 1]
        centres = costmap.cell_to_world(np.stack([xs, ys], -1))
        out[ys, xs] |= zone.contains(centres)
        for a, b in zip(poly, np.roll(poly, -1, axis=0), strict=True):
            cells = _segment_cells(costmap, a, b)
            out[cells[:, 1], cells[:, 0]] = True
    for wall in restrictions.walls:
        cells = _segment_cells(costmap, wall.a, wall.b)
        out[cells[:, 1], cells[:, 0]] = True
    return out


def restricted_costmap(costmap: Costmap, restrictions: Restrictions, robot_radius: float) -> Costmap:
    """``costmap`` with every cell within ``robot_radius`` of a zone or virtual wall lethal."""
    if not restrictions:
        return costmap
    forbidden = forbidden_cells(costmap, restrictions)
    if not forbidden.any():
        return costmap
    res = costmap.resolution
    away = distance_to_features(forbidden) * res
    blocked = away <= robot_radius
    weights = costmap.weights.copy()
    weights[blocked] = np.inf
    # Escape field: distance from the layer outside it, minus the depth inside it, so climbing it
    # leads out by the nearest way.
    depth = distance_to_features(~forbidden) * res
    field = np.where(forbidden, -depth, away)
    distance = np.minimum(costmap.distance, field)
    return Costmap(weights, res, costmap.origin, distance=distance, unknown=costmap.unknown & ~blocked,
                   lethal=costmap.lethal | blocked)


def check_goal(restrictions: Restrictions, goal_xy) -> None:
    """Refuse a goal inside a no-go zone."""
    for i, zone in enumerate(restrictions.zones):
        if zone.contains(np.asarray(goal_xy, float)[:2]):
            raise GoalInNoGoZone(f"goal ({goal_xy[0]:.2f}, {goal_xy[1]:.2f}) is inside no-go zone {i + 1}")


def exit_point(costmap: Costmap, start_xy, unrestricted: Costmap | None = None) -> np.ndarray | None:
    """Where a robot at ``start_xy`` inside the lethal area leaves it: the passable cell it reaches
    by the shortest way (``None`` when the start is passable, or outside the map).

    With ``unrestricted`` (the same costmap before zones and walls were added) the way out goes
    only through cells the map itself lets the robot cross, so it never leads through a real
    wall; without it, the nearest passable cell in a straight line.
    """
    start = costmap.world_to_cell(np.asarray(start_xy, float)[:2])
    if not costmap.contains_cell(*start) or np.isfinite(costmap.weights[start[1], start[0]]):
        return None
    passable = np.isfinite(costmap.weights)
    if not passable.any():
        return None
    if unrestricted is not None:
        cell = _nearest_reachable(passable, np.isfinite(unrestricted.weights), start)
        if cell is not None:
            return costmap.cell_to_world(np.array(cell))
    _, (iy, ix) = ndimage.distance_transform_edt(~passable, return_indices=True)
    return costmap.cell_to_world(np.array([ix[start[1], start[0]], iy[start[1], start[0]]]))


def _nearest_reachable(goal: np.ndarray, walkable: np.ndarray, start) -> tuple[int, int] | None:
    """The first ``goal`` cell met by a breadth-first search from ``start`` (4-connected) that
    steps only on ``walkable`` cells (the start itself may lie anywhere); ``(ix, iy)`` or ``None``."""
    height, width = goal.shape
    seen = np.zeros(goal.shape, dtype=bool)
    seen[start[1], start[0]] = True
    frontier = deque([(int(start[0]), int(start[1]))])
    while frontier:
        ix, iy = frontier.popleft()
        for nx, ny in ((ix + 1, iy), (ix - 1, iy), (ix, iy + 1), (ix, iy - 1)):
            if 0 <= nx < width and 0 <= ny < height and not seen[ny, nx] and walkable[ny, nx]:
                if goal[ny, nx]:
                    return nx, ny
                seen[ny, nx] = True
                frontier.append((nx, ny))
    return None
