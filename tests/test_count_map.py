"""The map kept by submap (slam_core.count_map): an incremental render equals a from-scratch one, the
log-odds are the clamped sum of every beam's observation, and only moved submaps are traced again."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from slam_core.count_map import MOVE_CELLS, MOVE_RAD, TILE, CountMap
from slam_core.occupancy_grid import OccupancyGrid, SensorModel
from slam_core.rbpf.hit_render import hit_sums_on
from tests.test_hit_render import scans_with_every_kind_of_beam

MODEL = SensorModel(usable_range=5.0, no_return_range=3.0)
RES = 0.05
SIZE = 4  # updates per submap


def updates(seed: int, n: int):
    rng = np.random.default_rng(seed)
    poses = np.column_stack([rng.uniform(-2, 3, n), rng.uniform(-1.5, 2.5, n), rng.uniform(-3, 3, n)])
    return poses, scans_with_every_kind_of_beam(rng, poses)


def unclamped_oracle(poses, scans) -> OccupancyGrid:
    """The grid of every beam's observation summed (OccupancyGrid.integrate with clamps so wide that they
    never bite), then clamped once to the model's."""
    m = MODEL
    wide = SensorModel(m.p_hit, m.p_miss, 1e-30, 1.0 - 1e-7, m.usable_range, m.no_return_range)
    grid = OccupancyGrid(RES, model=wide)
    for pose, scan in zip(poses, scans, strict=True):
        grid.integrate(scan, pose)
    grid.data = np.clip(grid.data, MODEL.l_min, MODEL.l_max)
    return grid


def same_cells(a: OccupancyGrid, b: OccupancyGrid) -> tuple[np.ndarray, np.ndarray]:
    """``a``'s and ``b``'s values over the union of their extents (zero outside either)."""
    lo = np.minimum(a.origin, b.origin)
    hi = np.maximum(np.array(a.extent()[2:]), np.array(b.extent()[2:]))
    shape = np.round((hi - lo) / RES).astype(int)[::-1]
    out = []
    for g in (a, b):
        full = np.zeros(shape, np.float32)
        x, y = np.round((g.origin - lo) / RES).astype(int)
        full[y:y + g.shape[0], x:x + g.shape[1]] = g.data
        out.append(full)
    return out[0], out[1]


def tiles_of(counts: CountMap) -> dict[tuple[int, int], np.ndarray]:
    """The counts of each tile that holds some, by absolute tile ``(ty, tx)``."""
    ty0, tx0 = counts.corner[::-1] // TILE
    return {(ty0 + ty, tx0 + tx): counts.pool[t] for (ty, tx), t in np.ndenumerate(counts.slots) if t >= 0}


def same_tiles(a: CountMap, b: CountMap) -> bool:
    """Whether ``a`` and ``b`` hold the same tiles with the same counts."""
    ta, tb = tiles_of(a), tiles_of(b)
    return ta.keys() == tb.keys() and all(np.array_equal(ta[k], tb[k]) for k in ta)


def test_the_map_is_the_clamped_sum_of_every_beam_and_its_hit_sums_the_echoes():
    poses, scans = updates(3, 14)
    counts = CountMap(RES, MODEL, SIZE)
    assert counts.update(poses, scans) == 4  # 14 updates: three whole submaps and a part
    grid = counts.grid()
    mine, oracle = same_cells(grid, unclamped_oracle(poses, scans))
    assert np.count_nonzero(oracle) > 3000  # the clamps bite on both sides:
    assert np.isclose(oracle, MODEL.l_max).sum() > 50 and np.isclose(oracle, MODEL.l_min).sum() > 1000
    np.testing.assert_allclose(mine, oracle, atol=1e-4)
    expected = hit_sums_on(grid, poses, scans, MODEL)
    hits = counts.hit_sums(grid)
    assert expected[..., 2].sum() > 1000
    np.testing.assert_allclose(hits.dense(), expected, atol=1e-5)


def test_clamping_after_the_sum_differs_from_clamping_after_every_beam():
    """A cell seen free many times, then occupied a few: clamped after every beam it turns occupied,
    clamped after the sum it stays free (the rule this map follows)."""
    poses, scans = updates(5, 14)
    per_beam = OccupancyGrid(RES, model=MODEL)
    for pose, scan in zip(poses, scans, strict=True):
        per_beam.integrate(scan, pose)
    counts = CountMap(RES, MODEL, SIZE)
    counts.update(poses, scans)
    mine, theirs = same_cells(counts.grid(), per_beam)
    assert np.count_nonzero(np.abs(mine - theirs) > 1e-4) > 0


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**16), moved=st.lists(st.booleans(), min_size=4, max_size=4),
       added=st.integers(0, 6))
def test_an_incremental_render_equals_one_from_scratch_and_traces_only_moved_submaps(seed, moved, added):
    poses, scans = updates(seed, 15 + added)
    rng = np.random.default_rng(seed + 1)
    counts = CountMap(RES, MODEL, SIZE)
    counts.update(poses[:15], scans[:15])  # submaps 0..2 whole, 3 holds three updates
    new = poses.copy()
    for block, move in enumerate(moved):
        if move:  # one update of the block moves (a tenth of a cell at least, or a turn)
            k = block * SIZE + int(rng.integers(0, SIZE if block < 3 else 3))
            step = rng.choice([-1, 1]) * np.array([2 * MOVE_CELLS * RES, 0.0, 0.0])
            new[k] += step if rng.random() < 0.5 else [0.0, rng.uniform(-0.2, 0.2), 2 * MOVE_RAD]
    traced = counts.update(new, scans)
    grew = added > 0  # the partial submap 3 grows, and new ones start past 16 updates
    assert traced == sum(moved[:3]) + int(moved[3] or grew) + -(-(15 + added) // SIZE) - 4
    scratch = CountMap(RES, MODEL, SIZE)
    scratch.update(new, scans)
    mine, theirs = same_cells(counts.grid(), scratch.grid())
    np.testing.assert_array_equal(mine, theirs)
    assert same_tiles(counts, scratch)
    grid = counts.grid()
    np.testing.assert_allclose(counts.hit_sums(grid).dense(), scratch.hit_sums(grid).dense(), atol=1e-5)


def test_of_each_submap_the_map_keeps_its_poses_and_echoes_not_the_cells_it_crossed():
    """Memory grows with the area mapped: a submap's counts are traced again when they must be
    taken out, so what is kept of it is its laser poses and at most one hit sum per echo."""
    poses, scans = updates(3, 14)
    counts = CountMap(RES, MODEL, SIZE)
    counts.update(poses, scans)
    kept = sum(a.nbytes for s in counts.submaps for a in vars(s).values() if isinstance(a, np.ndarray))
    per_echo = np.dtype(np.int32).itemsize + 3 * np.dtype(np.float64).itemsize  # a cell and its sums
    beams = sum(len(s) for s in scans)
    cells = sum(np.count_nonzero(t.any(axis=2)) for t in tiles_of(counts).values())
    assert cells > 8 * beams  # the beams cross many more cells than they hold echoes
    assert kept <= poses.nbytes + per_echo * beams + 2 * 8 * len(counts.submaps)  # + each corner


def test_moves_within_the_tolerance_trace_nothing_and_keep_the_map_of_the_traced_poses():
    poses, scans = updates(11, 12)
    counts = CountMap(RES, MODEL, SIZE)
    counts.update(poses, scans)
    before = counts.grid().data.copy()
    nudged = poses + np.array([0.5 * MOVE_CELLS * RES, -0.5 * MOVE_CELLS * RES, 0.5 * MOVE_RAD])
    assert counts.update(nudged, scans) == 0
    np.testing.assert_array_equal(counts.grid().data, before)
    turned = poses.copy()
    turned[5, 2] += 2 * np.pi  # the same heading
    assert counts.update(turned, scans) == 0


def test_the_grid_covers_a_box_and_the_map_keeps_its_cells():
    poses, scans = updates(2, 8)
    counts = CountMap(RES, MODEL, SIZE)
    counts.update(poses, scans)
    alone = counts.grid()
    layout = OccupancyGrid(RES, origin=alone.origin - 200 * RES, shape=(10, 10))
    wide = counts.grid(layout.extent())
    assert wide.extent()[0] <= layout.extent()[0] and wide.extent()[2] >= alone.extent()[2]
    mine, theirs = same_cells(alone, wide)
    np.testing.assert_array_equal(mine, theirs)


def test_a_blank_grid_is_drawn_as_the_map_was_and_not_once_the_map_outgrew_it():
    poses, scans = updates(2, 8)
    counts = CountMap(RES, MODEL, SIZE)
    counts.update(poses[:SIZE], scans[:SIZE])
    blank = counts.blank()
    assert blank.shape == counts.grid().shape and not blank.data.any()
    counts.draw(blank)
    np.testing.assert_array_equal(blank.data, counts.grid().data)
    far = poses[SIZE:] + np.array([25.0, 0.0, 0.0])  # the next submap, 25 m east
    counts.update(np.vstack([poses[:SIZE], far]), scans)
    with pytest.raises(ValueError, match="does not cover"):
        counts.draw(blank)


def test_bad_input_is_refused():
    poses, scans = updates(1, 9)
    counts = CountMap(RES, MODEL, SIZE)
    with pytest.raises(ValueError, match="poses for"):
        counts.update(poses[:5], scans)
    counts.update(poses, scans)
    with pytest.raises(ValueError, match="fewer"):
        counts.update(poses[:4], scans[:4])
    with pytest.raises(ValueError, match="at least 1"):
        CountMap(RES, MODEL, 0)


def test_the_counts_are_kept_where_beams_touched_not_over_the_box():
    """Two rooms' worth of updates 47 m apart: the map's box spans both, its counts only the tiles
    the beams touched; the map is still the clamped sum of every beam."""
    poses, scans = updates(4, 8)
    both = np.vstack([poses, poses + np.array([40.0, 25.0, 0.0])])
    counts = CountMap(RES, MODEL, SIZE)
    counts.update(both, scans + scans)
    grid = counts.grid()
    mine, oracle = same_cells(grid, unclamped_oracle(both, scans + scans))
    np.testing.assert_allclose(mine, oracle, atol=1e-4)
    box = grid.data.size * 8  # two int32 a cell
    assert grid.shape[1] * RES > 50 and counts.pool.nbytes < box / 2


def test_a_submap_moved_far_leaves_no_counts_behind():
    poses, scans = updates(6, 12)
    counts = CountMap(RES, MODEL, SIZE)
    counts.update(poses, scans)
    moved = poses.copy()
    moved[:SIZE, :2] += [30.0, -20.0]  # the first submap, far from where it was traced
    assert counts.update(moved, scans) == 1
    scratch = CountMap(RES, MODEL, SIZE)
    scratch.update(moved, scans)
    assert same_tiles(counts, scratch) and all(t.any() for t in tiles_of(counts).values())
    mine, theirs = same_cells(counts.grid(), scratch.grid())
    np.testing.assert_array_equal(mine, theirs)
