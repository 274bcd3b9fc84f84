"""The known map MCL localizes in: occupied / free cells and the distance to the nearest obstacle."""

from __future__ import annotations

import numpy as np

from slam_core.localization.distance_transform import distance_transform
from slam_core.occupancy_grid import OccupancyGrid

#: trinary() values of the ROS map convention.
OCCUPIED = 100
FREE = 0


class KnownMap:
    """An :class:`OccupancyGrid` prepared for localization.

    ``distance[iy, ix]`` is the Euclidean distance in metres from the centre of a
    cell to the centre of the nearest occupied cell (``inf`` when the map has none).
    """

    def __init__(self, grid: OccupancyGrid):
        if grid.data.ndim != 2 or grid.data.size == 0:
            raise ValueError(f"the map is empty (shape {grid.data.shape}); localization needs a map")
        trinary = grid.trinary()
        self.grid = grid
        self.resolution = grid.resolution
        self.origin = np.array(grid.origin, dtype=np.float64)
        self.occupied = trinary == OCCUPIED
        self.free = trinary == FREE
        if not self.free.any():
            raise ValueError("the map has no free cell: nowhere for the robot to be")
        self.distance = distance_transform(self.occupied, self.resolution).astype(np.float32)
        iy, ix = np.nonzero(self.free)
        self.free_cells = np.column_stack([ix, iy]).astype(np.int64)

    @property
    def shape(self) -> tuple[int, int]:
        return self.occupied.shape

    def free_area(self) -> float:
        """Free area in square metres."""
        return len(self.free_cells) * self.resolution ** 2

    def sample_free_poses(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` poses uniform over the free cells (uniform inside each cell), any heading."""
        cells = self.free_cells[rng.integers(0, len(self.free_cells), n)]
        xy = self.origin + (cells + rng.random((n, 2))) * self.resolution
        theta = rng.uniform(-np.pi, np.pi, n)
        return np.column_stack([xy, theta])

    def is_free(self, xy) -> np.ndarray:
        """Whether world points ``(..., 2)`` lie in free cells (False outside the map)."""
        cells = self.grid.world_to_cell(xy)
        ny, nx = self.shape
        ix, iy = cells[..., 0], cells[..., 1]
        inside = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
        out = np.zeros(inside.shape, bool)
        out[inside] = self.free[iy[inside], ix[inside]]
        return out
