"""The map's growth limit, checked before a pose or a scan makes the map allocate anything.

The live map must fit the server's shared block (``map_capacity_cells``, sides of at most
:data:`~app.worker.shared_map.MAX_SIDE`). A scan integrated from a pose far outside the home (a
wrong pose sent by hand, a corrupt checkpoint) would first make the estimator allocate a
huge map and then fail to publish it; :func:`check_room` refuses such a pose up front with
:class:`~app.worker.shared_map.MapTooLarge`, saying how large the map would become.
"""

from __future__ import annotations

import math

import numpy as np

from app.worker.shared_map import MAX_SIDE, MapTooLarge
from slam_core.occupancy_grid import SensorModel
from slam_core.rbpf.tiled_map import GROW_MARGIN_TILES, TILE, TiledMaps

Box = tuple[float, float, float, float]  # xmin, ymin, xmax, ymax (m)


def map_box(estimator, fallback_grid=None) -> Box | None:
    """The world box the estimator's map already covers (its tile lattice for the RBPF)."""
    maps = getattr(estimator, "maps", None)
    if isinstance(maps, TiledMaps) and maps.tables.shape[2]:
        _, n_ty, n_tx = maps.tables.shape
        x0, y0 = maps.origin
        return x0, y0, x0 + n_tx * maps.tile_size, y0 + n_ty * maps.tile_size
    grid = fallback_grid if fallback_grid is not None else estimator.occupancy_map()
    return None if grid is None or not grid.data.size else grid.extent()


def scan_reach(scan, model: SensorModel) -> float:
    """How far from the robot ``scan`` writes into the map (as :meth:`TiledMaps.integrate` grows it)."""
    return min(model.reach(scan), max(model.no_return_range, float(np.max(scan.ranges, initial=0.0))))


def check_room(box: Box | None, pose, reach: float, resolution: float, capacity_cells: int) -> None:
    """Raise :class:`MapTooLarge` unless a scan from ``pose`` seeing ``reach`` metres fits the limit."""
    x, y = float(pose[0]), float(pose[1])
    if not (math.isfinite(x) and math.isfinite(y)):
        raise MapTooLarge(f"pose ({x}, {y}) is not finite")
    lo = np.array([x - reach, y - reach])
    hi = np.array([x + reach, y + reach])
    if box is not None:
        lo = np.minimum(lo, box[:2])
        hi = np.maximum(hi, box[2:])
    margin = 2 * GROW_MARGIN_TILES * TILE
    width, height = ((hi - lo) / resolution).astype(float) + margin
    if width * height > capacity_cells or max(width, height) > MAX_SIDE:
        raise MapTooLarge(
            f"a scan from ({x:.2f}, {y:.2f}) would grow the map to about {width:.0f} x {height:.0f} cells, "
            f"over the limit of {capacity_cells} cells (sides of at most {MAX_SIDE}); refused")
