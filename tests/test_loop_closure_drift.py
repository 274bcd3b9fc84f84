"""Loops closed after large drift, and none closed between places that only look alike:
the back end on large hand-made worlds against their ground truth."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from slam_core.geometry import compose, relative, wrap_angle
from slam_core.graph.config import LoopClosureConfig
from slam_core.graph.loop_closure import ChainDrift, Submaps, close_loops, robust_solve, sparse_step_scales
from slam_core.occupancy_grid import SensorModel
from slam_core.rbpf.config import MatcherParams
from slam_core.scan import Scan
from tests.large_world import drifted, ring_tour, ring_world, twin_corridors, twin_tour
from tests.synthetic_room import cast

ANGLES = np.linspace(-np.pi, np.pi, 360, endpoint=False)
CONFIG = LoopClosureConfig(submap_updates=10)


def scans_along(poses, segments, seed=0):
    rng = np.random.default_rng(seed)
    return [Scan(ANGLES, cast(p, ANGLES, segments, 30.0) + rng.normal(0, 0.01, len(ANGLES)), 0.05, 30.0)
            for p in poses]


def distance(a, b):
    return np.hypot(*(a[:, :2] - b[:, :2]).T)


@pytest.fixture(scope="module")
def ring():
    truth = ring_tour()  # 208 m round a 70 m x 40 m ring, then 25 m into the second lap
    return truth, scans_along(truth, ring_world())


def test_a_long_loop_closes_after_metres_of_drift(ring):
    truth, scans = ring
    bent = drifted(truth, turn_bias=0.0004)  # 9.5 deg of heading at the return
    lap = len(truth) - 50  # the last 50 poses retrace the first 50
    before = distance(truth, bent)
    assert before[lap:].mean() > 4.0  # the return is metres off
    result, _ = close_loops(bent, scans, CONFIG)
    after = distance(truth, result.poses)
    assert result.loop_edges > 10, result.stats()
    assert after[lap:].max() < 0.3, after[lap:].max()
    # no doubled corridor: the second pass lies on the first
    retrace = distance(result.poses[lap:], result.poses[:50])
    assert retrace.max() < 0.15, retrace.max()
    heading = np.abs(wrap_angle(result.poses[lap:, 2] - result.poses[:50, 2]))
    assert np.degrees(heading.max()) < 1.0
    # the narrow search alone (today's window) leaves it open
    narrow, _ = close_loops(bent, scans, LoopClosureConfig(submap_updates=10, wide_every=10 ** 9))
    assert narrow.loop_edges == 0 and distance(narrow.poses[lap:], narrow.poses[:50]).min() > 3.0


def test_a_wide_match_that_fits_less_is_kept_when_its_neighbours_confirm_it(ring):
    """No wide match alone explains enough beams here (the accept fit is above 1); those that
    explain ``wide_confirm_fit`` close the loop because the updates around them match where
    they put them. Asking for more confirmations than there are neighbours leaves it open."""
    truth, scans = ring
    bent = drifted(truth, turn_bias=0.0004)
    lap = len(truth) - 50
    strict = dataclasses.replace(CONFIG, wide_accept_fit=1.01)
    result, _ = close_loops(bent, scans, strict)
    assert result.loop_edges > 10, result.stats()
    assert distance(truth, result.poses)[lap:].max() < 0.3
    assert distance(result.poses[lap:], result.poses[:50]).max() < 0.15
    unconfirmed, _ = close_loops(bent, scans, dataclasses.replace(strict, wide_confirmations=5))
    assert unconfirmed.loop_edges == 0
    assert distance(unconfirmed.poses[lap:], unconfirmed.poses[:50]).min() > 3.0


def test_a_narrow_match_where_the_chain_may_have_drifted_beyond_its_window_must_fit_as_a_wide_one(ring):
    """The second lap's estimate is within the narrow window of the truth, so the narrow search finds
    the loop. Where the chain's noise says it may have drifted farther than that window since the
    last loop (a look-alike could lie within reach), the match must pass the wide search's test,
    made impossible here (a fit above 1, more confirmations than neighbours): the loop stays open.
    The same with a chain said to drift little closes it."""
    truth, scans = ring
    bent = drifted(truth, turn_bias=0.00001)
    lap = len(truth) - 50
    assert distance(truth, bent)[lap:].max() < 0.3
    drifting = dataclasses.replace(CONFIG, wide_every=10 ** 9, wide_accept_fit=1.01, wide_confirmations=5)
    chain = ("chain_sigma_xy", "chain_sigma_th", "chain_sigma_per_metre", "chain_sigma_th_per_metre",
             "chain_sigma_per_radian")
    steady = dataclasses.replace(drifting, **{k: 0.01 * getattr(drifting, k) for k in chain})
    closed, _ = close_loops(bent, scans, steady)  # 0.11 m at the return: within the window
    assert closed.loop_edges > 10, closed.stats()
    held, _ = close_loops(bent, scans, drifting)  # 11 m
    assert held.loop_edges == 0, held.stats()


def thinned(scan: Scan, every: int = 15) -> Scan:
    """The scan with one beam in ``every`` left (the others no measurement): open ground."""
    ranges = np.full(len(scan), np.nan)
    ranges[::every] = scan.ranges[::every]
    return Scan(scan.angles, ranges, scan.range_min, scan.range_max)


def test_a_loop_after_a_stretch_of_sparse_scans_is_searched_as_wide_as_its_heading_drift(ring):
    """Where the scans hold few echoes, the filter's heading drifts more than the chain's model for
    full scans allows, and the wide search's window widens there. The same path behind full scans
    (the control) is beyond the window and stays open. The return is 18-28 m off, where the
    submaps nearest the drifted estimate are not those it returns to: they are found because the
    search tries the window's other submaps in turn (without, it stays open)."""
    truth, scans = ring
    lo, hi = 134, 250  # a 58 m stretch, from the first corner on
    steps = relative(truth[:-1], truth[1:])
    steps[lo:hi, 2] += 0.0036  # 24 deg of heading drift over the stretch
    bent = [truth[0]]
    for step in steps:
        bent.append(compose(bent[-1], step))
    bent = np.array(bent)
    lap = len(truth) - 50
    assert distance(truth, bent)[lap:].min() > 15.0
    sparse = [thinned(s) if lo < k <= hi else s for k, s in enumerate(scans)]  # 24 echoes each
    result, _ = close_loops(bent, sparse, CONFIG)
    assert result.loop_edges > 10, result.stats()
    assert distance(truth, result.poses)[lap:].max() < 0.3
    assert distance(result.poses[lap:], result.poses[:50]).max() < 0.15
    control, _ = close_loops(bent, scans, CONFIG)
    assert control.loop_edges == 0 and distance(control.poses[lap:], control.poses[:50]).min() > 10.0


def test_a_sparse_scan_widens_the_heading_noise_of_its_step_by_its_missing_echoes():
    """``sqrt(max_beams / n)`` for ``n`` echoes within reach, between 1 and the limit a match needs."""
    matcher = MatcherParams()
    full = scans_along(ring_tour()[:1], ring_world())[0]
    rng = np.random.default_rng(3)
    for n in (0, 5, 20, 45, 90, 179, 180, 360):
        keep = rng.choice(len(full), n, replace=False)
        ranges = np.full(len(full), 25.0)  # echoes beyond the 20 m reach
        ranges[keep] = rng.uniform(0.5, 19.0, n)
        ranges[rng.choice(len(full), 10)] = np.nan  # a few no measurement at all
        scan = Scan(full.angles, ranges, 0.05, 30.0)
        echoes = np.count_nonzero(np.isfinite(ranges) & (ranges <= 20.0))
        expected = np.sqrt(matcher.max_beams / min(max(echoes, matcher.min_matched_beams), matcher.max_beams))
        got = sparse_step_scales([full, scan], 20.0, matcher)
        assert got.shape == (1,)
        assert got[0] == pytest.approx(expected)
        assert 1.0 <= got[0] <= np.sqrt(matcher.max_beams / matcher.min_matched_beams)


def test_the_search_window_is_the_drift_the_chain_noise_lets_accumulate():
    """Against a Monte Carlo run of the chain's own noise model (an independent oracle): the
    spread across the path at its end, and of the heading."""
    config = LoopClosureConfig()
    rng = np.random.default_rng(0)
    n = 301
    poses = np.column_stack([np.arange(n) * 0.2, np.zeros(n), np.zeros(n)])  # 60 m straight on
    steps = relative(poses[:-1], poses[1:])
    path = np.arange(n) * 0.2
    linear, angular = ChainDrift(poses, path, config).sigmas(np.array([0]), n - 1)
    sxy = config.chain_sigma_xy + config.chain_sigma_per_metre * 0.2
    sth = config.chain_sigma_th + config.chain_sigma_th_per_metre * 0.2
    ends = np.tile(poses[0], (3000, 1))
    for step in steps:
        ends = compose(ends, step + rng.standard_normal((3000, 3)) * np.array([sxy, sxy, sth]))
    across, heading = ends[:, 1].std(), wrap_angle(ends[:, 2]).std()
    assert across > 1.0  # metres: far more than the narrow window
    assert abs(linear[0] - across) < 0.1 * across, (linear, across)
    assert abs(angular[0] - heading) < 0.1 * heading, (angular, heading)


def test_updates_that_retrace_the_ends_of_long_submaps_close_loops_there():
    """A scan every 2 m: a submap of 10 updates spans 18 m, its anchor 8-10 m from its ends. Every update
    of the second lap lies within a metre of one of the first lap's and is searched against its
    submap (its anchor lay near a few of them); all of them close a loop."""
    truth = ring_tour(step=2.0)
    lap = len(ring_tour(step=2.0, overlap=0.0))
    scans = scans_along(truth, ring_world())
    assert distance(truth[lap:], truth[:len(truth) - lap]).max() < 1.0
    result, _ = close_loops(drifted(truth, turn_bias=0.0004), scans, CONFIG)
    assert set(range(lap, len(truth))) <= {q for _, q in result.loop_pairs}, result.loop_pairs
    assert distance(truth, result.poses)[lap:].max() < 0.1


@given(st.integers(2, 60), st.integers(1, 12), st.integers(0, 10_000))
def test_a_submaps_distance_is_that_of_its_nearest_update(n, size, seed):
    rng = np.random.default_rng(seed)
    poses = np.column_stack([rng.uniform(-20, 20, (n, 2)), rng.uniform(-np.pi, np.pi, n)])
    scans = scans_along(poses[:1], ring_world())
    submaps = Submaps(poses, scans * n, LoopClosureConfig(submap_updates=size), 0.05, SensorModel(),
                      MatcherParams(), MatcherParams().packed())
    q = int(rng.integers(n))
    subs = np.arange(len(submaps))
    nearest = [min(np.hypot(*(poses[u, :2] - poses[q, :2])) for u in submaps.ranges[s]) for s in subs]
    assert submaps.distances(subs, poses, q) == pytest.approx(nearest)


def test_two_identical_corridors_close_no_false_loop():
    truth = twin_tour()  # down corridor A and back, through the connector, down its twin B
    scans = scans_along(truth, twin_corridors(), seed=1)
    bent = drifted(truth, turn_bias=0.0005)
    result, _ = close_loops(bent, scans, CONFIG)
    in_a = truth[:, 1] < 2.5
    in_b = truth[:, 1] > 8.0
    wrong = [(i, j) for i, j in result.loop_pairs if in_a[i] != in_a[j] or in_b[i] != in_b[j]]
    assert result.loop_edges > 20  # A's return leg closes on its first
    assert wrong == []
    after = distance(truth, result.poses)
    assert after[in_b].max() < 1.5 * distance(truth, bent)[in_b].max()  # B is not pulled onto A
    assert distance(result.poses[in_b], truth[in_b]).min() < 1.0


def test_the_robust_back_end_drops_false_loop_edges_fed_to_it(ring):
    """True loop edges (from the ground truth) and false ones (the scan matched a metre or
    more off, as in a look-alike place): the false ones are dropped, the loop still closes."""
    truth, _ = ring
    bent = drifted(truth, turn_bias=0.0005)
    rng = np.random.default_rng(7)
    lap = len(truth) - 50
    info = np.diag([400.0, 400.0, 4000.0])
    edges = {(k, lap + k): (relative(truth[k], truth[lap + k]), info) for k in range(0, 50, 2)}
    false = {}
    for k in range(1, 50, 6):
        off = np.append(rng.uniform(-3, 3, 2), rng.uniform(-0.2, 0.2))
        off[:2] += np.sign(off[:2]) * 1.0
        false[(k, lap + k)] = (compose(relative(truth[k], truth[lap + k]), off), info)
    chain = np.broadcast_to(np.diag([2500.0, 2500.0, 1e5]), (len(truth) - 1, 3, 3))
    poses, dropped = robust_solve(bent, chain, {**edges, **false}, CONFIG.outlier_chi2)
    assert set(dropped) == set(false)
    assert distance(poses[lap:], poses[:50]).max() < 0.15


@pytest.mark.parametrize("a, b_after", [(10, 49), (30, 49), (5, 30)])
def test_a_loop_edge_found_shrinks_the_window_to_the_drift_since(a, b_after):
    """Against a Monte Carlo run of the chain's noise from update ``a`` to the loop edge's older
    end, the edge taken as exact, then the chain on to update ``b`` (an independent oracle)."""
    config = LoopClosureConfig()
    truth = ring_tour()
    lap = len(truth) - 50  # the second lap passes the first lap's updates again
    i, j, b = 12, lap + 12, lap + b_after
    path = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(truth[:, :2], axis=0).T))])
    drift = ChainDrift(truth, path, config)
    chain, _ = drift.sigmas(np.array([a]), b)
    linear = drift.since_loops(np.array([a]), b, np.array([[i, j]]))
    steps = relative(truth[:-1], truth[1:])
    travel = np.hypot(steps[:, 0], steps[:, 1])
    sxy = config.chain_sigma_xy + config.chain_sigma_per_metre * travel
    sth = (config.chain_sigma_th + config.chain_sigma_per_radian * np.abs(steps[:, 2])
           + config.chain_sigma_th_per_metre * travel)
    rng = np.random.default_rng(1)
    noise = np.column_stack([sxy, sxy, sth])

    def walk(pose, lo, hi):
        for k in range(lo, hi):
            pose = compose(pose, steps[k] + rng.standard_normal((4000, 3)) * noise[k])
        return pose

    origin = np.zeros((4000, 3))
    at_i = walk(origin, a, i) if a <= i else relative(walk(origin, i, a), origin)  # i seen from a
    ends = walk(compose(at_i, relative(truth[i], truth[j])), j, b)
    off = ends - relative(truth[a], truth[b])
    major = np.sqrt(np.linalg.eigvalsh(np.cov(off[:, :2].T))[-1])
    assert chain[0] > 10.0 * major  # the chain alone: metres
    assert 0.9 * major < linear[0] < 1.25 * major, (linear, major)
    assert drift.since_loops(np.array([a]), b, np.zeros((0, 2), np.int64))[0] == chain[0]


def test_a_search_that_found_nothing_is_not_repeated_from_where_it_was(ring):
    """The second round searches again from the optimised poses; a pair that the first round's
    search found nothing for, and that the solve did not move, is not searched again. Here the
    second lap's scans are clutter that matches nothing, and the poses are the truth."""
    truth, scans = ring
    lap = len(truth) - 50
    rng = np.random.default_rng(5)
    clutter = [Scan(ANGLES, rng.uniform(0.5, 3.0, len(ANGLES)), 0.05, 30.0) for _ in range(50)]
    one, _ = close_loops(truth, scans[:lap] + clutter, dataclasses.replace(CONFIG, rounds=1))
    two, _ = close_loops(truth, scans[:lap] + clutter, dataclasses.replace(CONFIG, rounds=2))
    assert one.candidates_tried > 50  # the clutter's updates were searched once, in vain
    repeated = two.candidates_tried - one.candidates_tried  # every search repeated: 49
    assert repeated <= 0.1 * one.candidates_tried, (one.stats(), two.stats())
    assert not [q for _, q in one.loop_pairs + two.loop_pairs if q >= lap]  # the clutter closes nothing
