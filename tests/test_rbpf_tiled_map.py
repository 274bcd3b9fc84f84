"""Copy-on-write tiled maps: equal to the dense grid, shared until written."""

from dataclasses import replace

import numpy as np

from slam_core.occupancy_grid import OccupancyGrid
from slam_core.rbpf.tiled_map import HIT_N, PART, SWEEP_EVERY, TILE, TiledMaps
from slam_core.scan import Scan


def random_scan(rng, n=90):
    angles = np.sort(rng.uniform(-np.pi, np.pi, n))
    ranges = rng.uniform(0.2, 6.0, n)
    ranges[rng.random(n) < 0.1] = 80.0  # no return
    return Scan(angles, ranges, 0.1, 80.0)


def aligned(a: OccupancyGrid, b: OccupancyGrid):
    """The overlapping windows of two grids on the same lattice, and the cell counts outside."""
    x0 = np.maximum(a.origin, b.origin)
    x1 = np.minimum(np.array(a.extent()[2:]), np.array(b.extent()[2:]))
    ia = np.round((x0 - a.origin) / a.resolution).astype(int)
    ib = np.round((x0 - b.origin) / b.resolution).astype(int)
    nx, ny = np.round((x1 - x0) / a.resolution).astype(int)
    wa = a.data[ia[1]:ia[1] + ny, ia[0]:ia[0] + nx]
    wb = b.data[ib[1]:ib[1] + ny, ib[0]:ib[0] + nx]
    outside = np.count_nonzero(a.data) - np.count_nonzero(wa), np.count_nonzero(b.data) - np.count_nonzero(wb)
    return wa, wb, outside


def dense_equivalent(maps: TiledMaps, index: int, scans_and_poses) -> None:
    # the particle maps clear every crossed cell, echo_margin or not (see slam_core.rbpf.tiled_map)
    grid = OccupancyGrid(maps.resolution, model=replace(maps.model, echo_margin=0.0))
    for scan, pose in scans_and_poses:
        grid.integrate(scan, pose)
    a, b, outside = aligned(grid, maps.to_grid(index))
    np.testing.assert_allclose(a, b, atol=1e-5)
    assert outside == (0, 0)
    np.testing.assert_allclose(maps.extent(index), maps.to_grid(index).extent(), atol=1e-9)


def test_tiled_integration_equals_the_dense_grid():
    rng = np.random.default_rng(3)
    maps = TiledMaps(3, 0.05, capacity=8)  # the pools grow many times
    assert maps.extent(0) is None
    history = {i: [] for i in range(3)}
    for _ in range(5):
        poses = np.column_stack([rng.uniform(-3, 3, 3), rng.uniform(-3, 3, 3), rng.uniform(-3, 3, 3)])
        scan = random_scan(rng)
        maps.integrate(poses, scan)
        for i in range(3):
            history[i].append((scan, poses[i]))
    for i in range(3):
        dense_equivalent(maps, i, history[i])


def test_copies_share_tiles_until_they_write():
    rng = np.random.default_rng(5)
    maps = TiledMaps(30, 0.05)
    scan = random_scan(rng)
    maps.integrate(np.zeros((30, 3)), scan)
    maps.resample(np.zeros(30, np.int64))
    one_map = maps.tiles_in_use
    assert np.all(maps.tables == maps.tables[0])  # every particle points at the same tiles
    assert one_map == int(np.sum(maps.tables[0] >= 0))  # thirty maps in the memory of one


def test_a_copy_writes_its_own_tiles_and_leaves_its_sibling_untouched():
    rng = np.random.default_rng(7)
    maps = TiledMaps(2, 0.05)
    maps.integrate(np.zeros((2, 3)), random_scan(rng))
    maps.resample(np.array([0, 0]))
    shared = maps.tiles_in_use
    before = maps.to_grid(1)
    # Map 0 sees a new scan where both maps have cells; map 1 sees one far away.
    maps.integrate(np.array([[0.5, 0.2, 0.3], [60.0, 60.0, 0.0]]), random_scan(rng))
    a, b, _ = aligned(before, maps.to_grid(1))
    np.testing.assert_array_equal(a, b)  # map 1's old area: unchanged by map 0's write
    a, b, _ = aligned(before, maps.to_grid(0))
    assert not np.array_equal(a, b)  # map 0 did change there
    copied = int(np.sum((maps.tables[0] >= 0) & (maps.tables[0] != maps.tables[1])))
    assert maps.tiles_in_use > shared
    assert copied > 0 and np.sum(maps.tables[0] == maps.tables[1]) + copied >= shared


def test_resampling_frees_tiles_nobody_holds():
    rng = np.random.default_rng(11)
    maps = TiledMaps(4, 0.05)
    poses = np.array([[0, 0, 0], [20, 0, 0], [0, 20, 0], [20, 20, 0]], float)
    maps.integrate(poses, random_scan(rng))
    per_map = [int(np.sum(maps.tables[i] >= 0)) for i in range(4)]
    assert maps.tiles_in_use == sum(per_map)
    maps.resample(np.array([2, 2, 2, 2]))
    assert maps.tiles_in_use == per_map[2]
    assert np.all(maps.refs[maps.tables[0][maps.tables[0] >= 0]] == 4)


def test_grid_round_trip_through_seed():
    rng = np.random.default_rng(13)
    grid = OccupancyGrid(0.05)
    grid.integrate(random_scan(rng), [1.0, -2.0, 0.3])
    maps = TiledMaps(5, 0.05)
    maps.seed_from_grid(grid)
    assert maps.tiles_in_use == int(np.sum(maps.tables[0] >= 0))  # one copy shared by five maps
    a, b, outside = aligned(grid, maps.to_grid(3))
    np.testing.assert_allclose(a, b)
    assert outside == (0, 0)
    assert maps.to_grid(3).shape[0] % TILE == 0


def test_writes_that_change_nothing_copy_no_tile():
    """Free-space beams over cells already at the lower clamp leave shared tiles shared;
    a beam that changes a cell (an echo) still copies its tile, and only for that map."""
    maps = TiledMaps(3, 0.05)
    settled = OccupancyGrid(0.05, origin=(-8.0, -8.0), shape=(320, 320), model=maps.model,
                            data=np.full((320, 320), np.float32(maps.model.l_min)))
    maps.seed_from_grid(settled)
    shared = maps.tiles_in_use
    no_return = Scan(np.linspace(-np.pi, np.pi, 180, endpoint=False), np.full(180, 80.0), 0.1, 80.0)
    poses = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 0.5], [-2.0, 0.5, 1.0]])
    maps.integrate(poses, no_return)
    assert maps.tiles_in_use == shared
    assert np.all(maps.tables == maps.tables[0])
    echo = Scan(np.array([0.0]), np.array([2.0]), 0.1, 80.0)
    maps.integrate(poses, echo)
    assert maps.tiles_in_use > shared
    copied = [int(np.sum(maps.tables[i] != maps.tables[(i + 1) % 3])) for i in range(3)]
    assert 0 < max(copied) <= 2 * 3  # the echo's tile (and a neighbour) per map, nothing else
    assert maps.to_grid(0).data.max() > maps.model.l_min  # the echo was written


def test_settled_copies_are_shared_before_the_maps_hold_more_tiles_than_ever():
    """Three maps clear free space around ten places 6 m apart, each from its own poses, so each
    holds private copies of settled tiles (every cell at ``l_min``). Swept into one shared tile
    before the maps may take more tiles than they ever held, those copies are reused for the next
    places: the maps read the same, and hold fewer tiles at their most."""
    no_return = Scan(np.linspace(-np.pi, np.pi, 360, endpoint=False), np.full(360, 80.0), 0.1, 80.0)

    def mapped(sweep_every):
        rng = np.random.default_rng(7)
        maps = TiledMaps(3, 0.05, sweep_every=sweep_every)
        for k in range(60):
            place = np.array([6.0 * (k // 6), 0.0, 0.0])
            maps.integrate(place + rng.normal(0.0, [0.05, 0.05, 0.02], (3, 3)), no_return)
        return maps

    swept, unswept = mapped(SWEEP_EVERY), mapped(0)
    settled = np.float32(swept.model.l_min)
    assert np.count_nonzero(unswept.to_grid(0).data == settled) > 5000  # the copies the sweep frees
    for i in range(3):
        np.testing.assert_array_equal(swept.to_grid(i).data, unswept.to_grid(i).data)
        np.testing.assert_array_equal(swept.to_grid(i).origin, unswept.to_grid(i).origin)
    assert swept.most_tiles < 0.6 * unswept.most_tiles
    assert unswept.most_tiles == unswept.tiles_in_use  # no tile was freed without the sweep


def test_only_tile_parts_an_echo_fell_into_hold_hit_sums():
    """Hit blocks: none for free space, one per part of a tile with an echo, freed with their tile."""
    maps = TiledMaps(2, 0.05)
    no_return = Scan(np.linspace(-np.pi, np.pi, 180, endpoint=False), np.full(180, 80.0), 0.1, 80.0)
    maps.integrate(np.zeros((2, 3)), no_return)
    assert maps.tiles_in_use > 0 and maps.hit_blocks_in_use == 0
    rng = np.random.default_rng(19)
    maps.integrate(np.array([[0.0, 0.0, 0.0], [30.0, 0.0, 0.0]]), random_scan(rng))
    for i in range(2):
        sums = maps.hit_sums(i)
        n = sums[..., HIT_N]
        parts_hit = {(iy // PART, ix // PART) for iy, ix in np.argwhere(n > 0)}  # the sums start at a tile
        assert len(parts_hit) == int(np.sum(maps.hit_of[maps.tables[i][maps.tables[i] >= 0]] >= 0))
        inside = sums[..., :HIT_N][n > 0] / n[n > 0, None]
        assert inside.min() >= 0.0 and inside.max() < maps.resolution  # mean endpoints lie in their cells
    per_map = [int(np.sum(maps.hit_of[maps.tables[i][maps.tables[i] >= 0]] >= 0)) for i in range(2)]
    assert maps.hit_blocks_in_use == sum(per_map) > 0
    maps.resample(np.array([1, 1]))
    assert maps.hit_blocks_in_use == per_map[1]
    with_sums_everywhere = maps.tiles_in_use * maps.lo[0].nbytes * 4  # sums: 12 bytes a cell
    assert maps.nbytes() - maps.tables.nbytes < 0.6 * with_sums_everywhere


def test_a_pool_grows_in_place_and_is_copied_while_another_array_refers_to_it():
    """Grown tiles and hit blocks keep their rows and add zero ones; a view held elsewhere (which keeps
    the memory from being remapped) still reads the rows it saw, and the pool then is a copy."""
    maps = TiledMaps(2, 0.05, capacity=64)
    maps.integrate(np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.2]]), random_scan(np.random.default_rng(3)))
    before, blocks = maps.lo.copy(), maps.hit_blocks.copy()
    maps._reserve(maps.tiles_in_use + len(maps.refs))  # grown in place
    assert len(maps.lo) > len(before) and len(maps.hit_blocks) > len(blocks)
    np.testing.assert_array_equal(maps.lo[:len(before)], before)
    np.testing.assert_array_equal(maps.hit_blocks[:len(blocks)], blocks)
    assert not maps.lo[len(before):].any() and not maps.hit_blocks[len(blocks):].any()
    held, values = maps.lo, maps.lo.copy()
    maps._reserve(maps.tiles_in_use + 2 * len(maps.refs))  # copied: `held` refers to the old rows
    assert maps.lo.base is not held.base and len(maps.lo) > len(held)
    np.testing.assert_array_equal(held, values)
    np.testing.assert_array_equal(maps.lo[:len(held)], values)
