"""A corridor 2 m wide and 60 m long with a door every 6 m (a look-alike every 6 m), scanned
by a forward-looking 181-beam laser, and its map from scans along the first 40 m."""

import numpy as np
from synthetic_room import cast

from slam_core.occupancy_grid import OccupancyGrid
from slam_core.scan import Scan

#: Door frames 0.3 m deep every 6 m, walls off the cell lattice.
_DOORS = [seg for x in range(3, 58, 6) for seg in ([x, 1.0, x, 1.3], [x, 1.3, x + 1.0, 1.3],
                                                    [x + 1.0, 1.3, x + 1.0, 1.0])]
#: The upper wall runs between the doors' openings (x .. x + 1).
_UPPER = [[a, 1.0, b, 1.0] for a, b in zip([-1.0, *range(4, 59, 6)], [*range(3, 58, 6), 59.0], strict=True)]
CORRIDOR = np.array([[-1.0, -1.0, 59.0, -1.0], *_UPPER, [-1.0, -1.0, -1.0, 1.0],
                     [59.0, -1.0, 59.0, 1.0], *_DOORS], dtype=float) + np.array([0.013, 0.021, 0.013, 0.021])
ANGLES = np.linspace(-np.pi / 2, np.pi / 2, 181)
STEP = 0.2  # m per scan (1 m/s at 5 Hz)


def scan_at(pose, rng) -> Scan:
    return Scan(ANGLES, cast(pose, ANGLES, CORRIDOR) + rng.normal(0.0, 0.01, len(ANGLES)), 0.05, 30.0)


def mapped_along(scan_fn, length: float) -> OccupancyGrid:
    """The map of scans ``scan_fn(pose, rng)`` taken every 0.5 m along the x axis, both ways."""
    grid = OccupancyGrid(0.05)
    rng = np.random.default_rng(0)
    for x in np.arange(0.0, length, 0.5):
        for th in (0.0, np.pi):
            grid.integrate(scan_fn((x, 0.0, th), rng), np.array([x, 0.0, th]))
    return grid


def corridor_map() -> OccupancyGrid:
    return mapped_along(scan_at, 40.0)
