"""How well a map agrees with the ground-truth map of a simulated world.

Every cell the map knows (free or occupied, ROS map_server thresholds) is compared with
the ground truth, allowing :data:`TOLERANCE_CELLS` cells of misalignment: an occupied cell
agrees when a true obstacle lies that near; a free cell agrees unless a true obstacle
covers it with no free floor that near (so walls drawn a cell thick do not count against
the free space beside them). A map drawn twice, shifted, shows as walls where the true
floor is and free space across true walls: its agreement drops.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import binary_dilation

from slam_core.occupancy_grid import OccupancyGrid

TOLERANCE_CELLS = 2


def map_agreement(estimate: OccupancyGrid, truth: OccupancyGrid) -> tuple[float, int]:
    """``(fraction of known cells that agree, known cells compared)``; see the module docstring."""
    if abs(estimate.resolution - truth.resolution) > 1e-9:
        raise ValueError("the maps must share a resolution")
    labels = estimate.trinary()
    iy, ix = np.nonzero(labels >= 0)
    centres = estimate.cell_to_world(np.column_stack([ix, iy]))
    cells = truth.world_to_cell(centres)
    ny, nx = truth.shape
    inside = (cells[:, 0] >= 0) & (cells[:, 0] < nx) & (cells[:, 1] >= 0) & (cells[:, 1] < ny)
    true_labels = truth.trinary()
    structure = np.ones((2 * TOLERANCE_CELLS + 1,) * 2, bool)
    near_obstacle = binary_dilation(true_labels == 100, structure)
    near_free = binary_dilation(true_labels == 0, structure)
    occupied = labels[iy, ix] == 100
    tx, ty = np.clip(cells[:, 0], 0, nx - 1), np.clip(cells[:, 1], 0, ny - 1)
    agrees = np.where(occupied, near_obstacle[ty, tx], near_free[ty, tx]) & inside
    return (float(agrees.mean()) if len(agrees) else 0.0), len(agrees)
