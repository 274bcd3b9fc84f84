"""A traversal-cost map built from an :class:`~slam_core.occupancy_grid.OccupancyGrid`.

Every cell gets a *weight* ``w >= 1`` (the price of one metre through it) or
``inf`` (never entered). With ``d`` the exact Euclidean distance (metres, cell
centre to cell centre, :mod:`slam_core.distance_transform`) to the nearest
occupied cell, ``r`` the robot radius (the robot description's footprint radius,
:mod:`slam_core.robot_config`; by default the simulated robot's) and ``R`` the
inflation radius::

    d <= r        lethal: w = inf    (the robot's centre there would hit the wall)
    r < d <= R    w = 1 + max_cost * exp(-cost_scaling * (d - r))
    d > R         w = 1

This is the decay of ROS 2 Nav2's inflation layer (``cost = 252 * exp(-k (d - r))``
beyond the inscribed radius), scaled to a multiplier on distance: a path pays
up to ``1 + max_cost`` times its length while hugging a wall, so A* trades a
small detour for clearance. Unknown cells (``trinary() == -1``) are either
forbidden (``unknown_cost=None``: ``w = inf`` but not lethal) or cost an extra
``unknown_cost`` on top; obstacles are inflated, unknown space is not.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from slam_core.distance_transform import distance_to_features
from slam_core.occupancy_grid import FREE_THRESH, OCCUPIED_THRESH, OccupancyGrid
from slam_core.robot_config import robot_from

#: Default distance (m) beyond which walls add no cost.
INFLATION_RADIUS = 0.6
#: Default exponential decay rate (1/m) of the inflation cost.
COST_SCALING = 6.0
#: Default extra weight right at the lethal border.
MAX_COST = 10.0
#: Default extra weight of unknown cells (exploring needs to cross them).
UNKNOWN_COST = 2.0


@dataclass(frozen=True)
class CostmapConfig:
    """Inflation and unknown-space policy; ``unknown_cost=None`` forbids unknown cells."""

    robot_radius: float = field(default_factory=lambda: robot_from(None).footprint_radius)
    inflation_radius: float = INFLATION_RADIUS
    cost_scaling: float = COST_SCALING
    max_cost: float = MAX_COST
    unknown_cost: float | None = UNKNOWN_COST
    occupied_thresh: float = OCCUPIED_THRESH
    free_thresh: float = FREE_THRESH

    def __post_init__(self):
        if self.robot_radius < 0:
            raise ValueError(f"robot_radius must be >= 0, got {self.robot_radius}")
        if self.inflation_radius < self.robot_radius:
            raise ValueError(f"inflation_radius ({self.inflation_radius}) must be >= robot_radius "
                             f"({self.robot_radius})")
        if self.cost_scaling < 0 or self.max_cost < 0:
            raise ValueError("cost_scaling and max_cost must be >= 0")
        if self.unknown_cost is not None and self.unknown_cost < 0:
            raise ValueError(f"unknown_cost must be >= 0 or None, got {self.unknown_cost}")

    def inflation_cost(self, distance_m: np.ndarray) -> np.ndarray:
        """Extra weight at ``distance_m`` from the nearest obstacle (``inf`` when lethal)."""
        d = np.asarray(distance_m, dtype=np.float64)
        with np.errstate(over="ignore"):
            cost = self.max_cost * np.exp(-self.cost_scaling * (d - self.robot_radius))
        cost = np.where(d > self.inflation_radius, 0.0, cost)
        return np.where(d <= self.robot_radius, np.inf, cost)


class Costmap:
    """Cell weights ``weights[iy, ix]`` (>= 1, ``inf`` = impassable) in the grid's frame.

    Weights are stored as ``float32`` (half the memory traffic of the search);
    path costs are summed in ``float64``.
    """

    def __init__(self, weights: np.ndarray, resolution: float, origin=(0.0, 0.0),
                 distance: np.ndarray | None = None, unknown: np.ndarray | None = None,
                 lethal: np.ndarray | None = None):
        weights = np.asarray(weights, dtype=np.float32)
        if weights.ndim != 2:
            raise ValueError(f"weights must be 2-D, got shape {weights.shape}")
        if np.any(weights < 1.0) or np.any(np.isnan(weights)):
            raise ValueError("weights must be >= 1 (or inf); found smaller or NaN values")
        self.weights = weights
        self.resolution = float(resolution)
        self.origin = np.array(origin[:2], dtype=float)
        self.distance = np.full(weights.shape, np.inf) if distance is None else distance
        self.unknown = np.zeros(weights.shape, bool) if unknown is None else unknown
        self.lethal = np.isinf(weights) & ~self.unknown if lethal is None else lethal
        self._padded = None

    @property
    def shape(self) -> tuple[int, int]:
        return self.weights.shape

    def traversable(self) -> np.ndarray:
        return np.isfinite(self.weights)

    def padded_weights(self) -> np.ndarray:
        """Flat weights with a one-cell ``inf`` border, so A* never tests bounds."""
        if self._padded is None:
            self._padded = np.pad(self.weights, 1, constant_values=np.inf).ravel()
        return self._padded

    def world_to_cell(self, xy) -> np.ndarray:
        return np.floor((np.asarray(xy, float) - self.origin) / self.resolution).astype(np.int64)

    def cell_to_world(self, ixy) -> np.ndarray:
        return self.origin + (np.asarray(ixy, float) + 0.5) * self.resolution

    def contains_cell(self, ix, iy) -> bool:
        ny, nx = self.shape
        return 0 <= ix < nx and 0 <= iy < ny


def build_costmap(grid: OccupancyGrid, config: CostmapConfig | None = None) -> Costmap:
    """The costmap of a grid under ``config`` (see the module docstring for the formula)."""
    config = config or CostmapConfig()
    trinary = grid.trinary(config.occupied_thresh, config.free_thresh)
    return costmap_from_trinary(trinary, grid.resolution, grid.origin, config)


def costmap_from_trinary(trinary: np.ndarray, resolution: float, origin=(0.0, 0.0),
                         config: CostmapConfig | None = None) -> Costmap:
    """The costmap of a ROS-style ``int8`` map (100 occupied, 0 free, -1 unknown)."""
    config = config or CostmapConfig()
    trinary = np.asarray(trinary)
    if trinary.ndim != 2:
        raise ValueError(f"map must be 2-D, got shape {trinary.shape}")
    occupied = trinary == 100
    unknown = trinary == -1
    distance = distance_to_features(occupied) * resolution
    weights = 1.0 + config.inflation_cost(distance)
    lethal = np.isinf(weights)
    if config.unknown_cost is None:
        weights[unknown] = np.inf
    else:
        weights[unknown] += config.unknown_cost
    return Costmap(weights, resolution, origin, distance=distance, unknown=unknown & ~lethal,
                   lethal=lethal)
