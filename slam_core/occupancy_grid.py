"""A growing occupancy grid in log-odds (see :mod:`slam_core.raycast` for the update)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam_core.raycast import integrate_scan_dense
from slam_core.scan import Scan

#: Cells added at a time when a scan reaches outside the grid.
GROW_CHUNK = 64
#: Rows converted at a time, so that no whole-map float64 temporary is ever made.
ROW_BLOCK = 256

#: ROS map_server thresholds on the occupancy probability.
OCCUPIED_THRESH = 0.65
FREE_THRESH = 0.196


def logit(p):
    """Log-odds of a probability."""
    return np.log(p / (1.0 - p))


@dataclass(frozen=True)
class SensorModel:
    """The inverse sensor model's constants.

    ``p_hit`` / ``p_miss`` are the occupancy probabilities a beam's echo cell and
    the cells before it are given; ``p_min`` / ``p_max`` clamp a cell's belief.
    ``usable_range`` caps how far an echo is trusted: longer beams clear space up
    to it and mark nothing. No-return beams clear space up to ``no_return_range``
    (glass and black surfaces also give no return, so this cap is short).
    ``echo_margin`` (m): a beam leaves the cells this close to its echo as they were
    (see :mod:`slam_core.raycast`).

    With ``sparse_echoes`` set (0, the default, turns it off), a *sparse* scan, with fewer than
    that many echoes within ``usable_range`` and most of its echoes beyond (an open hall, a square
    between buildings), trusts its echoes further: out to the range within which it has that
    many, at most ``far_range`` (:meth:`reach`). Every other scan is capped at ``usable_range``,
    so the far echoes count only where the near ones are too few to match (and a sensor with few
    beams is not always sparse). Off by default (see the README and ``benchmarks/RESULTS.md``:
    measured on one log with open ground only).
    """

    p_hit: float = 0.7
    p_miss: float = 0.4
    p_min: float = 0.12
    p_max: float = 0.97
    usable_range: float = 20.0
    no_return_range: float = 4.0
    echo_margin: float = 0.1
    sparse_echoes: int = 0
    far_range: float = 80.0

    def reach(self, scan: Scan) -> float:
        """How far ``scan``'s echoes are trusted (see the class)."""
        if self.sparse_echoes <= 0:
            return self.usable_range
        r = scan.ranges[scan.valid]
        near = np.count_nonzero(r <= self.usable_range)
        if near >= self.sparse_echoes or 2 * near >= len(r):
            return self.usable_range
        far = np.sort(r[r <= self.far_range])
        if len(far) == 0:
            return self.usable_range
        return max(self.usable_range, float(far[min(self.sparse_echoes, len(far)) - 1]))

    def beam_reach(self, scan: Scan, cap: float) -> float:
        """How far a scan matcher whose beams reach ``cap`` takes ``scan``'s: ``cap`` (within
        ``usable_range``), or the whole :meth:`reach` of a sparse scan."""
        reach = self.reach(scan)
        return reach if reach > self.usable_range else min(cap, self.usable_range)

    @property
    def l_occ(self) -> float:
        return float(logit(self.p_hit))

    @property
    def l_free(self) -> float:
        return float(logit(self.p_miss))

    @property
    def l_min(self) -> float:
        return float(logit(self.p_min))

    @property
    def l_max(self) -> float:
        return float(logit(self.p_max))


class OccupancyGrid:
    """Log-odds occupancy grid, ``data[iy, ix]``, that grows to fit what it sees.

    ``origin`` is the world position of the lower-left corner of cell ``(0, 0)``;
    row ``iy`` grows with world ``y`` (REP-103), so images are flipped on output.
    """

    def __init__(self, resolution: float = 0.05, origin=(0.0, 0.0), shape=(0, 0),
                 model: SensorModel | None = None, data: np.ndarray | None = None):
        if resolution <= 0:
            raise ValueError("resolution must be positive")
        self.resolution = float(resolution)
        self.origin = np.array(origin[:2], dtype=float)
        self.model = model or SensorModel()
        self.data = np.zeros(shape, np.float32) if data is None else np.asarray(data, np.float32)

    @property
    def shape(self) -> tuple[int, int]:
        return self.data.shape

    def world_to_cell(self, xy) -> np.ndarray:
        """Integer cell indices ``(ix, iy)`` of world points ``(..., 2)``."""
        return np.floor((np.asarray(xy, float) - self.origin) / self.resolution).astype(np.int64)

    def cell_to_world(self, ixy) -> np.ndarray:
        """World position of the centre of cells ``(..., 2)``."""
        return self.origin + (np.asarray(ixy, float) + 0.5) * self.resolution

    def contains_cell(self, ix, iy) -> bool:
        ny, nx = self.shape
        return 0 <= ix < nx and 0 <= iy < ny

    def extent(self) -> tuple[float, float, float, float]:
        """World bounds ``(xmin, ymin, xmax, ymax)`` of the grid."""
        ny, nx = self.shape
        x0, y0 = self.origin
        return x0, y0, x0 + nx * self.resolution, y0 + ny * self.resolution

    def ensure_contains(self, xmin: float, ymin: float, xmax: float, ymax: float) -> None:
        """Grow the grid (in whole chunks, origin kept on the cell lattice) to cover a box."""
        res = self.resolution
        ny, nx = self.shape
        if nx == 0 or ny == 0:
            lo = np.floor(np.array([xmin, ymin]) / res / GROW_CHUNK) * GROW_CHUNK
            hi = np.ceil(np.array([xmax, ymax]) / res / GROW_CHUNK + 1e-9) * GROW_CHUNK
            hi = np.maximum(hi, lo + GROW_CHUNK)
            self.origin = lo * res
            self.data = np.zeros((int(hi[1] - lo[1]), int(hi[0] - lo[0])), np.float32)
            return
        ix0, iy0 = self.world_to_cell([xmin, ymin])
        ix1, iy1 = self.world_to_cell([xmax, ymax])
        pad_left = _chunks(-ix0)
        pad_bottom = _chunks(-iy0)
        pad_right = _chunks(ix1 - (nx - 1))
        pad_top = _chunks(iy1 - (ny - 1))
        if pad_left or pad_bottom or pad_right or pad_top:
            self.data = np.pad(self.data, ((pad_bottom, pad_top), (pad_left, pad_right)))
            self.origin = self.origin - np.array([pad_left, pad_bottom]) * res

    def integrate(self, scan: Scan, pose) -> None:
        """Update the grid with one scan taken from sensor pose ``pose`` (x, y, theta)."""
        pose = np.asarray(pose, dtype=np.float64)
        if pose.shape != (3,) or not np.isfinite(pose).all():
            raise ValueError(f"sensor pose must be three finite numbers (x, y, theta), got {pose}")
        m = self.model
        self._grow_for(scan, pose)
        integrate_scan_dense(self.data, self.origin[0], self.origin[1], self.resolution, pose,
                             scan.angles, scan.ranges, scan.range_min, scan.range_max,
                             m.reach(scan), m.usable_range, m.no_return_range, m.echo_margin, m.l_free,
                             m.l_occ, m.l_min, m.l_max)

    def _grow_for(self, scan: Scan, pose: np.ndarray) -> None:
        self.ensure_contains(*self.reach_of(scan, pose))

    def reach_of(self, scan: Scan, pose) -> tuple[float, float, float, float]:
        """``(xmin, ymin, xmax, ymax)``: what integrating ``scan`` at ``pose`` writes (and the pose)."""
        pose = np.asarray(pose, dtype=np.float64)
        r = scan.ranges
        usable = (r >= scan.range_min) & (r > 0)
        m = self.model
        r = np.where(r[usable] >= scan.range_max, m.no_return_range, r[usable])
        r = np.minimum(r, m.reach(scan))
        a = pose[2] + scan.angles[usable]
        xs = np.append(pose[0] + r * np.cos(a), pose[0])
        ys = np.append(pose[1] + r * np.sin(a), pose[1])
        return xs.min(), ys.min(), xs.max(), ys.max()

    def probability(self, rows: slice = slice(None)) -> np.ndarray:
        """Occupancy probability of every cell (0.5 where nothing was seen), or of ``rows``."""
        return probability(self.data[rows])

    def row_blocks(self):
        """Slices of at most ``ROW_BLOCK`` rows covering the grid: convert a large map a block
        at a time (its float64 probability is twice the size of the map)."""
        return [slice(y, y + ROW_BLOCK) for y in range(0, self.shape[0], ROW_BLOCK)]

    def bands(self):
        """``(rows, log_odds)``: the grid ``ROW_BLOCK`` rows at a time, from the top (largest y) down, as
        :meth:`slam_core.map_bands.MapBands.bands` gives a map too large to hold (the map writers take
        either)."""
        for top in range(self.shape[0], 0, -ROW_BLOCK):
            rows = slice(max(0, top - ROW_BLOCK), top)
            yield rows, self.data[rows]

    def trinary(self, occupied_thresh: float = OCCUPIED_THRESH,
                free_thresh: float = FREE_THRESH) -> np.ndarray:
        """``int8`` view as ROS ``OccupancyGrid`` data: 100 occupied, 0 free, -1 unknown."""
        out = np.full(self.shape, -1, np.int8)
        for rows in self.row_blocks():
            p = self.probability(rows)
            block = out[rows]
            block[p > occupied_thresh] = 100
            block[p < free_thresh] = 0
        return out


def probability(log_odds: np.ndarray) -> np.ndarray:
    """Occupancy probability of log-odds (0.5 where nothing was seen), in float64."""
    return 1.0 - 1.0 / (1.0 + np.exp(log_odds.astype(np.float64)))


def _chunks(cells_missing: int) -> int:
    """Cells to add, in whole chunks, when ``cells_missing`` (> 0) are outside."""
    if cells_missing <= 0:
        return 0
    return int(np.ceil((cells_missing + 1) / GROW_CHUNK)) * GROW_CHUNK



