"""Rooms from an occupancy grid: distance-transform segmentation of the free space.

Doors are narrow: the free space, eroded by a growing radius ``r`` (cells farther than ``r``
from any wall or unknown cell, read off an exact Euclidean distance transform), falls apart
into one core per room once ``r`` passes half a door's width (small obstacles such as table
legs are ignored here), while the rooms themselves
(wider than their doors) persist. Starting from the whole free space, a region is split at
the smallest ``r <= max_door_half_width`` where at least two of its eroded pieces are
*significant* (core area >= ``min_core_area`` and wider than the neck by ``min_margin``:
their largest wall distance exceeds ``r + min_margin``), and each piece is split again in
turn. The final cores are the seeds; every free cell joins the seed it reaches first by a
breadth-first walk through free space (a watershed on geodesic distance), so the borders
fall in the doorways. This is the distance-transform method of Bormann et al., "Room
segmentation: survey, implementation, and analysis" (ICRA 2016), with a per-region
threshold instead of one for the whole map.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from slam_core.distance_transform import distance_to_features
from slam_core.jit import njit
from slam_core.occupancy_grid import FREE_THRESH, OccupancyGrid

#: No room: walls, unknown space, free cells no seed reaches.
NO_ROOM = 0


@dataclass(frozen=True)
class SegmentationConfig:
    """Tunables (metres, square metres)."""

    max_door_half_width: float = 0.55
    min_margin: float = 0.2
    min_core_area: float = 0.5
    #: Free space apart from every room and smaller than this (specks, a glimpse) is no room.
    min_room_area: float = 1.0
    radius_step: float = 0.05
    #: Obstacles smaller than this (table legs, plant pots) do not shape rooms.
    max_clutter_area: float = 0.15


def free_space(grid: OccupancyGrid) -> np.ndarray:
    """Cells known to be free (``True``)."""
    return grid.probability() < FREE_THRESH


def segment_rooms(grid: OccupancyGrid, config: SegmentationConfig | None = None) -> np.ndarray:
    """A label per cell, ``data[iy, ix]`` like the grid: ``1..n`` rooms, :data:`NO_ROOM` elsewhere.

    Labels are numbered by the room's lowest cell index (bottom row first), so the same map
    always gives the same labels.
    """
    config = config or SegmentationConfig()
    free = free_space(grid)
    if not free.any():
        return np.zeros(free.shape, np.int32)
    res = grid.resolution
    clearance = distance_to_features(_walls(~free, config.max_clutter_area / (res * res))) * res
    seeds = np.zeros(free.shape, np.int32)
    count = 0
    labels, _ = ndimage.label(free)
    stack = [(labels[box] == i + 1, box, 0.0) for i, box in enumerate(ndimage.find_objects(labels))]
    while stack:
        region, box, radius = stack.pop()
        pieces = _split(region, box, clearance[box], radius, config, res)
        if pieces is None and radius == 0.0 and region.sum() * res * res < config.min_room_area:
            continue
        if pieces is None:
            count += 1
            seeds[box][region] = count
        else:
            stack.extend(pieces)
    rooms = _grow(seeds, free)
    return _renumber(rooms)


def _walls(blocked: np.ndarray, max_clutter_cells: float) -> np.ndarray:
    """``blocked`` without its small islands (8-connected pieces of at most ``max_clutter_cells``)."""
    labels, n = ndimage.label(blocked, structure=np.ones((3, 3), bool))
    if n == 0:
        return blocked
    sizes = np.bincount(labels.ravel(), minlength=n + 1)
    keep = sizes > max_clutter_cells
    keep[0] = False
    return keep[labels]


def _split(region: np.ndarray, box: tuple[slice, slice], clearance: np.ndarray, radius: float,
           config: SegmentationConfig, res: float):
    """The significant pieces of ``region`` at the smallest radius that gives two, or ``None``."""
    min_cells = config.min_core_area / (res * res)
    r = radius + config.radius_step
    while r <= config.max_door_half_width + 1e-9:
        labels, n = ndimage.label(region & (clearance > r))
        if n == 0:
            return None
        boxes = ndimage.find_objects(labels)
        pieces = []
        for i, inner in enumerate(boxes):
            piece = labels[inner] == i + 1
            if piece.sum() >= min_cells and clearance[inner][piece].max() > r + config.min_margin:
                pieces.append((piece, inner))
        if len(pieces) >= 2:
            return [(piece, _within(box, inner), r) for piece, inner in pieces]
        r += config.radius_step
    return None


def _within(outer: tuple[slice, slice], inner: tuple[slice, slice]) -> tuple[slice, slice]:
    """The grid slices of ``inner``, given relative to the crop ``outer``."""
    return tuple(slice(o.start + i.start, o.start + i.stop) for o, i in zip(outer, inner, strict=True))


@njit
def _grow_kernel(labels, free):
    """Breadth-first growth of the labelled cells through free cells (4-connected)."""
    ny, nx = labels.shape
    queue = np.empty(ny * nx, np.int64)
    head = 0
    tail = 0
    for iy in range(ny):
        for ix in range(nx):
            if labels[iy, ix] != 0:
                queue[tail] = iy * nx + ix
                tail += 1
    while head < tail:
        cell = queue[head]
        head += 1
        iy = cell // nx
        ix = cell % nx
        label = labels[iy, ix]
        for dy, dx in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            y = iy + dy
            x = ix + dx
            if 0 <= y < ny and 0 <= x < nx and free[y, x] and labels[y, x] == 0:
                labels[y, x] = label
                queue[tail] = y * nx + x
                tail += 1
    return labels


def _grow(seeds: np.ndarray, free: np.ndarray) -> np.ndarray:
    return _grow_kernel(seeds.copy(), np.ascontiguousarray(free))


def _renumber(rooms: np.ndarray) -> np.ndarray:
    flat = rooms.ravel()
    present = flat != NO_ROOM
    order = np.unique(flat[present], return_index=True)
    labels, first = order
    ranked = labels[np.argsort(first)]
    mapping = np.zeros(int(rooms.max()) + 1, np.int32)
    mapping[ranked] = np.arange(1, len(ranked) + 1, dtype=np.int32)
    return mapping[rooms]
