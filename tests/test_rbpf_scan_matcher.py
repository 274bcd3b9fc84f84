"""The scan matcher on a hand-made room: a known shift comes back."""

import numpy as np
import pytest

from slam_core.geometry import relative
from slam_core.rbpf.config import MatcherParams
from slam_core.rbpf.scan_matcher import evaluate_pose, hill_climb
from slam_core.rbpf.tiled_map import TiledMaps
from tests.synthetic_room import room_scan

TRUE_POSE = np.array([0.3, 0.2, 0.1])


@pytest.fixture(scope="module")
def room_map():
    maps = TiledMaps(1, 0.05)
    rng = np.random.default_rng(0)
    for _ in range(8):  # several looks from around the true pose make a confident map
        pose = TRUE_POSE + rng.normal(0, [0.3, 0.3, 0.2])
        maps.integrate(pose[None, :], room_scan(pose, 360))
    return maps


def beams_of(scan):
    v = scan.valid
    a, r = scan.angles[v], scan.ranges[v]
    return np.ascontiguousarray(np.column_stack([r * np.cos(a), r * np.sin(a), np.cos(a), np.sin(a)]))


def args_of(maps):
    return (maps.tables[0], maps.lo, maps.hits, maps.origin[0], maps.origin[1], maps.resolution)


@pytest.mark.parametrize("shift", [(0.04, -0.03, 0.02), (-0.06, 0.05, -0.04), (0.0, 0.0, 0.05),
                                   (0.08, 0.0, 0.0)])
def test_a_known_shift_is_recovered(room_map, shift):
    params = MatcherParams().packed()
    beams = beams_of(room_scan(TRUE_POSE, 180))
    start = TRUE_POSE + np.array(shift)
    x, y, th, score = hill_climb(*args_of(room_map), *start, beams, params, 0.05, 0.05, 8)
    err = relative(TRUE_POSE, [x, y, th])
    assert np.hypot(err[0], err[1]) < 0.006
    assert abs(err[2]) < np.radians(0.3)
    start_score, _, _ = evaluate_pose(*args_of(room_map), *start, beams, params)
    assert score > start_score


def test_score_and_likelihood_peak_at_the_true_pose(room_map):
    params = MatcherParams().packed()
    beams = beams_of(room_scan(TRUE_POSE, 180))
    best, best_ll, matched = evaluate_pose(*args_of(room_map), *TRUE_POSE, beams, params)
    assert matched >= 0.95 * len(beams)
    for d in [(0.05, 0, 0), (0, -0.05, 0), (0, 0, 0.03)]:
        score, ll, _ = evaluate_pose(*args_of(room_map), *(TRUE_POSE + d), beams, params)
        assert score < best and ll < best_ll


def test_beams_into_unknown_space_do_not_match():
    maps = TiledMaps(1, 0.05)
    params = MatcherParams().packed()
    beams = beams_of(room_scan(TRUE_POSE, 90))
    score, ll, matched = evaluate_pose(*args_of(maps), *TRUE_POSE, beams, params)
    assert matched == 0 and score == 0.0
    assert ll == pytest.approx(-len(beams) * params[2] / (2 * params[1]))
