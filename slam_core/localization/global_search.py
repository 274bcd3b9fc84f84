"""Correlative global search: where in the whole map does one scan fit best?

A global start with particles spread uniformly leaves few of them near the true
pose in a large map, and the first scans can pull the cloud onto a look-alike.
This scores the scan at every pose of a lattice over the map's free space (every
``stride`` metres, every ``heading_step``), as a correlative scan matcher does over
a window (Olson 2009): each endpoint scores ``max(0, 1 - D / reach)`` with ``D`` its
distance to the nearest wall, and the search keeps the best-scoring poses, at most
one per lattice position. ``reach`` is wide so that a lattice pose a stride and half a
heading step off the true pose still scores. The localizer seeds its particles around
these poses (Mixture MCL's idea of drawing poses from the measurement).
"""

from __future__ import annotations

import numpy as np
from numba import prange

from slam_core.jit import njit
from slam_core.localization.known_map import KnownMap

#: Endpoints farther than this (m) from a wall score nothing.
REACH = 0.5


@njit(parallel=True)
def _score_lattice(score, origin_x, origin_y, res, xs, ys, headings, bx, by, out_score, out_heading):
    """Best heading and its mean endpoint score at each lattice position."""
    ny, nx = score.shape
    nb = bx.shape[0]
    for i in prange(xs.shape[0]):
        best = -1.0
        best_k = 0
        for k in range(headings.shape[0]):
            c = np.cos(headings[k])
            s = np.sin(headings[k])
            total = 0.0
            for j in range(nb):
                gx = int(np.floor((xs[i] + c * bx[j] - s * by[j] - origin_x) / res))
                gy = int(np.floor((ys[i] + s * bx[j] + c * by[j] - origin_y) / res))
                if gx >= 0 and gy >= 0 and gx < nx and gy < ny:
                    total += score[gy, gx]
            if total > best:
                best = total
                best_k = k
        out_score[i] = best / nb
        out_heading[i] = headings[best_k]


class GlobalSearch:
    """Best poses of a scan over the free space of a :class:`KnownMap`."""

    def __init__(self, known_map: KnownMap, stride: float = 0.25, heading_step: float = np.radians(5.0)):
        self.map = known_map
        self._score = np.maximum(0.0, 1.0 - np.minimum(known_map.distance, REACH) / REACH).astype(np.float32)
        self.stride = stride
        self.heading_step = heading_step
        step = max(1, round(stride / known_map.resolution))
        cells = known_map.free_cells[(known_map.free_cells[:, 0] % step == 0)
                                     & (known_map.free_cells[:, 1] % step == 0)]
        centres = known_map.origin + (cells + 0.5) * known_map.resolution
        self._xs = np.ascontiguousarray(centres[:, 0])
        self._ys = np.ascontiguousarray(centres[:, 1])
        self._headings = np.arange(-np.pi, np.pi, heading_step)

    def best(self, points: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
        """The ``count`` best poses ``(count, 3)`` for endpoints ``(n, 2)`` in the robot frame, best
        first, and their scores (mean endpoint score, 0..1)."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        n = len(self._xs)
        if n == 0 or len(points) == 0:
            return np.zeros((0, 3)), np.zeros(0)
        scores = np.empty(n)
        headings = np.empty(n)
        m = self.map
        _score_lattice(self._score, m.origin[0], m.origin[1], m.resolution, self._xs, self._ys,
                       self._headings, np.ascontiguousarray(points[:, 0]), np.ascontiguousarray(points[:, 1]),
                       scores, headings)
        count = min(count, n)
        top = np.argpartition(-scores, count - 1)[:count]
        top = top[np.argsort(-scores[top])]
        return np.column_stack([self._xs[top], self._ys[top], headings[top]]), scores[top]
