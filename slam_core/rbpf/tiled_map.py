"""Particle maps that share storage: copy-on-write tiles (the "compact map model").

Every particle map is a table of tile indices over one common tile lattice;
the tiles themselves live in one pool with reference counts. Resampling copies
tables, not cells: a copy of a particle shares all its tiles. A particle that
then writes a shared tile first gets its own copy of just that tile, so memory
grows with what the particles disagree on, not with the particle count.

Each cell holds the occupancy in log-odds (see :mod:`slam_core.raycast`) and
the running sum and count of the beam endpoints that fell into it: the mean
endpoint locates the surface inside the cell, which the scan matcher uses for
sub-cell accuracy (as GMapping's point accumulators do). Here a beam clears every
cell it crosses before its echo: the model's ``echo_margin``, which the maps
published and localized in keep, made intel's trajectory worse when the particle
maps kept it too (0.15 m: 0.0169 -> 0.0234 m, seed 0; benchmarks/RESULTS.md). A tile's log-odds take
1 KB; the sums of a ``PART`` x ``PART`` part of it take ``PART**2 * 12`` bytes, so only a
part that some echo fell into has them, in a *hit block* of its own (copied with the
tile): most tiles a scan crosses are free space and have none, and a wall crosses a few
of a tile's parts (``hit_of[t, part_of(cy, cx)]`` is the block of tile ``t``'s cell ``(cy, cx)``).

Outdoors a third of the tiles in use end up as private copies of settled free space: every
cell at the lower clamp ``l_min``, no echo. Before a pool grows, and before the maps may take
more tiles than they ever held at once, all such tiles are made one shared tile
(:func:`_share_settled`); the maps read the same values from it, and a free-space write leaves
it shared as it leaves any cell at ``l_min``. A process holds every tile row it ever wrote, so
the most tiles ever in use at once is its memory.
"""

from __future__ import annotations

import numpy as np

from slam_core.jit import njit, split
from slam_core.mapped_pools import MappedPools
from slam_core.occupancy_grid import OccupancyGrid, SensorModel
from slam_core.raycast import FAR_TAIL, beam_endpoint, far_gap, ray_buffer_size, trace_ray

TILE_BITS = 4
TILE = 1 << TILE_BITS
#: A hit block holds the sums of PART x PART cells of a tile, one of its PARTS parts.
PART_BITS = 2
PART = 1 << PART_BITS
PARTS = (TILE // PART) ** 2
#: Empty tiles added around the lattice whenever it grows.
GROW_MARGIN_TILES = 4
#: Hit sums: x, y (metres from the cell's lower-left corner) and count.
HIT_X, HIT_Y, HIT_N = 0, 1, 2
#: A full pool grows by at least 1 / GROW_DIVISOR: maps that run out mid-scan grow it step by step,
#: and the grown rows are zeroed (held) at once, so a small step overshoots little.
GROW_DIVISOR = 8
#: Least slice of a pool's free entries a map that ran out is given next.
MIN_SLICE = 16
#: Integrations at least between two sweeps for settled tiles made before the maps may take more
#: tiles than they ever held at once (a sweep reads the whole pool and every table).
SWEEP_EVERY = 10


@njit
def part_of(cy, cx):
    """The part of a tile that holds its cell ``(cy, cx)`` (``hit_of``'s second index)."""
    return ((cy >> PART_BITS) << (TILE_BITS - PART_BITS)) | (cx >> PART_BITS)


@njit
def _parts_with_hits(hit_of, t):
    n = 0
    for j in range(PARTS):
        if hit_of[t, j] >= 0:
            n += 1
    return n


@njit
def _count_held(refs, hit_of, held):
    """``held[t]``: the parts of tile ``t`` with a hit block, for every tile in use."""
    for t in range(refs.shape[0]):
        if refs[t] > 0:
            held[t] = _parts_with_hits(hit_of, t)


@njit
def _demand(first, stop, tables, refs, held, origin_x, origin_y, tile_size, poses, reach, beams, tiles,
            blocks):
    """Upper bounds of the tiles and hit blocks a scan from the pose of map ``first`` to
    ``stop - 1`` can take: the tiles within ``reach`` that are not that map's own (missing or
    shared), and the parts there without a hit block of their own, at most one per beam, plus
    the shared tiles' blocks. ``held`` as :func:`_count_held` gives it (the maps share most
    tiles: counted once per tile rather than once per map)."""
    n_ty, n_tx = tables.shape[1], tables.shape[2]
    for p in range(first, stop):
        tx0 = max(int(np.floor((poses[p, 0] - reach - origin_x) / tile_size)) - 1, 0)
        ty0 = max(int(np.floor((poses[p, 1] - reach - origin_y) / tile_size)) - 1, 0)
        tx1 = min(int(np.floor((poses[p, 0] + reach - origin_x) / tile_size)) + 1, n_tx - 1)
        ty1 = min(int(np.floor((poses[p, 1] + reach - origin_y) / tile_size)) + 1, n_ty - 1)
        foreign = 0
        foreign_hits = 0
        without_hits = 0
        for ty in range(ty0, ty1 + 1):
            for tx in range(tx0, tx1 + 1):
                t = tables[p, ty, tx]
                n = 0 if t < 0 else held[t]
                without_hits += PARTS - n
                if t < 0 or refs[t] != 1:
                    foreign += 1
                    foreign_hits += n
        tiles[p] = foreign
        blocks[p] = foreign_hits + min(without_hits, beams)


@njit
def _copy_tile(lo, new, t):
    """Tile ``new``'s log-odds become tile ``t``'s (0 for ``t < 0``). Element by element, as
    :func:`_copy_block`: an array assigned to a slice compiles numba's shape-mismatch message
    (string formatting), seconds of a cold start."""
    for cy in range(TILE):
        for cx in range(TILE):
            lo[new, cy, cx] = 0.0 if t < 0 else lo[t, cy, cx]


@njit
def _copy_block(hit_blocks, new, h):
    """Hit block ``new`` becomes a copy of block ``h``."""
    for hy in range(PART):
        for hx in range(PART):
            for k in range(3):
                hit_blocks[new, hy, hx, k] = hit_blocks[h, hy, hx, k]


@njit
def _integrate_map(p, tables, refs, lo, hit_of, hit_blocks, stack, bottom, top, hit_stack, hit_bottom,
                   hit_top, source, base, start, origin_x, origin_y, resolution, poses, angles, ranges,
                   range_min, range_max, usable_range, near_range, no_return_range, l_free, l_occ, l_min,
                   l_max):
    """Integrate the scan (its echoes trusted to ``usable_range``; beyond ``near_range`` see
    :func:`~slam_core.raycast.far_gap`) into map ``p`` from beam ``start[p, 0]``'s cell ``start[p, 1]`` on, in
    one pass: a tile that is not the map's own is copied (or created) when a write first changes
    it, into a tile taken from ``stack[bottom[p]:top[p]]`` (top down; ``source`` records what
    it copies), a hit block likewise. Shared tiles are only read, and their reference counts
    left as they are (see :func:`_settle`). Returns where it stopped for want of a tile or a
    block, ``(-1, 0)`` when done."""
    inv = 1.0 / resolution
    n_ty, n_tx = tables.shape[1], tables.shape[2]
    buf = np.empty((ray_buffer_size(usable_range, resolution), 2), dtype=np.int64)
    gx0 = (poses[p, 0] - origin_x) * inv
    gy0 = (poses[p, 1] - origin_y) * inv
    first = start[p, 1]
    for b in range(start[p, 0], angles.shape[0]):
        use, hit, ex, ey = beam_endpoint(poses[p, 0], poses[p, 1], poses[p, 2], angles[b], ranges[b],
                                         range_min, range_max, usable_range, no_return_range)
        if not use:
            first = 0
            continue
        gx1, gy1 = (ex - origin_x) * inv, (ey - origin_y) * inv
        n = trace_ray(gx0, gy0, gx1, gy1, buf)
        gap_lo, gap_hi = far_gap(buf, n, hit, gx0, gy0, gx1, gy1, usable_range, near_range, FAR_TAIL, inv)
        for k in range(first, n):
            ix = buf[k, 0]
            iy = buf[k, 1]
            ty = iy >> TILE_BITS
            tx = ix >> TILE_BITS
            if ix < 0 or iy < 0 or ty >= n_ty or tx >= n_tx or (gap_lo < gap_hi and gap_lo <= k < gap_hi):
                continue
            cy = iy & (TILE - 1)
            cx = ix & (TILE - 1)
            part = part_of(cy, cx)
            echo = hit and k == n - 1
            t = tables[p, ty, tx]
            if t < 0 or refs[t] != 1:
                # A free-space write to a cell already at l_min changes nothing: the tile stays shared.
                if not echo and t >= 0 and np.float32(max(lo[t, cy, cx] + l_free, l_min)) == lo[t, cy, cx]:
                    continue
                blocks = 0 if t < 0 else _parts_with_hits(hit_of, t)  # copied with the tile
                if echo and (t < 0 or hit_of[t, part] < 0):
                    blocks += 1
                if top[p] == bottom[p] or hit_top[p] - hit_bottom[p] < blocks:
                    return b, k
                top[p] -= 1
                new = stack[top[p]]
                source[top[p] - base] = t
                refs[new] = 1
                _copy_tile(lo, new, t)
                for j in range(PARTS):
                    hit_of[new, j] = -1
                    if t >= 0 and hit_of[t, j] >= 0:
                        hit_top[p] -= 1
                        h = hit_stack[hit_top[p]]
                        _copy_block(hit_blocks, h, hit_of[t, j])
                        hit_of[new, j] = h
                tables[p, ty, tx] = new
                t = new
            elif echo and hit_of[t, part] < 0 and hit_top[p] == hit_bottom[p]:
                return b, k
            if echo:
                if hit_of[t, part] < 0:
                    hit_top[p] -= 1
                    h = hit_stack[hit_top[p]]
                    hit_blocks[h] = 0.0
                    hit_of[t, part] = h
                lo[t, cy, cx] = min(lo[t, cy, cx] + l_occ, l_max)
                h = hit_of[t, part]
                hy, hx = cy & (PART - 1), cx & (PART - 1)
                hit_blocks[h, hy, hx, HIT_X] += ex - (origin_x + ix * resolution)
                hit_blocks[h, hy, hx, HIT_Y] += ey - (origin_y + iy * resolution)
                hit_blocks[h, hy, hx, HIT_N] += 1.0
            else:
                lo[t, cy, cx] = max(lo[t, cy, cx] + l_free, l_min)
        first = 0
    return -1, 0


@njit
def _integrate(first, stop, tables, refs, lo, hit_of, hit_blocks, stack, bottom, top, hit_stack, hit_bottom,
               hit_top, source, base, start, origin_x, origin_y, resolution, poses, angles, ranges, range_min,
               range_max, usable_range, near_range, no_return_range, l_free, l_occ, l_min, l_max):
    """:func:`_integrate_map` for maps ``first`` to ``stop - 1`` not yet done (``start[p, 0] >= 0``);
    ``start`` becomes where each stopped. Maps are split over threads (:func:`slam_core.jit.split`)."""
    for p in range(first, stop):
        if start[p, 0] >= 0:
            b, k = _integrate_map(p, tables, refs, lo, hit_of, hit_blocks, stack, bottom, top, hit_stack,
                                  hit_bottom, hit_top, source, base, start, origin_x, origin_y, resolution,
                                  poses, angles, ranges, range_min, range_max, usable_range, near_range,
                                  no_return_range, l_free, l_occ, l_min, l_max)
            start[p, 0] = b
            start[p, 1] = k


@njit
def _take(free_stack, free_top):
    """Pop an entry's index off a pool's free stack."""
    free_top[0] -= 1
    return free_stack[free_top[0]]


@njit
def _compact(stack, base, bottom, top):
    """Move the entries the maps left (``stack[bottom[p]:top[p]]``, slices in order of ``p``)
    down to ``base``; returns the stack's new top."""
    end = base
    for p in range(bottom.shape[0]):
        for i in range(bottom[p], top[p]):
            stack[end] = stack[i]
            end += 1
    return end


@njit
def _free_blocks(hit_of, t, hit_stack, hit_free_top):
    """Put tile ``t``'s hit blocks back on their free stack."""
    for j in range(PARTS):
        if hit_of[t, j] >= 0:
            hit_stack[hit_free_top[0]] = hit_of[t, j]
            hit_free_top[0] += 1
            hit_of[t, j] = -1


@njit
def _settle(refs, hit_of, source, stack, free_top, base, bottom, ceiling, top, hit_stack, hit_free_top,
            hit_base, hit_bottom, hit_top):
    """After :func:`_integrate`: one reference fewer for every tile copied, freeing (with its hit
    block) each that no map holds any more, and the entries the maps did not take put back."""
    for p in range(top.shape[0]):
        for i in range(top[p] - base, ceiling[p] - base):
            s = source[i]
            if s >= 0:
                refs[s] -= 1
                if refs[s] != 0:
                    source[i] = -1  # only the copy that freed it pushes it below
    free_top[0] = _compact(stack, base, bottom, top)
    hit_free_top[0] = _compact(hit_stack, hit_base, hit_bottom, hit_top)
    for p in range(top.shape[0]):
        for i in range(top[p] - base, ceiling[p] - base):
            s = source[i]
            if s >= 0:
                stack[free_top[0]] = s
                free_top[0] += 1
                _free_blocks(hit_of, s, hit_stack, hit_free_top)


@njit
def _is_settled(lo, t, l_min):
    """Whether every cell of tile ``t`` is at ``l_min``."""
    for cy in range(TILE):
        for cx in range(TILE):
            if lo[t, cy, cx] != l_min:
                return False
    return True


@njit
def _share_settled(tables, refs, lo, hit_of, free_stack, free_top, l_min):
    """Point every map's settled tiles (every cell at ``l_min``, no hit block) at one of them,
    freeing the others."""
    settled = np.zeros(refs.shape[0], np.bool_)
    keep = -1
    for t in range(refs.shape[0]):
        if refs[t] > 0 and _parts_with_hits(hit_of, t) == 0 and _is_settled(lo, t, l_min):
            settled[t] = True
            if keep < 0:
                keep = t
    for p in range(tables.shape[0]):
        for ty in range(tables.shape[1]):
            for tx in range(tables.shape[2]):
                t = tables[p, ty, tx]
                if t >= 0 and t != keep and settled[t]:
                    tables[p, ty, tx] = keep
                    refs[keep] += 1
                    refs[t] -= 1
                    if refs[t] == 0:
                        free_stack[free_top[0]] = t
                        free_top[0] += 1


@njit
def _retable(tables, refs, free_stack, free_top, hit_of, hit_free_stack, hit_free_top, parents):
    """Replace the maps by copies of ``parents``, keeping reference counts and the free stacks. Only
    the parents' tables are copied (each once); every tile in them gains its children's references
    before any map's old tiles are released."""
    row = np.full(tables.shape[0], -1, np.int64)
    kept = 0
    for p in range(parents.shape[0]):
        if row[parents[p]] < 0:
            row[parents[p]] = kept
            kept += 1
    copies = np.empty((kept, tables.shape[1], tables.shape[2]), tables.dtype)
    for p in range(tables.shape[0]):
        if row[p] >= 0:
            for ty in range(tables.shape[1]):
                for tx in range(tables.shape[2]):
                    copies[row[p], ty, tx] = tables[p, ty, tx]
    for p in range(tables.shape[0]):
        for ty in range(tables.shape[1]):
            for tx in range(tables.shape[2]):
                t = copies[row[parents[p]], ty, tx]
                if t >= 0:
                    refs[t] += 1
    for p in range(tables.shape[0]):
        for ty in range(tables.shape[1]):
            for tx in range(tables.shape[2]):
                t = tables[p, ty, tx]
                if t >= 0:
                    refs[t] -= 1
                    if refs[t] == 0:
                        free_stack[free_top[0]] = t
                        free_top[0] += 1
                        _free_blocks(hit_of, t, hit_free_stack, hit_free_top)
                tables[p, ty, tx] = copies[row[parents[p]], ty, tx]


def part_cells(part: int) -> tuple[slice, slice]:
    """The cells ``[rows, columns]`` of a tile that its part ``part`` holds."""
    y, x = divmod(int(part), TILE // PART)
    return slice(y * PART, (y + 1) * PART), slice(x * PART, (x + 1) * PART)


def _slices(free: int, want: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """Consecutive slices ``[bottom[p], ceiling[p])`` of the top of a free stack of ``free``
    entries, ``want[p]`` long; when they do not fit, each gets ``MIN_SLICE`` (if that fits)
    and a share of the rest in proportion to what it wants. Also their base."""
    total = int(want.sum())
    sizes = want
    if total > free:
        least = np.minimum(want, MIN_SLICE)
        if int(least.sum()) > free:
            least = np.zeros_like(want)
        more = want - least
        sizes = least + more * (free - int(least.sum())) // max(int(more.sum()), 1)
    base = free - int(sizes.sum())
    ceiling = base + np.cumsum(sizes)
    return ceiling - sizes, ceiling, base


def _grown_stack(stack: np.ndarray, free: int, old: int, new: int) -> np.ndarray:
    """A free stack of ``free`` entries (of a pool of ``old``) with the pool's new entries up to
    ``new`` added below the old free ones' top, lowest on top."""
    out = np.empty(new, np.int32)
    out[:free] = stack[:free]
    out[free:free + new - old] = np.arange(new - 1, old - 1, -1, dtype=np.int32)
    return out


class TiledMaps:
    """``n`` occupancy maps over one growing tile lattice, sharing tiles copy-on-write.

    The pools (tiles, hit blocks) are allocated zeroed for ``capacity`` entries and handed
    out from their low ends, so the memory a process really holds is that of the entries
    taken so far (the operating system maps zeroed pages only when they are first written);
    when full a pool grows by an eighth (or what is needed), in place, the tile pool only after
    its settled tiles were shared (:func:`_share_settled`); they are shared too before the maps may
    hold more tiles than ``most_tiles``, the most they held at once so far, at most once in
    ``sweep_every`` integrations (0: only before a pool grows). The matching kernels read ``lo``
    and ``hits`` (each tile's hit block index, and the blocks).
    """

    def __init__(self, n_maps: int, resolution: float = 0.05, model: SensorModel | None = None,
                 capacity: int = 16384, sweep_every: int = SWEEP_EVERY):
        self.resolution = float(resolution)
        self.model = model or SensorModel()
        self._pools = MappedPools()  # the large pools, grown in place
        self.lo = self._pools.zeros("lo", (capacity, TILE, TILE), np.float32)
        self.refs = np.zeros(capacity, np.int32)
        self.hit_of = np.full((capacity, PARTS), -1, np.int32)
        self.free_stack = np.arange(capacity - 1, -1, -1, dtype=np.int32)
        self.free_top = np.array([capacity], np.int64)
        self.hit_blocks = self._pools.zeros("hit_blocks", (capacity, PART, PART, 3), np.float32)
        self.hit_free_stack = np.arange(capacity - 1, -1, -1, dtype=np.int32)
        self.hit_free_top = np.array([capacity], np.int64)
        self.tables = np.full((n_maps, 0, 0), -1, np.int32)
        self.origin = np.zeros(2)
        #: Tiles and hit blocks a map took in the last integrate, on average: slices of that and
        #: MIN_SLICE keep the maps taking from the stacks' tops, the entries already touched.
        self._took = np.zeros(2, np.int64)
        #: The most tiles ever in use at once, the integrations so far and at the last sweep.
        self.most_tiles = 0
        self.sweep_every = sweep_every
        self._integrations = 0
        self._swept_at = 0

    @property
    def n_maps(self) -> int:
        return self.tables.shape[0]

    @property
    def tiles_in_use(self) -> int:
        return int(len(self.refs) - self.free_top[0])

    @property
    def hit_blocks_in_use(self) -> int:
        return int(len(self.hit_blocks) - self.hit_free_top[0])

    @property
    def hits(self) -> tuple[np.ndarray, np.ndarray]:
        """What the matching kernels read of the endpoints: ``(hit_of, hit_blocks)``."""
        return self.hit_of, self.hit_blocks

    @property
    def tile_size(self) -> float:
        return self.resolution * TILE

    def nbytes(self) -> int:
        """Bytes of the tiles and hit blocks in use and of the tables."""
        per_tile = (self.lo.nbytes + self.refs.nbytes + self.hit_of.nbytes) // len(self.refs)
        per_block = self.hit_blocks.nbytes // len(self.hit_blocks)
        return self.tiles_in_use * per_tile + self.hit_blocks_in_use * per_block + self.tables.nbytes

    def ensure_contains(self, xmin: float, ymin: float, xmax: float, ymax: float) -> None:
        """Grow the common tile lattice (whole tiles, with margin) to cover a world box."""
        ts = self.tile_size
        _, n_ty, n_tx = self.tables.shape
        if n_tx == 0:
            lo = np.floor(np.array([xmin, ymin]) / ts) - GROW_MARGIN_TILES
            hi = np.floor(np.array([xmax, ymax]) / ts) + GROW_MARGIN_TILES + 1
            self.origin = lo * ts
            self.tables = np.full((self.n_maps, int(hi[1] - lo[1]), int(hi[0] - lo[0])), -1, np.int32)
            return
        t0 = np.floor((np.array([xmin, ymin]) - self.origin) / ts).astype(int)
        t1 = np.floor((np.array([xmax, ymax]) - self.origin) / ts).astype(int)
        left = GROW_MARGIN_TILES - t0[0] if t0[0] < 0 else 0
        bottom = GROW_MARGIN_TILES - t0[1] if t0[1] < 0 else 0
        right = t1[0] - n_tx + 1 + GROW_MARGIN_TILES if t1[0] >= n_tx else 0
        top = t1[1] - n_ty + 1 + GROW_MARGIN_TILES if t1[1] >= n_ty else 0
        if left or bottom or right or top:
            self.tables = np.pad(self.tables, ((0, 0), (bottom, top), (left, right)), constant_values=-1)
            self.origin = self.origin - np.array([left, bottom]) * ts

    def integrate(self, poses: np.ndarray, scan) -> None:
        """Integrate ``scan`` into map ``i`` at ``poses[i]``: one pass over each map's rays, maps in
        parallel, a shared tile copied when a write first changes it.

        Each map takes its new tiles and hit blocks from a slice of the free stacks of its own,
        sized by :func:`_demand`'s bound or what a map took last time (and MIN_SLICE), whichever is less
        (shorter when the pools hold fewer); a map whose slice runs out stops, and goes on where
        it stopped with what the others left, or once the pools have grown.
        """
        poses = np.ascontiguousarray(poses, dtype=np.float64).reshape(self.n_maps, 3)
        m = self.model
        usable = m.reach(scan)
        reach = min(usable, max(m.no_return_range, float(np.max(scan.ranges, initial=0.0))))
        self.ensure_contains(poses[:, 0].min() - reach, poses[:, 1].min() - reach,
                             poses[:, 0].max() + reach, poses[:, 1].max() + reach)
        tiles = np.empty(self.n_maps, np.int64)
        blocks = np.empty(self.n_maps, np.int64)
        held = np.empty(len(self.refs), np.int64)
        _count_held(self.refs, self.hit_of, held)
        split(_demand, self.n_maps, self.tables, self.refs, held, self.origin[0], self.origin[1],
              self.tile_size, poses, reach, len(scan.angles), tiles, blocks)
        bounds = tiles, blocks
        tiles = np.minimum(tiles, self._took[0] + MIN_SLICE)
        blocks = np.minimum(blocks, self._took[1] + MIN_SLICE)
        self._integrations += 1
        if (self.sweep_every > 0 and self.tiles_in_use + int(tiles.sum()) > self.most_tiles
                and self._integrations - self._swept_at >= self.sweep_every):
            self._sweep_settled()
        start = np.zeros((self.n_maps, 2), np.int64)
        took = np.zeros((self.n_maps, 2), np.int64)
        while True:
            bottom, ceiling, base = _slices(int(self.free_top[0]), tiles)
            hit_bottom, hit_ceiling, hit_base = _slices(int(self.hit_free_top[0]), blocks)
            top, hit_top = ceiling.copy(), hit_ceiling.copy()
            source = np.empty(int(self.free_top[0]) - base, np.int32)
            split(_integrate, self.n_maps, self.tables, self.refs, self.lo, self.hit_of, self.hit_blocks,
                  self.free_stack, bottom, top, self.hit_free_stack, hit_bottom, hit_top, source, base, start,
                  self.origin[0], self.origin[1], self.resolution, poses, scan.angles, scan.ranges,
                  scan.range_min, scan.range_max, usable, m.usable_range, m.no_return_range, m.l_free,
                  m.l_occ, m.l_min, m.l_max)
            _settle(self.refs, self.hit_of, source, self.free_stack, self.free_top, base, bottom, ceiling,
                    top, self.hit_free_stack, self.hit_free_top, hit_base, hit_bottom, hit_top)
            took[:, 0] += ceiling - top
            took[:, 1] += hit_ceiling - hit_top
            self.most_tiles = max(self.most_tiles, self.tiles_in_use)
            pending = start[:, 0] >= 0
            if not pending.any():
                self._took = took.sum(axis=0) // self.n_maps
                return
            # The maps left go on, wanting twice as much, with what the others left; the pools grow
            # only when fewer than MIN_SLICE entries each are free: no sooner than needed.
            tiles = np.where(pending, np.maximum(np.minimum(2 * tiles, bounds[0]), MIN_SLICE), 0)
            blocks = np.where(pending, np.maximum(np.minimum(2 * blocks, bounds[1]), MIN_SLICE), 0)
            self._reserve(MIN_SLICE * int(pending.sum()))

    def resample(self, parents: np.ndarray) -> None:
        """Map ``i`` becomes a copy of map ``parents[i]`` (sharing every tile)."""
        _retable(self.tables, self.refs, self.free_stack, self.free_top, self.hit_of, self.hit_free_stack,
                 self.hit_free_top, np.ascontiguousarray(parents, dtype=np.int64))

    def _reserve(self, needed: int, blocks: int | None = None) -> None:
        """Room for ``needed`` more tiles and ``blocks`` (as many if not given) more hit blocks.
        Before the tile pool grows, its settled tiles are shared (:func:`_share_settled`); it
        grows only if that left fewer than ``needed`` or a sixteenth of it free (so that a sweep
        that freed little is not followed by another at once)."""
        if self.free_top[0] < needed:
            self._sweep_settled()
            free = int(self.free_top[0])
            if free < max(needed, len(self.refs) // (2 * GROW_DIVISOR)):
                old = len(self.refs)
                new = max(old + needed - free, old + old // GROW_DIVISOR)
                for name in ("lo", "refs", "hit_of"):
                    self._grow(name, new)
                self.hit_of[old:] = -1
                self.free_stack = _grown_stack(self.free_stack, free, old, new)
                self.free_top[0] = free + new - old
        free = int(self.hit_free_top[0])
        needed = needed if blocks is None else blocks
        if free < needed:
            old = len(self.hit_blocks)
            new = max(old + needed - free, old + old // GROW_DIVISOR)
            self._grow("hit_blocks", new)
            self.hit_free_stack = _grown_stack(self.hit_free_stack, free, old, new)
            self.hit_free_top[0] = free + new - old

    def _sweep_settled(self) -> None:
        """Make every map's settled tiles one shared tile (:func:`_share_settled`)."""
        _share_settled(self.tables, self.refs, self.lo, self.hit_of, self.free_stack, self.free_top,
                       np.float32(self.model.l_min))
        self._swept_at = self._integrations

    def _grow(self, name: str, length: int) -> None:
        """Give the pool array ``name`` ``length`` rows, the new ones zero, in place when nothing else
        refers to it (so the old rows are never held twice, as a copy would). The tiles and hit
        blocks are mapped pools (:mod:`slam_core.mapped_pools`): their new rows take no memory
        until written (a resized array's new rows are zeroed, and so held, at once)."""
        if name in self._pools:
            self._pools.grow(self, name, length)
            return
        array = self.__dict__.pop(name)  # so that this is its only reference
        shape = (length, *array.shape[1:])
        try:
            array.resize(shape)
        except ValueError:
            array = np.concatenate([array, np.zeros((length - len(array), *shape[1:]), array.dtype)])
        setattr(self, name, array)

    def to_grid(self, index: int) -> OccupancyGrid:
        """Map ``index`` as a dense :class:`OccupancyGrid` (cropped to its known tiles)."""
        grid = OccupancyGrid(self.resolution, self.origin, model=self.model)
        dense = self._dense(index, lambda t: self.lo[t])
        if dense is not None:
            grid.data, grid.origin = dense
        return grid

    def extent(self, index: int) -> tuple[float, float, float, float] | None:
        """World bounds ``(xmin, ymin, xmax, ymax)`` of :meth:`to_grid` ``(index)``, without making it
        (``None`` for a map with no known tile)."""
        used = self._known_tiles(index)
        if used is None:
            return None
        (ty0, tx0), (ty1, tx1) = used.min(axis=0), used.max(axis=0)
        x0, y0 = self.origin + np.array([tx0, ty0]) * self.tile_size
        x1, y1 = self.origin + np.array([tx1 + 1, ty1 + 1]) * self.tile_size
        return float(x0), float(y0), float(x1), float(y1)

    def hit_sums(self, index: int) -> np.ndarray:
        """Map ``index``'s per-cell hit sums ``(ny, nx, 3)`` (``HIT_*``), aligned with :meth:`to_grid`."""
        dense = self._dense(index, self.tile_hit_sums)
        return np.zeros((0, 0, 3), np.float32) if dense is None else dense[0]

    def tile_hit_sums(self, t: int) -> np.ndarray:
        """Tile ``t``'s hit sums ``(TILE, TILE, 3)``: its parts' blocks, zeros for parts without one."""
        sums = np.zeros((TILE, TILE, 3), np.float32)
        for part in np.flatnonzero(self.hit_of[t] >= 0):
            sums[part_cells(part)] = self.hit_blocks[self.hit_of[t, part]]
        return sums

    def _dense(self, index: int, tile_values) -> tuple[np.ndarray, np.ndarray] | None:
        """``tile_values(t)`` of map ``index``'s tiles ``t`` as one array over its known tiles, and
        that array's origin."""
        table = self.tables[index]
        used = self._known_tiles(index)
        if used is None:
            return None
        (ty0, tx0), (ty1, tx1) = used.min(axis=0), used.max(axis=0)
        first = tile_values(table[tuple(used[0])])
        data = np.zeros(((ty1 - ty0 + 1) * TILE, (tx1 - tx0 + 1) * TILE, *first.shape[2:]), first.dtype)
        for ty, tx in used:
            y, x = (ty - ty0) * TILE, (tx - tx0) * TILE
            data[y:y + TILE, x:x + TILE] = tile_values(table[ty, tx])
        return data, self.origin + np.array([tx0, ty0]) * self.tile_size

    def _known_tiles(self, index: int) -> np.ndarray | None:
        """``(ty, tx)`` of map ``index``'s known tiles (``None`` if it has none)."""
        used = np.argwhere(self.tables[index] >= 0)
        return used if len(used) else None

    def seed_from_grid(self, grid: OccupancyGrid, hit_sums: np.ndarray | None = None) -> None:
        """Start every map as the same copy of ``grid`` (e.g. a checkpoint).

        ``hit_sums`` (as :meth:`hit_sums` gives them) restore the endpoints exactly; without them
        every occupied cell gets one hit at its centre.
        """
        if hit_sums is not None and hit_sums.shape != (*grid.shape, 3):
            raise ValueError(f"hit sums of shape {hit_sums.shape} do not fit a {grid.shape} grid")
        if abs(grid.resolution - self.resolution) > 1e-12:
            raise ValueError(f"grid resolution {grid.resolution} != map resolution {self.resolution}")
        x0, y0, x1, y1 = grid.extent()
        self.ensure_contains(x0, y0, x1, y1)
        offset = np.round((grid.origin - self.origin) / self.resolution).astype(int)
        ny, nx = grid.shape
        t_lo = offset // TILE
        t_hi = (offset + np.array([nx, ny]) - 1) // TILE
        tiles = (t_hi[0] - t_lo[0] + 1) * (t_hi[1] - t_lo[1] + 1)
        self._reserve(tiles, tiles * PARTS)
        occupied_lo = self.model.l_occ
        for ty in range(t_lo[1], t_hi[1] + 1):
            for tx in range(t_lo[0], t_hi[0] + 1):
                block = np.zeros((TILE, TILE), np.float32)
                gy0, gx0 = ty * TILE - offset[1], tx * TILE - offset[0]
                sy, sx = slice(max(gy0, 0), min(gy0 + TILE, ny)), slice(max(gx0, 0), min(gx0 + TILE, nx))
                inside = slice(sy.start - gy0, sy.stop - gy0), slice(sx.start - gx0, sx.stop - gx0)
                block[inside] = grid.data[sy, sx]
                if not block.any():
                    continue
                t = _take(self.free_stack, self.free_top)
                self.lo[t] = block
                hits = np.zeros((TILE, TILE, 3), np.float32)
                if hit_sums is not None:
                    hits[inside] = hit_sums[sy, sx]
                else:
                    occ = block > occupied_lo * 0.5
                    hits[occ] = (0.5 * self.resolution, 0.5 * self.resolution, 1.0)
                self.hit_of[t] = -1
                for part in range(PARTS):
                    sums = hits[part_cells(part)]
                    if sums[..., HIT_N].any():
                        self.hit_of[t, part] = _take(self.hit_free_stack, self.hit_free_top)
                        self.hit_blocks[self.hit_of[t, part]] = sums
                self.refs[t] = self.n_maps
                self.tables[:, ty, tx] = t
        self.most_tiles = max(self.most_tiles, self.tiles_in_use)
