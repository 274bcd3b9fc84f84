"""The loop-closing back end: branch and bound against exhaustive search, loops closed
on a drifted trajectory against ground truth, scans between updates re-matched."""

import dataclasses

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from slam_core.geometry import relative, wrap_angle
from slam_core.graph import loop_closure as lc
from slam_core.graph import pose_graph
from slam_core.graph.config import LoopClosureConfig
from slam_core.graph.loop_closure import (
    Submap,
    _within_reach,
    _witnessed_chain,
    close_loops,
    loop_edge,
    robust_solve,
    scan_poses,
    steady_starts,
)
from slam_core.graph.wide_search import field_pyramid, wide_search
from slam_core.occupancy_grid import SensorModel
from slam_core.rbpf.config import MatcherParams
from slam_core.rbpf.correlative import (
    NO_SKIP,
    _block_scores,
    _pop,
    _push,
    _score,
    bound_levels,
    bounded_search,
    max_pool,
    pool_pairs,
    pooled_bound,
    pooled_bounds,
    search,
)
from slam_core.rbpf.scan_matcher import beam_rows
from tests.large_world import drifted
from tests.synthetic_room import room_scan

CONFIG = LoopClosureConfig(submap_updates=10, min_loop_path=4.0)


def two_laps(n=160):
    """True poses driving twice around an ellipse in the synthetic room."""
    t = np.linspace(0, 4 * np.pi, n)
    x, y = 0.5 + 2.0 * np.cos(t), 0.4 + 1.3 * np.sin(t)
    th = np.arctan2(np.gradient(y), np.gradient(x))
    return np.column_stack([x, y, th])


def errors(truth, poses):
    return (np.hypot(*(truth[:, :2] - poses[:, :2]).T),
            np.abs(wrap_angle(truth[:, 2] - poses[:, 2])))


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 10_000), st.sampled_from([2, 3, 4, 5]))
@example(224, 2)  # endpoints just off the field's low edge: the bound must still cover them
def test_branch_and_bound_finds_the_exhaustive_searchs_optimum(seed, block):
    rng = np.random.default_rng(seed)
    field = np.where(rng.random((120, 140)) < 0.05, rng.random((120, 140)), 0.0).astype(np.float32)
    points = rng.uniform(-2.5, 2.5, (40, 2))
    px, py, pth = rng.uniform(2.5, 4.5), rng.uniform(2.5, 3.5), rng.uniform(-np.pi, np.pi)
    cells = int(rng.integers(3, 12))
    exhaustive = search(field, 0.05, 0.0, 0.0, px, py, pth, points, 0.1, 0.02, cells, 1e9, 1e9)
    bounded = bounded_search(field, *bound_levels(field, block), block, 0.05, 0.0, 0.0, px, py, pth, points,
                             0.1, 0.02, cells, *NO_SKIP)
    assert abs(bounded[3] - exhaustive[3]) <= 1e-5 * max(1.0, exhaustive[3])


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 10_000), st.integers(0, 3), st.integers(0, 2))
def test_branch_and_bound_skips_a_region_and_finds_the_best_pose_outside_it(seed, skip_cells, skip_steps):
    """Against every pose of the window scored one by one, those in the skipped region left out."""
    rng = np.random.default_rng(seed)
    field = np.where(rng.random((80, 90)) < 0.08, rng.random((80, 90)), 0.0).astype(np.float32)
    points = rng.uniform(-1.5, 1.5, (30, 2))
    px, py, pth = rng.uniform(1.8, 2.5), rng.uniform(1.8, 2.2), rng.uniform(-np.pi, np.pi)
    cells, n_rot, step = 5, 3, 0.02
    sx, sr = rng.integers(-cells, cells + 1, 2), rng.integers(-n_rot, n_rot + 1)
    skip = (px + sx[0] * 0.05, py + sx[1] * 0.05, pth + sr * step)
    scores = [search(field, 0.05, 0.0, 0.0, px + dx * 0.05, py + dy * 0.05, pth + r * step, points, 0.0, step,
                     0, 1e9, 1e9)[3]
              for r in range(-n_rot, n_rot + 1)
              for dy in range(-cells, cells + 1) for dx in range(-cells, cells + 1)
              if not (abs(dx - sx[0]) <= skip_cells and abs(dy - sx[1]) <= skip_cells
                      and abs(r - sr) <= skip_steps)]
    _, _, _, runner_up = bounded_search(field, *bound_levels(field, 3), 3, 0.05, 0.0, 0.0, px, py, pth,
                                        points, n_rot * step, step, cells, *skip, skip_cells, skip_steps)
    assert abs(runner_up - max(scores)) <= 1e-5 * max(1.0, max(scores))


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 10_000), st.sampled_from([2, 3, 4, 8]))
def test_block_sums_equal_the_per_offset_sums_to_the_bit(seed, block):
    """The searches' sums over a square of blocks or offsets, point by point, against the one-offset
    functions, with endpoints inside, across and beyond every edge of the field."""
    rng = np.random.default_rng(seed)
    field = rng.random((30, 34)).astype(np.float32)
    pooled = max_pool(field, block)
    cells_x, cells_y = rng.integers(-12, 46, 25), rng.integers(-12, 42, 25)
    first, blocks = int(rng.integers(-6, 3)), int(rng.integers(1, 6))
    bounds = np.empty((blocks, blocks))
    pooled_bounds(pooled, block, cells_x, cells_y, first, bounds)
    scores = np.empty((int(rng.integers(1, 5)), int(rng.integers(1, 5))))
    _block_scores(field, cells_x, cells_y, first, first + 1, scores)
    for by in range(blocks):
        for bx in range(blocks):
            assert bounds[by, bx] == pooled_bound(pooled, block, cells_x, cells_y, first + bx * block,
                                                  first + by * block)
    for j in range(scores.shape[0]):
        for i in range(scores.shape[1]):
            assert scores[j, i] == _score(field, cells_x, cells_y, first + i, first + 1 + j)


def test_max_pool_is_the_maximum_over_each_block():
    rng = np.random.default_rng(3)
    field = rng.random((9, 11)).astype(np.float32)
    pooled = max_pool(field, 3)
    for y in range(9):
        for x in range(11):
            assert pooled[y, x] == field[y:y + 3, x:x + 3].max()


@pytest.mark.parametrize("block", [1, 2, 4])
def test_pooling_pairs_of_blocks_pools_over_blocks_twice_as_wide(block):
    rng = np.random.default_rng(block)
    field = rng.random((13, 17)).astype(np.float32)
    assert np.array_equal(pool_pairs(max_pool(field, block), block), max_pool(field, 2 * block))


@settings(max_examples=25, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 5), st.integers(0, 50)), min_size=1, max_size=60,
                unique_by=lambda e: e[1]))
def test_the_search_heap_gives_the_largest_bound_first_then_the_lowest_code(entries):
    keys, codes = np.empty(len(entries)), np.empty(len(entries), np.int64)
    size = 0
    for key, code in entries:
        size = _push(keys, codes, size, float(key), code)
    out = []
    while size:
        out.append((keys[0], codes[0]))
        size = _pop(keys, codes, size)
    assert out == sorted(((float(k), c) for k, c in entries), key=lambda e: (-e[0], e[1]))


def test_loops_close_on_a_drifted_trajectory():
    truth = two_laps()
    bent = drifted(truth, turn_bias=0.002, scale=1.01)
    rng = np.random.default_rng(0)
    scans = [room_scan(p, 360, noise=0.01, rng=rng) for p in truth]
    result, _ = close_loops(bent, scans, CONFIG)
    before, _ = errors(truth, bent)
    after, after_th = errors(truth, result.poses)
    assert result.loop_edges > 20
    assert before.max() > 0.5  # the second lap is far off the first
    assert after.mean() < 0.03 and after.max() < 0.08, (after.mean(), after.max())
    assert np.degrees(after_th.max()) < 1.5
    assert after.mean() < 0.1 * before.mean()


def test_an_edge_dropped_in_every_round_is_counted_once():
    truth = two_laps()
    bent = drifted(truth, turn_bias=0.002, scale=1.01)
    rng = np.random.default_rng(0)
    scans = [room_scan(p, 360, noise=0.01, rng=rng) for p in truth]
    # every loop edge is an outlier: each round's searches find the same pairs again and drop them
    strict = LoopClosureConfig(submap_updates=10, min_loop_path=4.0, outlier_chi2=0.0, rounds=1)
    once, _ = close_loops(bent, scans, strict)
    twice, _ = close_loops(bent, scans, dataclasses.replace(strict, rounds=2))
    assert once.loop_edges == twice.loop_edges == 0
    assert once.rejected_edges > 20
    assert twice.candidates_tried > once.candidates_tried  # the second round searched them again
    assert twice.rejected_edges == once.rejected_edges


def test_a_straight_trajectory_is_left_where_it_is():
    truth = two_laps()
    rng = np.random.default_rng(1)
    scans = [room_scan(p, 360, noise=0.01, rng=rng) for p in truth]
    result, _ = close_loops(truth, scans, CONFIG)
    after, after_th = errors(truth, result.poses)
    assert result.loop_edges > 20
    assert after.max() < 0.03 and np.degrees(after_th.max()) < 1.0


def test_disabled_back_end_returns_the_input():
    truth = two_laps(40)
    scans = [room_scan(p, 90) for p in truth]
    result, _ = close_loops(truth + 0.1, scans, LoopClosureConfig(enabled=False))
    assert np.array_equal(result.poses, truth + 0.1) and result.loop_edges == 0


def test_every_scan_is_matched_instead_of_trusting_stale_odometry_or_noisy_poses():
    # every other scan is an update, at a pose off by sampling noise; the odometry of the
    # scans between stalled (it repeats the update's reading), leaving them a step (9 cm,
    # within the fine matcher's reach) behind
    truth = two_laps(240)
    rng = np.random.default_rng(2)
    scans = [room_scan(p, 360, noise=0.01, rng=rng) for p in truth]
    is_update = np.arange(len(truth)) % 2 == 0
    update_of_scan = np.cumsum(is_update) - 1
    noisy = truth[is_update] + rng.normal(0.0, [0.02, 0.02, 0.005], (is_update.sum(), 3))
    odometry = truth.copy()
    odometry[~is_update] = truth[np.flatnonzero(~is_update) - 1]
    closed, submaps = close_loops(noisy, [scans[k] for k in np.flatnonzero(is_update)], CONFIG)
    poses = scan_poses(submaps, closed.poses, update_of_scan, odometry, odometry[is_update], scans,
                       CONFIG)
    stale, stale_th = errors(truth[~is_update], closed.poses[update_of_scan[~is_update]])
    err, err_th = errors(truth, poses)
    noise, _ = errors(truth[is_update], noisy)
    assert stale.mean() > 0.08
    assert err[~is_update].mean() < 0.02
    assert err_th[~is_update].mean() < 0.5 * stale_th.mean()
    assert err[is_update].mean() < 0.6 * noise.mean()
    assert not any("field" in vars(sub) for sub in submaps._kept.values())  # the re-match needs none


@pytest.mark.parametrize("budget", [0, 3])
def test_submaps_beyond_the_kept_bytes_are_rebuilt_to_the_same_poses(monkeypatch, budget):
    truth = two_laps()
    bent = drifted(truth, turn_bias=0.002, scale=1.01)
    rng = np.random.default_rng(3)
    scans = [room_scan(p, 360, noise=0.01, rng=rng) for p in truth]
    update_of_scan = np.arange(len(truth))
    builds = []
    real_init = Submap.__init__

    def counted(self, updates, *args):
        builds.append(int(updates[0]))
        real_init(self, updates, *args)

    monkeypatch.setattr(Submap, "__init__", counted)

    def run():
        builds.clear()
        closed, submaps = close_loops(bent, scans, CONFIG)
        poses = scan_poses(submaps, closed.poses, update_of_scan, bent, bent, scans, CONFIG)
        return closed, submaps, poses, list(builds)

    kept_all, submaps, poses, built_once = run()
    assert sorted(built_once) == sorted(set(built_once)) and len(built_once) == len(submaps)
    assert sum(sub.maps.nbytes() for sub in submaps._kept.values()) <= lc.KEPT_SUBMAP_BYTES
    one = next(iter(submaps._kept.values())).maps.nbytes()
    monkeypatch.setattr(lc, "KEPT_SUBMAP_BYTES", budget * one)
    rebuilt, submaps, rebuilt_poses, built = run()
    assert len(submaps._kept) <= budget
    assert len(built) > len(built_once)  # the searches' later rounds and the re-match built them again
    assert np.array_equal(rebuilt.poses, kept_all.poses) and rebuilt.loop_pairs == kept_all.loop_pairs
    assert np.array_equal(rebuilt_poses, poses)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(st.booleans(), st.floats(0.02, 0.5)), min_size=3, max_size=40),
       st.floats(0.05, 1.5), st.floats(-3.0, 3.0))
def test_a_robot_at_a_steady_pace_is_where_its_last_update_step_puts_it(scans, speed, heading):
    """On a straight line at constant speed, scans at uneven times: the update step's pace, timed,
    puts every scan after the second update exactly where it is."""
    n = len(scans)
    t = np.cumsum([gap for _, gap in scans])
    truth = np.column_stack([speed * t * np.cos(heading), speed * t * np.sin(heading), np.full(n, heading)])
    is_update = np.array([True, *(update for update, _ in scans[1:])])
    update_of_scan = np.cumsum(is_update) - 1
    steady = steady_starts(truth[is_update], update_of_scan, t)
    known = ~is_update & (update_of_scan >= 1)
    np.testing.assert_allclose(steady[known], truth[known], atol=1e-9)
    assert np.all(np.isnan(steady[~known]))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_scans_whose_odometry_froze_beyond_the_matchers_reach_keep_the_robots_pace(seed):
    # every fourth scan is an update; the odometry of the three scans between froze at the
    # update's reading (mit-csail's wheels do this), leaving them 13, 26 and 39 cm behind: too far
    # for a fine match from there, but the pace of the scans before says where they are
    truth = two_laps(160)
    rng = np.random.default_rng(seed)
    scans = [dataclasses.replace(room_scan(p, 360, noise=0.01, rng=rng), timestamp=0.2 * k)
             for k, p in enumerate(truth)]
    is_update = np.arange(len(truth)) % 4 == 0
    update_of_scan = np.cumsum(is_update) - 1
    noisy = truth[is_update] + rng.normal(0.0, [0.02, 0.02, 0.005], (is_update.sum(), 3))
    odometry = truth[np.flatnonzero(is_update)[update_of_scan]]
    closed, submaps = close_loops(noisy, [scans[k] for k in np.flatnonzero(is_update)], CONFIG)
    poses = scan_poses(submaps, closed.poses, update_of_scan, odometry, odometry[is_update], scans,
                       CONFIG)
    between = ~is_update & (update_of_scan > 0)  # before the second update no pace is known
    stale, _ = errors(truth[between], closed.poses[update_of_scan[between]])
    err, err_th = errors(truth, poses)
    assert stale.mean() > 0.2
    assert np.percentile(err[between], 95) < 0.06 and err[between].max() < 0.1  # were 0.46 / 0.49
    assert err_th[between].max() < np.radians(3.0)  # was 20 deg
    assert np.hypot(*np.diff(poses[4:, :2], axis=0).T).max() < 0.3  # steps of 10-14 cm; were up to 0.65


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 10_000), st.integers(1, 6))
def test_wide_branch_and_bound_finds_the_exhaustive_searchs_optimum(seed, levels):
    rng = np.random.default_rng(seed)
    field = np.where(rng.random((90, 100)) < 0.05, rng.random((90, 100)), 0.0).astype(np.float32)
    points = rng.uniform(-2.0, 2.0, (30, 2))
    px, py, pth = rng.uniform(1.5, 3.5), rng.uniform(1.5, 3.0), rng.uniform(-np.pi, np.pi)
    cells = int(rng.integers(3, 40))
    exhaustive = search(field, 0.05, 0.0, 0.0, px, py, pth, points, 0.06, 0.02, cells, 1e9, 1e9)
    pyramid = field_pyramid(field, levels)
    wide = wide_search(pyramid, 0.05, 0.0, 0.0, px, py, pth, points, 0.06, 0.02, cells, 0.0, 0.0, 0.0, 0.0)
    assert abs(wide[3] - exhaustive[3]) <= 1e-5 * max(1.0, exhaustive[3])
    # a floor above the optimum finds nothing
    assert wide_search(pyramid, 0.05, 0.0, 0.0, px, py, pth, points, 0.06, 0.02, cells,
                       exhaustive[3] + 1e-3, 0.0, 0.0, 0.0)[3] == -1.0


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 10_000), st.integers(0, 12))
def test_wide_branch_and_bound_leaves_out_a_disc_and_finds_the_best_pose_outside_it(seed, radius):
    """Against every pose of the window scored one by one, those within ``radius`` cells of a
    random offset left out (a look-alike's search around a match)."""
    rng = np.random.default_rng(seed)
    field = np.where(rng.random((90, 100)) < 0.05, rng.random((90, 100)), 0.0).astype(np.float32)
    points = rng.uniform(-2.0, 2.0, (30, 2))
    px, py, pth = rng.uniform(1.5, 3.5), rng.uniform(1.5, 3.0), rng.uniform(-np.pi, np.pi)
    cells, n_rot, step = int(rng.integers(3, 25)), 3, 0.02
    ex, ey = rng.integers(-cells, cells + 1, 2)
    scores = [search(field, 0.05, 0.0, 0.0, px + dx * 0.05, py + dy * 0.05, pth + r * step, points, 0.0, step,
                     0, 1e9, 1e9)[3]
              for r in range(-n_rot, n_rot + 1)
              for dy in range(-cells, cells + 1) for dx in range(-cells, cells + 1)
              if radius == 0 or (dx - ex) ** 2 + (dy - ey) ** 2 > radius ** 2]  # 0: nothing left out
    pyramid = field_pyramid(field, 4)
    got = wide_search(pyramid, 0.05, 0.0, 0.0, px, py, pth, points, n_rot * step, step, cells, 0.0,
                      float(ex), float(ey), float(radius))[3]
    best = max(scores, default=-1.0)  # (-1: the disc covers the window, no pose is left)
    assert abs(got - best) <= 1e-5 * max(1.0, best)


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 10_000))
def test_a_wide_window_searched_only_where_points_reach_the_submap_finds_the_same_best_score(seed):
    """Against the whole window: the part left out is where no point can land on the field."""
    rng = np.random.default_rng(seed)
    truth = two_laps(40)
    matcher = MatcherParams()
    sub = Submap(np.arange(10), truth, [room_scan(p, 360) for p in truth], 0.05, SensorModel(), matcher,
                 matcher.packed(), 3.0)
    query = truth[25] + np.append(rng.uniform(-0.3, 0.3, 2), rng.uniform(-0.1, 0.1))
    points = beam_rows(room_scan(truth[25], 360), matcher.coarse_range, matcher.coarse_beams)[:, :2]
    linear = float(rng.uniform(20.0, 30.0))
    start = query + np.append(rng.uniform(-0.8 * linear, 0.8 * linear, 2), 0.0)  # the truth in the window
    clipped = _within_reach(sub, start, linear, matcher.coarse_range)
    assert clipped is not None and clipped[1] < linear
    whole = wide_search(sub.pyramid(), 0.05, *sub.field_corner, *start, points, 0.1, 0.01,
                        int(np.ceil(linear / 0.05)), 0.0, 0.0, 0.0, 0.0)
    part = wide_search(sub.pyramid(), 0.05, *sub.field_corner, *clipped[0], points, 0.1, 0.01,
                       int(np.ceil(clipped[1] / 0.05)), 0.0, 0.0, 0.0, 0.0)
    assert whole[3] > 0.25 * len(points)  # it finds the room
    assert part[3] == pytest.approx(whole[3], rel=1e-6)
    far = start + np.array([60.0, 0.0, 0.0])  # a window wholly beyond the field's reach
    assert _within_reach(sub, far, 10.0, matcher.coarse_range) is None


def test_field_pyramid_is_the_maximum_over_each_block():
    rng = np.random.default_rng(4)
    field = rng.random((13, 10)).astype(np.float32)
    pyramid = field_pyramid(field, 3)
    for level in range(4):
        block = 1 << level
        for y in range(13):
            for x in range(10):
                assert pyramid[level, y, x] == field[y:y + block, x:x + block].max()


def test_a_growing_trajectory_solved_incrementally_closes_its_loops_and_searches_far_less():
    """The live back end's way: solve every 20 updates going on from the last solve's memory.
    Against the ground truth as good as one full solve; each update searched about once."""
    truth = two_laps()
    bent = drifted(truth, turn_bias=0.002, scale=1.01)
    rng = np.random.default_rng(0)
    scans = [room_scan(p, 360, noise=0.01, rng=rng) for p in truth]
    full, _ = close_loops(bent, scans, CONFIG)
    memory, tried, repeated = None, 0, 0
    for n in range(20, len(truth) + 1, 20):
        result, _ = close_loops(bent[:n], scans[:n], CONFIG, memory=memory)
        tried += result.candidates_tried
        repeated += close_loops(bent[:n], scans[:n], CONFIG)[0].candidates_tried
        memory = result.memory
    after, after_th = errors(truth, result.poses)
    assert result.loop_edges >= 0.8 * full.loop_edges
    assert after.mean() < 0.03 and after.max() < 0.08, (after.mean(), after.max())
    assert np.degrees(after_th.max()) < 1.5
    assert tried < 0.5 * repeated, (tried, repeated)


def test_a_memory_is_dropped_where_the_trajectory_it_searched_has_changed():
    truth = two_laps()
    rng = np.random.default_rng(2)
    scans = [room_scan(p, 360, noise=0.01, rng=rng) for p in truth]
    first, _ = close_loops(truth[:120], scans[:120], CONFIG)
    moved = truth.copy()
    moved[95:, 0] += 0.05  # a different best particle from update 95 on, 5 cm off the truth
    start, edges, tried = first.memory.reusable(moved, CONFIG.submap_updates)
    assert start == 95
    assert edges and all(q < 95 and a // CONFIG.submap_updates < 9 for a, q in edges)
    assert all(q < 95 and s < 9 for s, q in tried)
    again, _ = close_loops(moved, scans, CONFIG, memory=first.memory)
    after, _ = errors(truth, again.poses)  # the new part's loops, searched again, pull it back
    assert after.max() < 0.03 and again.loop_edges > 20


def test_a_warm_started_solve_reaches_the_cold_solves_optimum_in_fewer_steps(monkeypatch):
    """The next solve of a grown trajectory starts from the last optimum (the new updates carried
    along by the filter's motion): the same poses as a solve from the filter's poses, in fewer
    Gauss-Newton steps."""
    steps = []
    solve_step = pose_graph.spsolve
    monkeypatch.setattr(pose_graph, "spsolve", lambda *a, **k: steps.append(1) or solve_step(*a, **k))
    truth = two_laps()
    bent = drifted(truth, turn_bias=0.002, scale=1.01)
    rng = np.random.default_rng(1)
    scans = [room_scan(p, 360, noise=0.01, rng=rng) for p in truth]
    first, _ = close_loops(bent[:140], scans[:140], CONFIG)
    memory = first.memory
    start = memory.warm_start(bent)
    assert np.allclose(start[:140], memory.optimised)  # the old part where the last solve put it
    # the new part moved rigidly with the last old update
    assert np.allclose(relative(start[139], start[140:]), relative(bent[139], bent[140:]))
    _, chain = _witnessed_chain(bent, CONFIG)
    edges = dict(memory.edges)
    steps.clear()
    cold, _ = robust_solve(bent, chain, edges, CONFIG.outlier_chi2)
    cold_steps = len(steps)
    steps.clear()
    warm, _ = robust_solve(bent, chain, edges, CONFIG.outlier_chi2, start=start)
    assert len(steps) < cold_steps, (len(steps), cold_steps)
    assert np.abs(warm[:, :2] - cold[:, :2]).max() < 1e-4
    assert np.abs(wrap_angle(warm[:, 2] - cold[:, 2])).max() < 1e-5


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-5.0, 5.0), min_size=5, max_size=5), st.floats(-np.pi, np.pi),
       st.lists(st.floats(-0.3, 0.3), min_size=3, max_size=3), st.floats(0.0, np.pi),
       st.floats(1.0, 1e4), st.floats(1.0, 1e4))
def test_a_loop_edges_error_weighs_a_pose_off_its_match_as_the_matcher_does(values, heading, off, axis,
                                                                              strong, weak):
    """The matcher's information is on the matched pose's position in the map's axes; the edge's
    error is in the pose's own frame. An estimate off the match by ``off`` (map axes) costs the
    edge exactly the matcher's ``off^T info off``, whatever the pose's heading (with the
    information used unturned, a corridor's edge would pin the robot along the corridor)."""
    anchor = np.array(values[:3])
    pose = np.array([values[3], values[4], heading])
    c, s = np.cos(axis), np.sin(axis)
    info = np.zeros((3, 3))
    info[:2, :2] = np.array([[c, -s], [s, c]]) @ np.diag([strong, weak]) @ np.array([[c, s], [-s, c]])
    info[2, 2] = 50.0
    info[:2, 2] = info[2, :2] = 0.3 * np.sqrt(strong * 50.0) * np.array([c, s])
    z, edge_info = loop_edge(anchor, pose, info)
    graph = pose_graph.PoseGraph(np.array([anchor, pose + np.array(off)]))
    graph.add_edge(0, 1, z, edge_info)
    d = np.array(off)
    assert graph.chi2()[0] == pytest.approx(d @ info @ d, rel=1e-9, abs=1e-9)


def test_a_corridors_loop_edge_moves_the_robot_across_the_corridor_not_along_it():
    """A loop edge from a match in a corridor running north (known across it, in x, not along
    it): the solve takes the edge's x and leaves y to the chain."""
    poses = np.array([[0.0, 0.0, np.pi / 2], [0.0, 1.0, np.pi / 2], [0.0, 2.0, np.pi / 2]])
    _, chain = _witnessed_chain(poses, CONFIG)
    info = np.diag([1e6, 1e-2, 1e4])  # in the map's axes: across the corridor is x
    z, edge_info = loop_edge(poses[0], np.array([0.3, 2.5, np.pi / 2]), info)
    solved, dropped = robust_solve(poses, chain, {(0, 2): (z, edge_info)}, outlier_chi2=1e12)
    assert not dropped
    assert solved[2, 0] == pytest.approx(0.3, abs=0.01)
    assert solved[2, 1] == pytest.approx(2.0, abs=0.01)
