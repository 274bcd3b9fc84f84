"""The final map of a finished log, counted a band of rows at a time: no whole-map array is ever held.

:class:`MapBands` has the cells of :meth:`slam_core.count_map.CountMap.grid` for the same updates
(origin, shape and values): each submap is traced once for the map's bounds, then, for every band of
rows, its beams that reach the band are traced again, from the submap's own corner as
:class:`~slam_core.count_map.SubmapCounts` traces them (so every ray crosses the same cells), and
their counts added into the band, which then becomes clamped log-odds. The map files are written
from :meth:`MapBands.bands` (:mod:`slam_core.io.ros_map`, :mod:`slam_core.io.render`).
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from slam_core.count_map import SubmapCounts, _reach, clamped_log_odds, scan_limits
from slam_core.jit import njit
from slam_core.occupancy_grid import GROW_CHUNK, OccupancyGrid, SensorModel
from slam_core.raycast import FAR_TAIL, beam_endpoint, cleared_cells, far_gap, ray_buffer_size, trace_ray
from slam_core.scan import Scan

#: Cells counted at a time (8 bytes each, and a float64 probability each while written).
BAND_CELLS = 1 << 21


@njit
def _count_band(occupied, free, row0, col0, ix0, iy0, nx, ny, inv, poses, angles, ranges, offsets, limits,
                near_range, no_return_range, echo_margin):
    """Add the observations of scan ``s`` (beams ``offsets[s]:offsets[s + 1]`` from laser pose
    ``poses[s]``), traced as ``count_map._count_beams`` traces them into ``ny`` x ``nx`` cells from the
    absolute cell ``(ix0, iy0)``, to the band ``occupied`` / ``free`` whose cell ``[0, 0]`` is the
    absolute cell ``(col0, row0)``; cells outside the band are left out, and beams whose rows all are."""
    buf = np.empty((ray_buffer_size(limits[:, 2].max(), 1.0 / inv), 2), dtype=np.int64)
    rows = occupied.shape[0]
    first, last = row0 - iy0, row0 - iy0 + rows - 1  # the band's rows, from the corner
    low, high = max(first, 0), min(last, ny - 1)  # ... that the traced cells hold
    for s in range(poses.shape[0]):
        px, py, pth = poses[s, 0], poses[s, 1], poses[s, 2]
        gx0, gy0 = px * inv - ix0, py * inv - iy0
        for b in range(offsets[s], offsets[s + 1]):
            use, hit, ex, ey = beam_endpoint(px, py, pth, angles[b], ranges[b], limits[s, 0], limits[s, 1],
                                             limits[s, 2], no_return_range)
            if not use:
                continue
            gy1 = ey * inv - iy0
            a, z = int(np.floor(gy0)), int(np.floor(gy1))  # a ray's cells stay within its ends' rows
            if max(a, z) < first or min(a, z) > last:
                continue
            gx1 = ex * inv - ix0
            n = trace_ray(gx0, gy0, gx1, gy1, buf)
            cleared = cleared_cells(buf, n, hit, gx1, gy1, echo_margin * inv)
            gap_lo, gap_hi = far_gap(buf, n, hit, gx0, gy0, gx1, gy1, limits[s, 2], near_range, FAR_TAIL, inv)
            for k in range(n):
                cx, cy = buf[k, 0], buf[k, 1]
                if (cx < 0 or cx >= nx or cy < low or cy > high or cleared <= k < n - 1
                        or (gap_lo < gap_hi and gap_lo <= k < gap_hi)):
                    continue
                if hit and k == n - 1:
                    occupied[cy - first, cx + ix0 - col0] += 1
                else:
                    free[cy - first, cx + ix0 - col0] += 1


@njit
def _to_log_odds(occupied, free, l_occ, l_free, l_min, l_max):
    """In place: the counts in ``occupied`` become the cells' clamped log-odds, rounded to float32 as
    :meth:`~slam_core.count_map.CountMap.grid` has them."""
    for iy in range(occupied.shape[0]):
        for ix in range(occupied.shape[1]):
            occupied[iy, ix] = clamped_log_odds(occupied[iy, ix], free[iy, ix], l_occ, l_free, l_min, l_max)


class MapBands:
    """The map of ``scans`` seen from ``laser_poses``, traced by blocks of ``submap_updates`` (see the
    module); ``band_cells`` bounds the cells counted at a time."""

    def __init__(self, laser_poses: np.ndarray, scans: list[Scan], resolution: float, model: SensorModel,
                 submap_updates: int, band_cells: int = BAND_CELLS):
        laser_poses = np.asarray(laser_poses, np.float64).reshape(-1, 3)
        if len(laser_poses) != len(scans):
            raise ValueError(f"{len(laser_poses)} poses for {len(scans)} scans")
        self.resolution, self.model, self.band_cells = float(resolution), model, band_cells
        self._blocks = []  # (poses, scans, their limits, the rows its cells span) of every submap that
        # touched a cell
        lows, highs = [], []
        for first in range(0, len(scans), submap_updates):
            block = slice(first, first + submap_updates)
            submap = SubmapCounts.trace(laser_poses[block], scans[block], resolution, model)
            if len(submap.cells):
                limits = scan_limits(scans[block], model)
                self._blocks.append((submap.poses, scans[block], limits, submap.lo[1], submap.hi[1]))
                lows.append(submap.lo)
                highs.append(submap.hi)
        if lows:  # as CountMap's box grows
            self.corner = np.floor_divide(np.min(lows, axis=0), GROW_CHUNK) * GROW_CHUNK
            nx, ny = (np.floor_divide(np.max(highs, axis=0), GROW_CHUNK) + 1) * GROW_CHUNK - self.corner
        else:
            self.corner, nx, ny = np.zeros(2, np.int64), 0, 0
        self.shape = (int(ny), int(nx))
        self.origin = self.corner * self.resolution

    def world_to_cell(self, xy) -> np.ndarray:
        """Integer cell indices ``(ix, iy)`` of world points ``(..., 2)``, as the map's grid has them."""
        return np.floor((np.asarray(xy, float) - self.origin) / self.resolution).astype(np.int64)

    def bands(self) -> Iterator[tuple[slice, np.ndarray]]:
        """``(rows, log_odds)``: the map's rows a band at a time, from the top (largest y) down (float32)."""
        ny, nx = self.shape
        height = max(1, self.band_cells // max(nx, 1))
        for top in range(ny, 0, -height):
            rows = slice(max(0, top - height), top)
            yield rows, self._band(rows)

    def _band(self, rows: slice) -> np.ndarray:
        m, inv = self.model, 1.0 / self.resolution
        occupied = np.zeros((rows.stop - rows.start, self.shape[1]), np.float32)
        free = np.zeros(occupied.shape, np.int32)
        row0, col0 = self.corner[1] + rows.start, self.corner[0]
        for poses, scans, limits, low, high in self._blocks:
            if high < row0 or low >= row0 + occupied.shape[0]:
                continue
            ix0, iy0, ix1, iy1 = _reach(poses, scans, limits, m, inv)
            offsets = np.concatenate([[0], np.cumsum([len(s) for s in scans])]).astype(np.int64)
            _count_band(occupied, free, row0, col0, ix0, iy0, ix1 - ix0 + 1, iy1 - iy0 + 1, inv, poses,
                        np.concatenate([s.angles for s in scans]), np.concatenate([s.ranges for s in scans]),
                        offsets, limits, m.usable_range, m.no_return_range, m.echo_margin)
        _to_log_odds(occupied, free, m.l_occ, m.l_free, m.l_min, m.l_max)
        return occupied

    def grid(self) -> OccupancyGrid:
        """The whole map as one grid (every cell in memory at once)."""
        grid = OccupancyGrid(self.resolution, self.origin, self.shape, self.model)
        for rows, log_odds in self.bands():
            grid.data[rows] = log_odds
        return grid
