"""A reference pose that its own map puts elsewhere is told apart from a right one."""

import numpy as np
from synthetic_room import room_scan
from test_localization_occlusion import room_map

from slam_core.localization.reference_check import contradicted, settled_poses


def test_a_displaced_reference_is_contradicted_a_true_one_is_not():
    rng = np.random.default_rng(0)
    truth = np.array([(-1.0, 0.0, 0.3), (1.5, 1.0, -2.0), (0.5, -1.2, 1.0), (2.0, 0.5, 2.5)])
    scans = [room_scan(p, noise=0.01, rng=rng) for p in truth]
    shifted = truth + np.array([(0.6, 0.0, 0.0), (0.0, -0.5, 0.0), (-0.4, 0.4, 0.0), (0.45, 0.0, 0.03)])
    grid = room_map()
    assert not contradicted(grid, scans, truth).any()
    assert contradicted(grid, scans, shifted).all()
    assert not contradicted(grid, scans, truth + np.array([0.05, -0.05, 0.01])).any()


def test_the_matcher_settles_near_a_true_reference_and_pulls_a_nudged_one_back():
    rng = np.random.default_rng(1)
    truth = np.array([(-1.0, 0.0, 0.3), (1.5, 1.0, -2.0), (0.5, -1.2, 1.0), (2.0, 0.5, 2.5)])
    scans = [room_scan(p, noise=0.01, rng=rng) for p in truth]
    grid = room_map()
    nudged = truth + np.array([(0.08, 0.0, 0.0), (0.0, -0.08, 0.02), (-0.05, 0.05, 0.0), (0.0, 0.0, -0.03)])
    for start in (truth, nudged):
        settled = settled_poses(grid, scans, start)
        assert settled.shape == truth.shape
        assert np.hypot(*(settled[:, :2] - truth[:, :2]).T).max() < 0.04
        assert np.abs(np.angle(np.exp(1j * (settled[:, 2] - truth[:, 2])))).max() < np.radians(1.0)
