"""An occupancy map kept as counts of observations, by submap, so that only moved submaps are traced again.

Every beam adds one "free" observation to each cell it crosses before its echo and one "occupied"
to its echo's cell (:mod:`slam_core.raycast`'s rules). A cell's log-odds is
``clamp(l_occ * n_occ + l_free * n_free, l_min, l_max)``: clamped once after the sum, not after
every beam as :meth:`~slam_core.occupancy_grid.OccupancyGrid.integrate` does, so the map does not
depend on the order of the scans, and a submap (a block of consecutive updates) can be taken out
and put back from other poses exactly (the counts are integers).

:class:`CountMap` keeps the sums of every submap's counts in tiles of :data:`TILE` x :data:`TILE`
cells, only where a beam touched (its grid's log-odds are made from them), and of each submap only the
laser poses it was traced from and its echoes' hit sums (:class:`SubmapEchoes`): its memory grows with
the area mapped, not with the updates or the box around it.
:meth:`CountMap.update` traces again only the submaps whose poses moved (an update by more than
:data:`MOVE_CELLS` of a cell or :data:`MOVE_RAD`) and the ones that are new or grew; a moved
submap's old counts are traced again from its old poses (the same cells, exactly) and taken out.
Cells are on the absolute lattice (cell ``(ix, iy)`` spans ``[ix, ix + 1) * resolution``), and
the map's box grows in chunks of :data:`~slam_core.occupancy_grid.GROW_CHUNK` cells aligned
to it, as an :class:`~slam_core.occupancy_grid.OccupancyGrid` started empty does; the tiles are
those chunks.
:class:`slam_core.map_bands.MapBands` gives the same cells for a finished log, a band of rows at a time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam_core.jit import njit
from slam_core.mapped_pools import MappedPools
from slam_core.occupancy_grid import GROW_CHUNK, OccupancyGrid, SensorModel
from slam_core.raycast import FAR_TAIL, beam_endpoint, cleared_cells, far_gap, ray_buffer_size, trace_ray
from slam_core.rbpf.hit_render import SparseHits, echo_endpoints
from slam_core.scan import Scan

#: A submap is traced again when one of its laser poses moved by more than this fraction of a cell...
MOVE_CELLS = 0.1
#: ... or turned by more than this (rad).
MOVE_RAD = 1e-3
OCC, FREE = 0, 1
#: Side (cells) of the tiles the counts are kept in: the box's chunks, so a tile lies wholly in the box.
TILE = GROW_CHUNK


@njit
def _count_beams(counts, touched, ix0, iy0, inv, poses, angles, ranges, offsets, limits, near_range,
                 no_return_range, echo_margin):
    """Add the observations of scan ``s`` (beams ``offsets[s]:offsets[s + 1]``, from laser pose
    ``poses[s]``, its range limits and reach ``limits[s]``, see :func:`scan_limits`) to zeroed
    ``counts[iy - iy0, ix - ix0, OCC | FREE]``, which must hold every traced cell; the flat indices
    of the cells touched go to ``touched`` (as large as ``counts``' cells), their number is returned."""
    buf = np.empty((ray_buffer_size(limits[:, 2].max(), 1.0 / inv), 2), dtype=np.int64)
    ny, nx = counts.shape[0], counts.shape[1]
    m = 0
    for s in range(poses.shape[0]):
        px, py, pth = poses[s, 0], poses[s, 1], poses[s, 2]
        gx0, gy0 = px * inv - ix0, py * inv - iy0
        for b in range(offsets[s], offsets[s + 1]):
            use, hit, ex, ey = beam_endpoint(px, py, pth, angles[b], ranges[b], limits[s, 0], limits[s, 1],
                                             limits[s, 2], no_return_range)
            if not use:
                continue
            gx1, gy1 = ex * inv - ix0, ey * inv - iy0
            n = trace_ray(gx0, gy0, gx1, gy1, buf)
            cleared = cleared_cells(buf, n, hit, gx1, gy1, echo_margin * inv)
            gap_lo, gap_hi = far_gap(buf, n, hit, gx0, gy0, gx1, gy1, limits[s, 2], near_range, FAR_TAIL, inv)
            for k in range(n):
                cx, cy = buf[k, 0], buf[k, 1]
                if (cx < 0 or cy < 0 or cx >= nx or cy >= ny or cleared <= k < n - 1
                        or (gap_lo < gap_hi and gap_lo <= k < gap_hi)):
                    continue
                if counts[cy, cx, OCC] == 0 and counts[cy, cx, FREE] == 0:
                    touched[m] = cy * nx + cx
                    m += 1
                counts[cy, cx, OCC if (hit and k == n - 1) else FREE] += 1
    return m


@njit
def clamped_log_odds(occupied, free, l_occ, l_free, l_min, l_max):
    """A cell's log-odds from its counts of observations (0 for none), clamped once after the sum."""
    return min(max(l_occ * occupied + l_free * free, l_min), l_max)


@njit
def _log_odds(counts, out, l_occ, l_free, l_min, l_max):
    """``out[iy, ix]``: the log-odds of ``counts[iy, ix]`` (float32)."""
    for iy in range(counts.shape[0]):
        for ix in range(counts.shape[1]):
            n = counts[iy, ix]
            out[iy, ix] = clamped_log_odds(n[OCC], n[FREE], l_occ, l_free, l_min, l_max)


@njit
def _missing_tiles(slots, cells, width, cx, cy, missing):
    """Mark in ``missing`` (``slots``' shape, zeroed) the tiles that ``cells`` (flat indices into rows
    of ``width`` from box cell ``(cx, cy)``) touch and that have no slot (-1); returns how many."""
    n = 0
    for k in range(cells.shape[0]):
        ty, tx = (cy + cells[k] // width) // TILE, (cx + cells[k] % width) // TILE
        if slots[ty, tx] < 0 and not missing[ty, tx]:
            missing[ty, tx] = True
            n += 1
    return n


@njit
def _add_tiled(pool, slots, cells, width, cx, cy, occupied, free, sign):
    """The tiles' counts += ``sign`` * the counts of ``cells`` (as :func:`_missing_tiles`; every tile
    they touch has a slot)."""
    for k in range(cells.shape[0]):
        iy, ix = cy + cells[k] // width, cx + cells[k] % width
        t = slots[iy // TILE, ix // TILE]
        pool[t, iy % TILE, ix % TILE, OCC] += sign * np.int64(occupied[k])
        pool[t, iy % TILE, ix % TILE, FREE] += sign * np.int64(free[k])


@njit
def _empty_slots(pool, slots, ty0, tx0, ty1, tx1, out):
    """The slots of tiles ``ty0..ty1``, ``tx0..tx1`` that hold no count, to ``out``; returns how many."""
    n = 0
    for ty in range(ty0, ty1 + 1):
        for tx in range(tx0, tx1 + 1):
            t = slots[ty, tx]
            if t >= 0 and not np.any(pool[t]):
                out[n] = t
                n += 1
    return n


@njit
def _tiled_log_odds(pool, slots, out, l_occ, l_free, l_min, l_max):
    """``out`` (the box's cells, float32): the log-odds of every tile with a slot (the others stay)."""
    for ty in range(slots.shape[0]):
        for tx in range(slots.shape[1]):
            t = slots[ty, tx]
            if t >= 0:
                _log_odds(pool[t], out[ty * TILE:(ty + 1) * TILE, tx * TILE:(tx + 1) * TILE],
                          l_occ, l_free, l_min, l_max)


def scan_limits(scans: list[Scan], model: SensorModel) -> np.ndarray:
    """``(range_min, range_max, reach)`` of each scan: its sensor's limits and how far its echoes
    are trusted (:meth:`~slam_core.occupancy_grid.SensorModel.reach`)."""
    return np.array([(s.range_min, s.range_max, model.reach(s)) for s in scans], np.float64).reshape(-1, 3)


def _reach(laser_poses: np.ndarray, scans: list[Scan], limits: np.ndarray, model: SensorModel,
           inv: float) -> np.ndarray:
    """``[ix0, iy0, ix1, iy1]``: the cells that tracing ``scans`` (their :func:`scan_limits`) can
    touch, with a cell to spare."""
    lengths = [len(s) for s in scans]
    angles, ranges = np.concatenate([s.angles for s in scans]), np.concatenate([s.ranges for s in scans])
    r_min, r_max, usable = (np.repeat(limits[:, k], lengths) for k in range(3))
    poses = np.repeat(laser_poses, lengths, axis=0)
    with np.errstate(invalid="ignore"):
        use = (ranges >= r_min) & (ranges > 0)
    r = np.where(ranges[use] >= r_max[use], np.minimum(model.no_return_range, usable[use]),
                 np.minimum(ranges[use], usable[use]))
    a = poses[use, 2] + angles[use]
    xs = np.concatenate([poses[use, 0] + r * np.cos(a), laser_poses[:, 0]])
    ys = np.concatenate([poses[use, 1] + r * np.sin(a), laser_poses[:, 1]])
    lo = np.floor(np.array([xs.min(), ys.min()]) * inv).astype(np.int64) - 1
    hi = np.floor(np.array([xs.max(), ys.max()]) * inv).astype(np.int64) + 1
    return np.concatenate([lo, hi])


@dataclass(frozen=True)
class SubmapEchoes:
    """What :class:`CountMap` keeps of a traced submap: the laser poses it was traced from, and its
    echoes' cells (flat indices ``hit_cells`` into rows of ``width`` cells from the absolute cell
    ``corner``) with their hit sums ``(h, 3)``."""

    poses: np.ndarray
    corner: np.ndarray
    width: int
    hit_cells: np.ndarray
    hit_values: np.ndarray

    def moved(self, laser_poses: np.ndarray, resolution: float) -> bool:
        """Whether ``laser_poses`` are other updates than those traced, or any moved past the tolerance."""
        if laser_poses.shape != self.poses.shape:
            return True
        step = np.abs(laser_poses - self.poses)
        turn = np.abs((step[:, 2] + np.pi) % (2 * np.pi) - np.pi)
        return bool(step[:, :2].max() > MOVE_CELLS * resolution or turn.max() > MOVE_RAD)


@dataclass(frozen=True)
class SubmapCounts:
    """One submap's observations: the cells it touched (flat indices ``cells`` into rows of ``width``
    cells from the absolute cell ``corner``; within absolute cells ``lo..hi``), their occupied and
    free counts, its echoes' cells (the same way) with their hit sums ``(h, 3)``, and the laser poses
    it was traced from."""

    poses: np.ndarray
    corner: np.ndarray
    width: int
    lo: np.ndarray
    hi: np.ndarray
    cells: np.ndarray
    occupied: np.ndarray
    free: np.ndarray
    hit_cells: np.ndarray
    hit_values: np.ndarray

    @classmethod
    def trace(cls, laser_poses: np.ndarray, scans: list[Scan], resolution: float,
              model: SensorModel) -> SubmapCounts:
        inv = 1.0 / resolution
        laser_poses = np.ascontiguousarray(laser_poses, np.float64).reshape(-1, 3)
        limits = scan_limits(scans, model)
        ix0, iy0, ix1, iy1 = _reach(laser_poses, scans, limits, model, inv)
        counts = np.zeros((iy1 - iy0 + 1, ix1 - ix0 + 1, 2), np.int32)
        touched = np.empty(counts.shape[0] * counts.shape[1], np.int64)
        offsets = np.concatenate([[0], np.cumsum([len(s) for s in scans])]).astype(np.int64)
        m = _count_beams(counts, touched, float(ix0), float(iy0), inv, laser_poses,
                         np.concatenate([s.angles for s in scans]), np.concatenate([s.ranges for s in scans]),
                         offsets, limits, model.usable_range, model.no_return_range, model.echo_margin)
        touched = np.sort(touched[:m]).astype(np.int32)
        found = counts.reshape(-1, 2)[touched]
        dtype = np.uint16 if found.max(initial=0) <= np.iinfo(np.uint16).max else np.int32
        corner, nx = np.array([ix0, iy0]), counts.shape[1]
        ends = echo_endpoints(laser_poses, scans, model)
        hits = SparseHits.of_echoes(corner * resolution, counts.shape[:2], resolution, ends)
        every = np.concatenate([touched, hits.cells])  # an echo's cell is its ray's last, up to rounding
        columns, rows = every % nx, every // nx
        lo = corner + np.array([columns.min(initial=0), rows.min(initial=0)])
        hi = corner + np.array([columns.max(initial=0), rows.max(initial=0)])
        return cls(laser_poses, corner, nx, lo, hi, touched, found[:, OCC].astype(dtype),
                   found[:, FREE].astype(dtype), hits.cells.astype(np.int32), hits.values)

    def echoes(self) -> SubmapEchoes:
        return SubmapEchoes(self.poses, self.corner, self.width, self.hit_cells, self.hit_values)


class CountMap:
    """The map of a growing list of updates, traced by blocks of ``submap_updates`` (see the module)."""

    def __init__(self, resolution: float, model: SensorModel, submap_updates: int):
        if submap_updates < 1:
            raise ValueError(f"submap_updates must be at least 1, got {submap_updates}")
        self.resolution, self.model, self.submap_updates = float(resolution), model, submap_updates
        self.submaps: list[SubmapEchoes] = []
        #: Each tile's counts ``(TILE, TILE, OCC | FREE)``, in the pool's slot that ``slots`` gives a
        #: tile of the box (-1: no beam touched it); the slots of tiles emptied are used again.
        self._pools = MappedPools()  # the pool grows in place, new slots zero until written
        self.pool = self._pools.zeros("pool", (0, TILE, TILE, 2), np.int32)
        self.slots = np.full((0, 0), -1, np.int32)
        self._free: list[int] = []
        self.corner = np.zeros(2, np.int64)  # the absolute cell (ix, iy) of the box's first (a tile's)

    def update(self, laser_poses: np.ndarray, scans: list[Scan]) -> int:
        """Make the map that of ``scans`` seen from ``laser_poses``, the updates so far (they only grow);
        returns the number of submaps traced."""
        laser_poses = np.asarray(laser_poses, np.float64).reshape(-1, 3)
        if len(laser_poses) != len(scans):
            raise ValueError(f"{len(laser_poses)} poses for {len(scans)} scans")
        size = self.submap_updates
        if len(scans) < size * (len(self.submaps) - 1) + 1 and self.submaps:
            raise ValueError(f"{len(scans)} updates: fewer than the map already holds")
        traced = 0
        for block, first in enumerate(range(0, len(scans), size)):
            poses = laser_poses[first:first + size]
            old = self.submaps[block] if block < len(self.submaps) else None
            if old is not None and not old.moved(poses, self.resolution):
                continue
            if old is not None:  # its counts, as they were added
                self._add(self._trace(old.poses, scans[first:first + len(old.poses)]), -1)
            new = self._trace(poses, scans[first:first + size])
            self._add(new, 1)
            if old is not None:
                self.submaps[block] = new.echoes()
            else:
                self.submaps.append(new.echoes())
            traced += 1
        return traced

    def _trace(self, laser_poses: np.ndarray, scans: list[Scan]) -> SubmapCounts:
        return SubmapCounts.trace(laser_poses, scans, self.resolution, self.model)

    @property
    def shape(self) -> tuple[int, int]:
        """The box's ``(ny, nx)`` cells: whole tiles."""
        return self.slots.shape[0] * TILE, self.slots.shape[1] * TILE

    def _add(self, submap: SubmapCounts, sign: int) -> None:
        """Add ``sign`` times ``submap``'s counts; a tile left with none gives its slot back."""
        if len(submap.cells) == 0:
            return
        self._grow_to(submap.lo, submap.hi)
        cx, cy = submap.corner - self.corner
        if sign > 0:
            missing = np.zeros(self.slots.shape, np.bool_)
            if _missing_tiles(self.slots, submap.cells, submap.width, cx, cy, missing):
                self._allocate(np.argwhere(missing))
        _add_tiled(self.pool, self.slots, submap.cells, submap.width, cx, cy, submap.occupied, submap.free,
                   sign)
        if sign < 0:
            (tx0, ty0), (tx1, ty1) = (np.floor_divide(v - self.corner, TILE) for v in (submap.lo, submap.hi))
            out = np.empty((ty1 - ty0 + 1) * (tx1 - tx0 + 1), np.int64)
            empty = out[:_empty_slots(self.pool, self.slots, ty0, tx0, ty1, tx1, out)]
            self.slots[np.isin(self.slots, empty)] = -1
            self._free.extend(int(t) for t in empty)

    def _allocate(self, tiles: np.ndarray) -> None:
        """A slot for each tile ``(ty, tx)`` of the box: freed ones first (freed only when they hold no
        count), then new ones (the pool grows by half, in place: :mod:`slam_core.mapped_pools`)."""
        fresh = len(tiles) - len(self._free)
        if fresh > 0:
            size = len(self.pool)
            self._pools.grow(self, "pool", max(size + fresh, size * 3 // 2))
            self._free.extend(range(size, len(self.pool)))
        for ty, tx in tiles:
            self.slots[ty, tx] = self._free.pop()

    def _grow_to(self, lo: np.ndarray, hi: np.ndarray) -> None:
        """Make the box cover absolute cells ``lo..hi`` (in tiles on the lattice)."""
        nty, ntx = self.slots.shape
        if nty and ntx:
            lo = np.minimum(lo, self.corner)
            hi = np.maximum(hi, self.corner + TILE * np.array([ntx, nty]) - 1)
        new_lo = np.floor_divide(lo, TILE) * TILE
        (ntx1, nty1) = np.floor_divide(hi, TILE) + 1 - new_lo // TILE
        if nty and ntx and np.array_equal(new_lo, self.corner) and (nty1, ntx1) == (nty, ntx):
            return
        slots = np.full((nty1, ntx1), -1, np.int32)
        if nty and ntx:
            x, y = (self.corner - new_lo) // TILE
            slots[y:y + nty, x:x + ntx] = self.slots
        self.corner, self.slots = new_lo, slots

    def grid(self, extent: tuple[float, float, float, float] | None = None) -> OccupancyGrid:
        """A fresh grid of the map, over its cells and (when given) the box ``extent`` too
        (``(xmin, ymin, xmax, ymax)``, a grid's :meth:`~slam_core.occupancy_grid.OccupancyGrid.extent`)."""
        grid = self.blank(extent)
        self.draw(grid)
        return grid

    def blank(self, extent: tuple[float, float, float, float] | None = None) -> OccupancyGrid:
        """The grid :meth:`grid` gives, every cell still unknown: its box, for :meth:`hit_sums`, before
        :meth:`draw` fills it (a fresh grid's cells take memory only when first written)."""
        grid = OccupancyGrid(self.resolution, model=self.model)
        ny, nx = self.shape
        centres = []  # (xmin, ymin, xmax, ymax) of the cell centres to cover
        if nx and ny:
            centres.append(np.concatenate([self.corner + 0.5, self.corner + np.array([nx, ny]) - 0.5])
                           * self.resolution)
        if extent is not None:
            centres.append(np.array(extent) + 0.5 * self.resolution * np.array([1, 1, -1, -1]))
        if centres:
            box = np.array(centres)
            grid.ensure_contains(*box[:, :2].min(axis=0), *box[:, 2:].max(axis=0))
        return grid

    def draw(self, grid: OccupancyGrid) -> None:
        """Write the map's log-odds into ``grid``, a :meth:`blank` of this map as it is now."""
        ny, nx = self.shape
        if not (nx and ny):
            return
        x, y = self.corner - np.round(grid.origin / self.resolution).astype(np.int64)
        if x < 0 or y < 0 or x + nx > grid.shape[1] or y + ny > grid.shape[0]:
            raise ValueError("the grid does not cover the map")
        m = self.model  # the cells of no tile have no counts: log-odds 0, as the grid starts
        _tiled_log_odds(self.pool, self.slots, grid.data[y:y + ny, x:x + nx], m.l_occ, m.l_free, m.l_min,
                        m.l_max)

    def hit_sums(self, grid: OccupancyGrid) -> SparseHits:
        """Every submap's hit sums on ``grid``'s cells (a grid of :meth:`grid`)."""
        corner = np.round(grid.origin / self.resolution).astype(np.int64)
        cells = np.vstack([np.column_stack([s.hit_cells % s.width, s.hit_cells // s.width]) + s.corner
                           for s in self.submaps] or [np.zeros((0, 2), np.int64)]) - corner
        values = np.vstack([s.hit_values for s in self.submaps] or [np.zeros((0, 3))]).astype(np.float64)
        ny, nx = grid.shape
        if not np.all((cells >= 0) & (cells < [nx, ny])):
            raise ValueError("the grid does not hold every echo of the map")
        # each submap's sums are from its own cell corners, on the same lattice as the grid's
        return SparseHits.summed(grid.origin, grid.shape, cells[:, 1] * nx + cells[:, 0], values)
