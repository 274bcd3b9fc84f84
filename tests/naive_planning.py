"""Slow, obvious references for the planning tests (independent of slam_core.planning)."""

from __future__ import annotations

import itertools
import math
from fractions import Fraction

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

SQRT2 = math.sqrt(2)
MOVES = [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)]


def move_allowed(weights, x, y, dx, dy, corner_cutting):
    """Can the robot step from (x, y) by (dx, dy)? Both squeezed cells must be passable on a diagonal."""
    ny, nx = weights.shape
    u, v = x + dx, y + dy
    if not (0 <= u < nx and 0 <= v < ny) or not np.isfinite(weights[v, u]):
        return False
    if dx and dy and not corner_cutting:
        return bool(np.isfinite(weights[y, u]) and np.isfinite(weights[v, x]))
    return True


def step_cost(weights, dx, dy, u, v, diagonal_step):
    return (diagonal_step if dx and dy else 1.0) * weights[v, u]


def dijkstra_cost(weights, start, goal, diagonal_step=SQRT2, corner_cutting=False):
    """Cheapest path cost with scipy's Dijkstra on the explicit 8-connected graph."""
    ny, nx = weights.shape
    rows, cols, vals = [], [], []
    for y in range(ny):
        for x in range(nx):
            for dx, dy in MOVES:
                if move_allowed(weights, x, y, dx, dy, corner_cutting):
                    rows.append(y * nx + x)
                    cols.append((y + dy) * nx + x + dx)
                    vals.append(step_cost(weights, dx, dy, x + dx, y + dy, diagonal_step))
    graph = coo_matrix((vals, (rows, cols)), shape=(nx * ny, nx * ny)).tocsr()
    dist = dijkstra(graph, directed=True, indices=start[1] * nx + start[0])
    return float(dist[goal[1] * nx + goal[0]])


def path_cost(weights, cells, diagonal_step=SQRT2, corner_cutting=False):
    """Cost of a cell path under the same rules; ``inf`` if any step is illegal."""
    total = 0.0
    for (x, y), (u, v) in itertools.pairwise(cells):
        dx, dy = int(u - x), int(v - y)
        if max(abs(dx), abs(dy)) != 1 or not move_allowed(weights, x, y, dx, dy, corner_cutting):
            return math.inf
        total += step_cost(weights, dx, dy, u, v, diagonal_step)
    return total


def supercover_reference(x0, y0, x1, y1):
    """Cells whose closed square meets the segment between cell centres, by exact clipping."""
    ax, ay = Fraction(2 * x0 + 1, 2), Fraction(2 * y0 + 1, 2)
    bx, by = Fraction(2 * x1 + 1, 2), Fraction(2 * y1 + 1, 2)
    out = set()
    for ix in range(min(x0, x1) - 1, max(x0, x1) + 2):
        for iy in range(min(y0, y1) - 1, max(y0, y1) + 2):
            lo, hi = Fraction(0), Fraction(1)
            for p, d, cmin in ((ax, bx - ax, ix), (ay, by - ay, iy)):
                if d == 0:
                    if p < cmin or p > cmin + 1:
                        lo, hi = Fraction(1), Fraction(0)
                    continue
                t0, t1 = (cmin - p) / d, (cmin + 1 - p) / d
                lo, hi = max(lo, min(t0, t1)), min(hi, max(t0, t1))
            if lo <= hi:
                out.add((ix, iy))
    return out
