"""Loops closed after large drift, and none closed between places that only look alike:
the back end on large hand-made worlds against their ground truth."""

import numpy as np
import pytest

from slam_core.geometry import compose, relative, wrap_angle
from slam_core.graph.config import LoopClosureConfig
from slam_core.graph.loop_closure import ChainDrift, close_loops
from slam_core.scan import Scan
from tests.large_world import drifted, ring_tour, ring_world
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
    bent = drifted(truth, turn_bias=0.0005)
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
