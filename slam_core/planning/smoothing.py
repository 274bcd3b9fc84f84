"""Line-of-sight shortcutting of an A* cell path, and waypoints for the controller.

Costs here are line integrals of the weight, ``C(segment) = integral of w ds``,
estimated by sampling the weight at the midpoints of ``ceil(length /
SAMPLE_STEP)`` equal pieces (cell units). Walking the path greedily from an
anchor vertex ``i``, the next kept vertex is the farthest ``j`` such that every
vertex up to it can be reached by a straight segment ``i -> j`` that

* crosses no impassable cell (every cell of its supercover, :mod:`.line`, has
  a finite weight), and
* costs at most ``(1 + tolerance) * C(path i..j)``, the same integral along
  the A* polyline it replaces.

So the smoothed path never crosses an obstacle and its cost is at most
``(1 + tolerance)`` times that of the A* polyline (each replaced piece obeys
the bound, and the pieces partition the path).
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from slam_core.jit import njit
from slam_core.planning.line import segment_clear

#: Spacing (cells) of the weight samples of the line integral.
SAMPLE_STEP = 0.25
#: Default allowed relative cost increase of a shortcut.
SHORTCUT_TOLERANCE = 0.01


@njit
def _segment_cost(weights, x0, y0, x1, y1):
    """Sampled ``integral of w ds`` from cell centre ``(x0, y0)`` to ``(x1, y1)``."""
    dx = x1 - x0
    dy = y1 - y0
    length = math.sqrt(dx * dx + dy * dy)
    if length == 0.0:
        return 0.0
    k = max(1, math.ceil(length / SAMPLE_STEP))
    total = 0.0
    for j in range(k):
        t = (j + 0.5) / k
        ix = math.floor(x0 + 0.5 + t * dx)
        iy = math.floor(y0 + 0.5 + t * dy)
        total += weights[iy, ix]
    return total * length / k


@njit
def _shortcut(weights, cells, tolerance):
    n = cells.shape[0]
    prefix = np.zeros(n)
    for i in range(1, n):
        prefix[i] = prefix[i - 1] + _segment_cost(weights, cells[i - 1, 0], cells[i - 1, 1],
                                                  cells[i, 0], cells[i, 1])
    keep = np.empty(n, np.int64)
    keep[0] = 0
    m = 1
    i = 0
    while i < n - 1:
        best = i + 1
        for j in range(i + 2, n):
            x0 = cells[i, 0]
            y0 = cells[i, 1]
            x1 = cells[j, 0]
            y1 = cells[j, 1]
            if not segment_clear(weights, x0, y0, x1, y1):
                break
            if _segment_cost(weights, x0, y0, x1, y1) > (1.0 + tolerance) * (prefix[j] - prefix[i]):
                break
            best = j
        keep[m] = best
        m += 1
        i = best
    return keep[:m]


def polyline_cost(weights: np.ndarray, cells: np.ndarray) -> float:
    """Sampled line-integral cost (cell units) of the polyline through cell centres ``cells``."""
    cells = np.asarray(cells, np.int64)
    return float(sum(_segment_cost(weights, *cells[i - 1], *cells[i]) for i in range(1, len(cells))))


def shortcut_path(weights: np.ndarray, cells: np.ndarray,
                  tolerance: float = SHORTCUT_TOLERANCE) -> np.ndarray:
    """The vertices of ``cells`` (``(n, 2)`` of ``(ix, iy)``) kept after line-of-sight shortcutting."""
    cells = np.ascontiguousarray(cells, dtype=np.int64)
    if cells.ndim != 2 or cells.shape[1] != 2:
        raise ValueError(f"cells must have shape (n, 2), got {cells.shape}")
    if tolerance < 0:
        raise ValueError(f"tolerance must be >= 0, got {tolerance}")
    if len(cells) < 3:
        return cells.copy()
    weights = np.asarray(weights, dtype=np.float64)
    ny, nx = weights.shape
    if cells.min() < 0 or cells[:, 0].max() >= nx or cells[:, 1].max() >= ny:
        raise ValueError("cells outside the weight grid")
    return cells[_shortcut(weights, cells, float(tolerance))]


def resample(points: np.ndarray, spacing: float) -> np.ndarray:
    """Every vertex of the polyline ``points`` plus evenly spaced points, no gap above ``spacing``."""
    points = np.asarray(points, dtype=np.float64)
    if spacing <= 0:
        raise ValueError(f"waypoint spacing must be positive, got {spacing}")
    if len(points) < 2:
        return points.copy()
    out = [points[:1]]
    for a, b in itertools.pairwise(points):
        pieces = max(1, math.ceil(float(np.linalg.norm(b - a)) / spacing - 1e-9))
        t = np.arange(1, pieces + 1)[:, None] / pieces
        out.append(a + t * (b - a))
    return np.concatenate(out)
