"""The ground-truth occupancy map of a world, rasterised from its exact geometry.

Cells touched by a wall, furniture edge or leg at least ``min_height`` tall
(the lidar's mounting height: what the scan plane can see) are occupied. A
geometry point lying exactly on a cell border marks the cells on both sides,
so a zero-thickness wall is one or two cells thick whatever side it is seen
from. Free cells are those reachable from the start pose by 4-connected steps
through unoccupied cells (the home's floor); everything else (outside the
walls, inside furniture) stays unknown.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from slam_core.occupancy_grid import OccupancyGrid
from slam_core.sim.world import World

#: Geometry is sampled at this fraction of a cell.
SAMPLES_PER_CELL = 4
#: Empty border (m) around the world's bounds.
MAP_MARGIN = 0.5
#: Offset used to find both cells of a point on a border (m).
BORDER_EPS = 1e-7


def _outline_points(world: World, min_height: float, spacing: float) -> np.ndarray:
    segs, circles = world.obstacles(min_height)
    pts = []
    for x1, y1, x2, y2 in segs:
        n = max(2, int(np.ceil(np.hypot(x2 - x1, y2 - y1) / spacing)) + 1)
        s = np.linspace(0.0, 1.0, n)[:, None]
        pts.append(np.hstack([x1 + s * (x2 - x1), y1 + s * (y2 - y1)]))
    for cx, cy, r in circles:
        n = max(8, int(np.ceil(2 * np.pi * r / spacing)))
        a = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
        pts.append(np.column_stack([cx + r * np.cos(a), cy + r * np.sin(a)]))
        pts.append(np.array([[cx, cy]]))
    return np.vstack(pts) if pts else np.zeros((0, 2))


def occupied_mask(world: World, resolution: float, min_height: float = 0.0) -> OccupancyGrid:
    """An empty grid covering the world, and the boolean occupied mask of its cells."""
    xmin, ymin, xmax, ymax = world.bounds()
    res = float(resolution)
    origin = np.floor((np.array([xmin, ymin]) - MAP_MARGIN) / res) * res
    top = np.ceil((np.array([xmax, ymax]) + MAP_MARGIN) / res) * res
    nx, ny = np.round((top - origin) / res).astype(int)
    grid = OccupancyGrid(res, origin, shape=(ny, nx))
    occ = np.zeros((ny, nx), bool)
    pts = _outline_points(world, min_height, res / SAMPLES_PER_CELL)
    for ox in (-BORDER_EPS, BORDER_EPS):
        for oy in (-BORDER_EPS, BORDER_EPS):
            cells = grid.world_to_cell(pts + np.array([ox, oy]))
            ok = (cells[:, 0] >= 0) & (cells[:, 0] < nx) & (cells[:, 1] >= 0) & (cells[:, 1] < ny)
            occ[cells[ok, 1], cells[ok, 0]] = True
    return grid, occ


def ground_truth_map(world: World, resolution: float = 0.05, min_height: float = 0.0) -> OccupancyGrid:
    """The world as an :class:`OccupancyGrid`: occupied geometry, free reachable floor, unknown rest."""
    if not resolution > 0:
        raise ValueError("resolution must be positive")
    grid, occ = occupied_mask(world, resolution, min_height)
    ny, nx = occ.shape
    free = np.zeros_like(occ)
    sx, sy = grid.world_to_cell(world.start[:2])
    if occ[sy, sx]:
        raise ValueError(f"world {world.name!r}: start pose is on an obstacle at {resolution} m per cell")
    free[sy, sx] = True
    queue = deque([(int(sx), int(sy))])
    while queue:
        x, y = queue.popleft()
        for nxx, nyy in ((x + 1, y), (x - 1, y), (x, y + 1), (x, y - 1)):
            if 0 <= nxx < nx and 0 <= nyy < ny and not occ[nyy, nxx] and not free[nyy, nxx]:
                free[nyy, nxx] = True
                queue.append((nxx, nyy))
    m = grid.model
    data = np.zeros(occ.shape, np.float32)
    data[occ] = m.l_max
    data[free] = m.l_min
    grid.data = data
    return grid
