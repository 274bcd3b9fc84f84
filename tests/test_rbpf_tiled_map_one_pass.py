"""The one-pass, parallel, copy-on-write integrate against a plain per-map reference.

The reference keeps every map as its own dict of cells (global cell indices), applies each
beam with the inverse sensor model of :mod:`slam_core.occupancy_grid` (float32 cells, float64
arithmetic, as the kernels do) and copies whole maps on resampling: no tiles, no sharing.
"""

import numpy as np
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from slam_core.occupancy_grid import OccupancyGrid
from slam_core.raycast import FAR_TAIL, beam_endpoint, far_gap, ray_buffer_size, trace_ray
from slam_core.rbpf.tiled_map import HIT_N, HIT_X, HIT_Y, TILE, TiledMaps
from slam_core.scan import Scan


def reference_integrate(maps: TiledMaps, cells: dict, pose, scan: Scan) -> None:
    """Apply ``scan`` from ``pose`` to one reference map ``cells``: ``(gx, gy) -> [lo, x, y, n]``."""
    m, res = maps.model, maps.resolution
    ox, oy = maps.origin
    shift = np.round(maps.origin / res).astype(int)
    reach = m.reach(scan)
    buf = np.empty((ray_buffer_size(reach, res), 2), np.int64)
    for angle, rng in zip(scan.angles, scan.ranges, strict=True):
        use, hit, ex, ey = beam_endpoint(pose[0], pose[1], pose[2], angle, rng, scan.range_min,
                                         scan.range_max, reach, m.no_return_range)
        if not use:
            continue
        gx0, gy0, gx1, gy1 = (pose[0] - ox) / res, (pose[1] - oy) / res, (ex - ox) / res, (ey - oy) / res
        n = trace_ray(gx0, gy0, gx1, gy1, buf)
        gap = range(*far_gap(buf, n, hit, gx0, gy0, gx1, gy1, reach, m.usable_range, FAR_TAIL, 1.0 / res))
        for k in range(n):
            if k in gap:
                continue
            ix, iy = int(buf[k, 0]), int(buf[k, 1])
            cell = cells.setdefault((ix + shift[0], iy + shift[1]), [np.float32(0.0)] * 4)
            if hit and k == n - 1:
                cell[0] = np.float32(min(float(cell[0]) + m.l_occ, m.l_max))
                cell[1] = np.float32(float(cell[1]) + (ex - (ox + ix * res)))
                cell[2] = np.float32(float(cell[2]) + (ey - (oy + iy * res)))
                cell[3] = np.float32(float(cell[3]) + 1.0)
            else:
                cell[0] = np.float32(max(float(cell[0]) + m.l_free, m.l_min))


def resolved(maps: TiledMaps, index: int) -> dict:
    """Map ``index``'s cells in its tiles, keyed like the reference's; cells never written left out."""
    places = np.argwhere(maps.tables[index] >= 0)
    tiles = maps.tables[index][places[:, 0], places[:, 1]]
    hits = np.array([maps.tile_hit_sums(t) for t in tiles]).reshape(len(tiles), TILE, TILE, 3)
    values = np.concatenate([maps.lo[tiles][..., None], hits[..., [HIT_X, HIT_Y, HIT_N]]], axis=-1)
    cy, cx = np.mgrid[0:TILE, 0:TILE]
    shift = np.round(maps.origin / maps.resolution).astype(int)
    gx = places[:, 1, None, None] * TILE + cx + shift[0]
    gy = places[:, 0, None, None] * TILE + cy + shift[1]
    written = np.any(values != 0, axis=-1)
    keys = zip(gx[written].tolist(), gy[written].tolist(), strict=True)
    return dict(zip(keys, values[written].tolist(), strict=True))


def tiles_by_place(maps: TiledMaps) -> list[dict]:
    """Per map, its tile indices keyed by global tile coordinates."""
    shift = np.round(maps.origin / maps.tile_size).astype(int)
    return [{(tx + shift[0], ty + shift[1]): maps.tables[p, ty, tx]
             for ty, tx in np.argwhere(maps.tables[p] >= 0)} for p in range(maps.n_maps)]


def is_settled(maps: TiledMaps, t: int) -> bool:
    """Whether tile ``t`` is settled free space: every cell at ``l_min``, no hit block."""
    return bool(np.all(maps.hit_of[t] < 0) and np.all(maps.lo[t] == np.float32(maps.model.l_min)))


def assert_pools_consistent(maps: TiledMaps) -> None:
    """Reference counts are the tables' references; the free stacks hold exactly the rest."""
    held = maps.tables[maps.tables >= 0]
    counts = np.bincount(held, minlength=len(maps.refs))
    in_use = counts > 0
    np.testing.assert_array_equal(maps.refs[in_use], counts[in_use])
    free = maps.free_stack[:maps.free_top[0]]
    assert len(np.unique(free)) == len(free)
    np.testing.assert_array_equal(np.sort(free), np.flatnonzero(~in_use))
    blocks = maps.hit_of[in_use]
    blocks = blocks[blocks >= 0]
    hit_free = maps.hit_free_stack[:maps.hit_free_top[0]]
    assert len(np.unique(blocks)) == len(blocks)
    everything = np.sort(np.concatenate([blocks, hit_free]))
    np.testing.assert_array_equal(everything, np.arange(len(maps.hit_blocks)))


def random_scan(rng, n):
    angles = np.sort(rng.uniform(-np.pi, np.pi, n))
    ranges = rng.uniform(0.2, 5.0, n)
    ranges[rng.random(n) < 0.15] = 80.0  # no return: free space out to the no-return range
    ranges[rng.random(n) < 0.05] = 0.0  # no measurement
    return Scan(angles, ranges, 0.1, 80.0)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow],
          phases=[Phase.explicit, Phase.reuse, Phase.generate])  # shrinking these takes minutes
@given(seed=st.integers(0, 2**32 - 1), n_maps=st.integers(1, 9), capacity=st.sampled_from([4, 64, 4096]),
       settled=st.booleans())
def test_one_pass_integrate_equals_the_per_map_reference(seed, n_maps, capacity, settled):
    """Random scans from nearby poses, resampled in between (parents repeated, so tiles are
    shared), from a small pool (maps run out of their slices and resume) or a large one,
    optionally over a settled map (cells at l_min that free space leaves as they are)."""
    rng = np.random.default_rng(seed)
    maps = TiledMaps(n_maps, 0.05, capacity=capacity)
    reference = [{} for _ in range(n_maps)]
    if settled:
        low = np.float32(maps.model.l_min)
        grid = OccupancyGrid(0.05, origin=(-3.0, -3.0), shape=(120, 120), model=maps.model,
                             data=np.full((120, 120), low))
        maps.seed_from_grid(grid)
        for cells in reference:
            for gy in range(-60, 60):
                for gx in range(-60, 60):
                    cells[(gx, gy)] = [low, np.float32(0), np.float32(0), np.float32(0)]
    for _ in range(4):
        poses = np.column_stack([rng.normal(0, 1.0, n_maps), rng.normal(0, 1.0, n_maps),
                                 rng.uniform(-np.pi, np.pi, n_maps)])
        scan = random_scan(rng, int(rng.integers(1, 60)))
        before = tiles_by_place(maps)
        contents = [resolved(maps, p) for p in range(n_maps)]
        maps.integrate(poses, scan)
        for p in range(n_maps):
            reference_integrate(maps, reference[p], poses[p], scan)
            assert resolved(maps, p) == {c: v for c, v in reference[p].items() if any(x != 0 for x in v)}
        assert_pools_consistent(maps)
        # A map took a new tile only where a write changed what it held there, or the shared
        # settled tile (the pool was swept before growing).
        after = tiles_by_place(maps)
        for p in range(n_maps):
            now = resolved(maps, p)
            for place, t in after[p].items():
                if before[p].get(place) != t:
                    keys = [(place[0] * TILE + cx, place[1] * TILE + cy)
                            for cy in range(TILE) for cx in range(TILE)]
                    assert any(now.get(k) != contents[p].get(k) for k in keys) or is_settled(maps, t)
        parents = rng.integers(0, n_maps, n_maps)
        maps.resample(parents)
        reference = [dict((c, list(v)) for c, v in reference[q].items()) for q in parents]
        assert_pools_consistent(maps)
    assert capacity > 64 or len(maps.refs) > capacity  # the small pools grew on the way


def swept_and_plain(seed: int, n_maps: int) -> tuple[TiledMaps, TiledMaps]:
    """The same random integrate / resample sequence into maps from a small pool (swept for
    settled tiles whenever it would grow, and as shipped) and from one that never grows (never
    swept). Each
    dense scan, its echoes 3 m out or more, is integrated a few times from nearby poses, so
    that the free space within settles at ``l_min``. Asserts that every map is the same in
    both after each round."""
    rng = np.random.default_rng(seed)
    swept = TiledMaps(n_maps, 0.05, capacity=4)
    plain = TiledMaps(n_maps, 0.05, capacity=1 << 15, sweep_every=0)
    for _ in range(4):
        centre = rng.normal(0.0, 1.0, 3)
        scan = random_scan(rng, 240)
        scan.ranges[(scan.ranges > 0.0) & (scan.ranges < 3.0)] += 3.0
        for _ in range(int(rng.integers(1, 8))):
            poses = centre + rng.normal(0.0, [0.02, 0.02, 0.01], (n_maps, 3))
            swept.integrate(poses, scan)
            plain.integrate(poses, scan)
        for p in range(n_maps):
            assert resolved(swept, p) == resolved(plain, p)
        assert_pools_consistent(swept)
        parents = rng.integers(0, n_maps, n_maps)
        swept.resample(parents)
        plain.resample(parents)
    assert len(plain.refs) == 1 << 15
    return swept, plain


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow],
          phases=[Phase.explicit, Phase.reuse, Phase.generate])
@given(seed=st.integers(0, 2**32 - 1), n_maps=st.integers(1, 6))
def test_sharing_settled_tiles_changes_no_map(seed, n_maps):
    swept, plain = swept_and_plain(seed, n_maps)
    assert swept.tiles_in_use <= plain.tiles_in_use


def test_settled_tiles_are_shared_before_the_pool_grows():
    swept, plain = swept_and_plain(0, 8)
    settled = [sum(is_settled(m, t) for t in np.unique(m.tables[m.tables >= 0])) for m in (swept, plain)]
    assert settled[0] < settled[1]
    assert swept.tiles_in_use < plain.tiles_in_use
