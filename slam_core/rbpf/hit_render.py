"""Per-cell hit sums of many scans at once, as the particle filter's own maps keep them.

The filter's maps (:mod:`slam_core.rbpf.tiled_map`) add, for every echo, the endpoint's offset
from its cell's lower-left corner and a count (``HIT_X``, ``HIT_Y``, ``HIT_N``); the scan matcher
aligns to the mean endpoint. A map rendered from other poses (the loop-closing back end's
optimised ones) has no such sums; :func:`add_hit_sums` draws them for every beam of every scan
in one vectorised pass, with the same rules as the filter's kernels: an echo counts when
``range_min <= r < range_max`` and ``r <= usable_range``, in the cell ``floor((end - origin) /
resolution)`` that the ray tracer ends in.
"""

from __future__ import annotations

import numpy as np

from slam_core.rbpf.tiled_map import HIT_N, HIT_X, HIT_Y
from slam_core.scan import Scan


def echo_endpoints(laser_poses: np.ndarray, scans: list[Scan], usable_range: float) -> np.ndarray:
    """World endpoints ``(m, 2)`` of the echoes (beams that mark a cell) of ``scans`` seen from
    ``laser_poses``."""
    if not scans:
        return np.zeros((0, 2))
    counts = np.array([len(s.ranges) for s in scans])
    angles = np.concatenate([s.angles for s in scans]).astype(np.float64)
    ranges = np.concatenate([s.ranges for s in scans]).astype(np.float64)
    range_min = np.repeat([s.range_min for s in scans], counts)
    range_max = np.repeat([s.range_max for s in scans], counts)
    with np.errstate(invalid="ignore"):
        echo = (ranges >= range_min) & (ranges > 0.0) & (ranges < range_max) & (ranges <= usable_range)
    poses = np.asarray(laser_poses, np.float64).reshape(-1, 3)[np.repeat(np.arange(len(scans)), counts)[echo]]
    r, a = ranges[echo], poses[:, 2] + angles[echo]
    return np.column_stack([poses[:, 0] + r * np.cos(a), poses[:, 1] + r * np.sin(a)])


def add_hit_sums(hits: np.ndarray, origin, resolution: float, laser_poses: np.ndarray, scans: list[Scan],
                 usable_range: float) -> int:
    """Add the hit sums of ``scans`` (from ``laser_poses``) to ``hits`` ``(ny, nx, 3)`` (C-contiguous),
    a grid's cells from ``origin``; returns the number of echoes that fell outside it (not added)."""
    if not hits.flags.c_contiguous:
        raise ValueError("hit sums must be one C-contiguous array (they are added in place)")
    ny, nx = hits.shape[:2]
    end = echo_endpoints(laser_poses, scans, usable_range)
    inv = 1.0 / resolution
    ix = np.floor((end[:, 0] - origin[0]) * inv).astype(np.int64)
    iy = np.floor((end[:, 1] - origin[1]) * inv).astype(np.int64)
    inside = (ix >= 0) & (iy >= 0) & (ix < nx) & (iy < ny)
    ix, iy, end = ix[inside], iy[inside], end[inside]
    cell = iy * nx + ix
    flat = hits.reshape(ny * nx, 3)
    for channel, weights in ((HIT_X, end[:, 0] - (origin[0] + ix * resolution)),
                             (HIT_Y, end[:, 1] - (origin[1] + iy * resolution)), (HIT_N, None)):
        flat[:, channel] += np.bincount(cell, weights, minlength=ny * nx).astype(hits.dtype)
    return int(np.count_nonzero(~inside))


def hit_sums_on(grid, laser_poses: np.ndarray, scans: list[Scan], usable_range: float) -> np.ndarray:
    """Fresh hit sums ``(ny, nx, 3)`` of ``scans`` (from ``laser_poses``) on ``grid``'s cells."""
    hits = np.zeros((*grid.shape, 3), np.float32)
    add_hit_sums(hits, grid.origin, grid.resolution, laser_poses, scans, usable_range)
    return hits
