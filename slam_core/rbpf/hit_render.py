"""Per-cell hit sums of many scans at once, as the particle filter's own maps keep them.

The filter's maps (:mod:`slam_core.rbpf.tiled_map`) add, for every echo, the endpoint's offset
from its cell's lower-left corner and a count (``HIT_X``, ``HIT_Y``, ``HIT_N``); the scan matcher
aligns to the mean endpoint. A map rendered from other poses (the loop-closing back end's
optimised ones) has no such sums; :func:`add_hit_sums` draws them for every beam of every scan
in one vectorised pass, with the same rules as the filter's kernels: an echo counts when
``range_min <= r < range_max`` and ``r`` within its scan's reach, in the cell ``floor((end - origin) /
resolution)`` that the ray tracer ends in.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam_core.occupancy_grid import SensorModel
from slam_core.rbpf.tiled_map import HIT_N, HIT_X, HIT_Y
from slam_core.scan import Scan


def echo_endpoints(laser_poses: np.ndarray, scans: list[Scan], model: SensorModel) -> np.ndarray:
    """World endpoints ``(m, 2)`` of the echoes (beams that mark a cell, within the sensor
    ``model``'s :meth:`~slam_core.occupancy_grid.SensorModel.reach` of their scan) of ``scans``
    seen from ``laser_poses``."""
    if not scans:
        return np.zeros((0, 2))
    counts = np.array([len(s.ranges) for s in scans])
    angles = np.concatenate([s.angles for s in scans]).astype(np.float64)
    ranges = np.concatenate([s.ranges for s in scans]).astype(np.float64)
    range_min = np.repeat([s.range_min for s in scans], counts)
    range_max = np.repeat([s.range_max for s in scans], counts)
    usable_range = np.repeat([model.reach(s) for s in scans], counts)
    with np.errstate(invalid="ignore"):
        echo = (ranges >= range_min) & (ranges > 0.0) & (ranges < range_max) & (ranges <= usable_range)
    poses = np.asarray(laser_poses, np.float64).reshape(-1, 3)[np.repeat(np.arange(len(scans)), counts)[echo]]
    r, a = ranges[echo], poses[:, 2] + angles[echo]
    return np.column_stack([poses[:, 0] + r * np.cos(a), poses[:, 1] + r * np.sin(a)])


def add_hit_sums(hits: np.ndarray, origin, resolution: float, laser_poses: np.ndarray, scans: list[Scan],
                 model: SensorModel) -> int:
    """Add the hit sums of ``scans`` (from ``laser_poses``) to ``hits`` ``(ny, nx, 3)`` (C-contiguous),
    a grid's cells from ``origin``; returns the number of echoes that fell outside it (not added)."""
    if not hits.flags.c_contiguous:
        raise ValueError("hit sums must be one C-contiguous array (they are added in place)")
    ny, nx = hits.shape[:2]
    end = echo_endpoints(laser_poses, scans, model)
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


def hit_sums_on(grid, laser_poses: np.ndarray, scans: list[Scan], model: SensorModel) -> np.ndarray:
    """Fresh hit sums ``(ny, nx, 3)`` of ``scans`` (from ``laser_poses``) on ``grid``'s cells."""
    hits = np.zeros((*grid.shape, 3), np.float32)
    add_hit_sums(hits, grid.origin, grid.resolution, laser_poses, scans, model)
    return hits


@dataclass(frozen=True)
class SparseHits:
    """Hit sums of the cells an echo fell into: ``cells`` (flat indices) into a grid of
    ``shape`` whose cell ``(0, 0)`` has its lower-left corner at ``origin``, and their sums
    ``values`` ``(m, 3)`` (``HIT_*``). ``ValueError`` for cells outside ``shape`` or unpaired arrays."""

    origin: np.ndarray
    shape: tuple[int, int]
    cells: np.ndarray
    values: np.ndarray

    def __post_init__(self):
        cells, values = np.asarray(self.cells), np.asarray(self.values)
        shape = tuple(int(v) for v in self.shape)
        if len(shape) != 2 or min(shape) < 0:
            raise ValueError(f"hit sums on a grid of shape {self.shape}")
        if cells.ndim != 1 or values.shape != (len(cells), 3) or not np.issubdtype(cells.dtype, np.integer):
            raise ValueError(f"hit cells {cells.shape} and values {values.shape} do not pair")
        if len(cells) and (cells.min() < 0 or cells.max() >= shape[0] * shape[1]):
            raise ValueError("hit cells outside the map")
        object.__setattr__(self, "origin", np.array(self.origin, float).reshape(2))
        object.__setattr__(self, "shape", shape)
        object.__setattr__(self, "cells", cells.astype(np.int64))
        object.__setattr__(self, "values", values.astype(np.float32))

    @classmethod
    def from_dense(cls, hits: np.ndarray, origin) -> SparseHits:
        """The cells of dense sums ``(ny, nx, 3)`` that hold a count."""
        flat = hits.reshape(-1, 3)
        cells = np.flatnonzero(flat[:, HIT_N])
        return cls(origin, hits.shape[:2], cells, flat[cells])

    @classmethod
    def of_echoes(cls, origin, shape, resolution: float, ends: np.ndarray) -> SparseHits:
        """The sums of echo endpoints ``ends`` ``(m, 2)`` (those outside the grid left out)."""
        origin = np.asarray(origin, float)
        cell = np.floor((ends - origin) * (1.0 / resolution)).astype(np.int64)  # as the kernels do
        inside = np.all((cell >= 0) & (cell < np.array(shape[::-1])), axis=1)
        cell, ends = cell[inside], ends[inside]
        offsets = ends - (origin + cell * resolution)
        flat = cell[:, 1] * shape[1] + cell[:, 0]
        return cls.summed(origin, shape, flat, np.column_stack([offsets, np.ones(len(flat))]))

    @classmethod
    def summed(cls, origin, shape, flat: np.ndarray, values: np.ndarray) -> SparseHits:
        """Sums ``values`` of the same cell of ``flat`` (in any order, repeated) added up."""
        cells, index = np.unique(flat, return_inverse=True)
        sums = np.column_stack([np.bincount(index, values[:, c], len(cells)) for c in range(3)])
        return cls(origin, shape, cells, sums.reshape(-1, 3))

    def fits(self, grid) -> bool:
        """Whether these are sums on ``grid``'s cells (its shape and origin)."""
        return self.shape == grid.shape and bool(np.allclose(self.origin, grid.origin))

    def dense(self) -> np.ndarray:
        """The sums as one ``(ny, nx, 3)`` array (to seed a filter's maps)."""
        hits = np.zeros((self.shape[0] * self.shape[1], 3), np.float32)
        hits[self.cells] = self.values
        return hits.reshape(*self.shape, 3)

    def on(self, origin, shape, resolution: float) -> SparseHits:
        """The same sums on a grid that holds this one (same lattice, ``origin`` and ``shape``)."""
        x, y = np.round((self.origin - np.asarray(origin, float)) / resolution).astype(np.int64)
        ny, nx = self.shape
        if x < 0 or y < 0 or x + nx > shape[1] or y + ny > shape[0]:
            raise ValueError(f"hit sums of {self.shape} at {self.origin} do not fit a {shape} grid at "
                             f"{origin}")
        cells = (self.cells // nx + y) * shape[1] + self.cells % nx + x
        return SparseHits(origin, shape, cells, self.values)

    def plus(self, other: SparseHits) -> SparseHits:
        """The sums of both (on the same grid)."""
        if self.shape != other.shape or not np.allclose(self.origin, other.origin):
            raise ValueError("hit sums of different grids")
        flat = np.concatenate([self.cells, other.cells])
        return self.summed(self.origin, self.shape, flat,
                            np.vstack([self.values, other.values]).astype(np.float64))


def sparse_hit_sums(grid, laser_poses: np.ndarray, scans: list[Scan], model: SensorModel) -> SparseHits:
    """:func:`hit_sums_on`, sparse: the hit sums of ``scans`` (from ``laser_poses``) on ``grid``'s cells."""
    return SparseHits.of_echoes(grid.origin, grid.shape, grid.resolution,
                                echo_endpoints(laser_poses, scans, model))
