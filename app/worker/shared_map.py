"""The published map in shared memory, with a per-tile change stamp, so no step pickles the map.

Layout of the one block (``multiprocessing.shared_memory``):

- header, ``float64[HEADER_FIELDS]``: write counter (odd while writing: a seqlock),
  map sequence, layout epoch, width, height, origin x, origin y, resolution;
- ``uint64`` stamps, one per tile: the map sequence at which the tile last changed;
- ``uint8`` cells, row-major ``(height, width)``: 0..100 occupancy percent, 255 unknown.

One writer (the worker) and any number of readers (the server). A seqlock rather
than a lock: a worker killed mid-write cannot leave a lock held; readers retry and
the restarted worker rewrites the whole map.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from multiprocessing import shared_memory

import numpy as np

from slam_core.occupancy_grid import OccupancyGrid

UNKNOWN = 255
HEADER_FIELDS = 8
_WRITES, _SEQ, _EPOCH, _WIDTH, _HEIGHT, _OX, _OY, _RES = range(HEADER_FIELDS)
#: Longest side, in cells, the shared map accepts.
MAX_SIDE = 8192
READ_RETRIES = 200


class MapTooLarge(ValueError):
    """The estimator's map outgrew the shared block (raise ``map_capacity_cells``)."""


def grid_cells(grid: OccupancyGrid) -> np.ndarray:
    """``uint8`` cells of a grid: occupancy percent, :data:`UNKNOWN` where never observed (converted a
    block of rows at a time: no whole-map float64 temporaries)."""
    cells = np.empty(grid.shape, np.uint8)
    for rows in grid.row_blocks():
        block = cells[rows]
        np.rint(grid.probability(rows) * 100.0, out=block, casting="unsafe")
        block[grid.data[rows] == 0.0] = UNKNOWN
    return cells


def _cell_logodds() -> np.ndarray:
    """Log-odds of each ``uint8`` cell value (percent clipped to 1..99; :data:`UNKNOWN`: 0)."""
    p = np.clip(np.arange(256) / 100.0, 0.01, 0.99)
    table = np.log(p / (1.0 - p)).astype(np.float32)
    table[UNKNOWN] = 0.0
    return table


#: Looked up per cell: no whole-map float64 temporary when the server rebuilds a large map.
_CELL_LOGODDS = _cell_logodds()


def tile_count(width: int, height: int, tile: int) -> tuple[int, int]:
    return math.ceil(width / tile), math.ceil(height / tile)


@dataclass(frozen=True)
class MapSnapshot:
    """A consistent copy of the shared map."""

    seq: int
    epoch: int
    width: int
    height: int
    origin: tuple[float, float]
    resolution: float
    cells: np.ndarray  # (height, width) uint8
    stamps: np.ndarray  # (tiles_y * tiles_x,) uint64

    def grid(self) -> OccupancyGrid:
        """The map as an :class:`OccupancyGrid` (log-odds rebuilt from the percentages)."""
        return OccupancyGrid(self.resolution, self.origin, data=_CELL_LOGODDS[self.cells])


class SharedMap:
    """Create (``create=True``, the server) or attach to (the worker) the shared map block."""

    def __init__(self, capacity_cells: int, tile: int, name: str | None = None, create: bool = False):
        self.capacity = int(capacity_cells)
        self.tile = int(tile)
        self.max_tiles = self.capacity // (self.tile * self.tile) + 2 * (MAX_SIDE // self.tile) + 1
        size = HEADER_FIELDS * 8 + self.max_tiles * 8 + self.capacity
        self.shm = shared_memory.SharedMemory(name=name, create=create, size=size if create else 0)
        buf = self.shm.buf
        self.header = np.ndarray((HEADER_FIELDS,), np.float64, buf, 0)
        self.stamps = np.ndarray((self.max_tiles,), np.uint64, buf, HEADER_FIELDS * 8)
        self.cells = np.ndarray((self.capacity,), np.uint8, buf, HEADER_FIELDS * 8 + self.max_tiles * 8)
        if create:
            self.header[:] = 0.0
            self.header[_RES] = 0.05

    @property
    def name(self) -> str:
        return self.shm.name

    @property
    def seq(self) -> int:
        return int(self.header[_SEQ])

    # writer
    def publish(self, cells: np.ndarray, origin, resolution: float, force_full: bool = False) -> int:
        """Write ``cells`` (``(h, w)`` uint8); stamp the tiles that changed; return the map sequence."""
        h, w = cells.shape
        if h * w > self.capacity or max(h, w) > MAX_SIDE:
            raise MapTooLarge(f"map {w}x{h} cells exceeds the shared capacity {self.capacity} cells")
        hdr = self.header
        ox, oy = float(origin[0]), float(origin[1])
        relayout = (force_full or int(hdr[_WIDTH]) != w or int(hdr[_HEIGHT]) != h
                    or hdr[_OX] != ox or hdr[_OY] != oy or hdr[_RES] != resolution or hdr[_SEQ] == 0)
        current = self.cells[: h * w].reshape(h, w)
        t = self.tile
        tx, ty = tile_count(w, h, t)
        if relayout:
            changed = None
        else:
            diff = current != cells
            padded = np.zeros((ty * t, tx * t), bool)
            padded[:h, :w] = diff
            changed = padded.reshape(ty, t, tx, t).any(axis=(1, 3)).ravel()
            if not changed.any():
                return int(hdr[_SEQ])
        seq = int(hdr[_SEQ]) + 1
        hdr[_WRITES] += 1  # odd: writing
        if relayout:
            hdr[_EPOCH] += 1
            hdr[_WIDTH], hdr[_HEIGHT], hdr[_OX], hdr[_OY], hdr[_RES] = w, h, ox, oy, resolution
            self.cells[: h * w] = cells.ravel()
            self.stamps[: tx * ty] = seq
        else:
            idx = np.flatnonzero(changed)
            for i in idx:
                y0, x0 = (i // tx) * t, (i % tx) * t
                current[y0:y0 + t, x0:x0 + t] = cells[y0:y0 + t, x0:x0 + t]
            self.stamps[idx] = seq
        hdr[_SEQ] = seq
        hdr[_WRITES] += 1  # even: done
        return seq

    # reader
    def snapshot(self) -> MapSnapshot | None:
        """A consistent copy, or ``None`` when nothing was published (or a writer died mid-write)."""
        hdr = self.header
        for _ in range(READ_RETRIES):
            before = hdr[_WRITES]
            if int(before) % 2:
                time.sleep(0.001)
                continue
            w, h = int(hdr[_WIDTH]), int(hdr[_HEIGHT])
            seq, epoch = int(hdr[_SEQ]), int(hdr[_EPOCH])
            origin, res = (float(hdr[_OX]), float(hdr[_OY])), float(hdr[_RES])
            tx, ty = tile_count(w, h, self.tile)
            cells = self.cells[: h * w].reshape(h, w).copy()
            stamps = self.stamps[: tx * ty].copy()
            if hdr[_WRITES] == before:
                if seq == 0:
                    return None
                return MapSnapshot(seq, epoch, w, h, origin, res, cells, stamps)
        return None

    def close(self) -> None:
        self.header = self.stamps = self.cells = None
        self.shm.close()

    def unlink(self) -> None:
        self.shm.unlink()

