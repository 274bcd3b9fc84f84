"""A match's spread, the mean squared distance to the map's walls of the beams near them, tells
apart two poses that explain as many beams: against the distance field itself, and in the room."""

import numpy as np
import pytest
from synthetic_room import room_scan

from slam_core.localization.known_map import KnownMap
from slam_core.localization.scan_to_map import CUTOFF_END, FIELD_CAP, ScanToMapMatcher, field_at
from slam_core.occupancy_grid import OccupancyGrid

HELD = (1e6, 1e6)  # a prior that holds the match where it starts


def room_and_matcher(rng):
    poses = np.c_[rng.uniform(-2.5, 2.0, 120), rng.uniform(-1.0, 1.2, 120), rng.uniform(-np.pi, np.pi, 120)]
    grid = OccupancyGrid(0.05)
    for pose in poses:
        grid.integrate(room_scan(pose, n=360, noise=0.01, rng=rng), pose)
    return poses, ScanToMapMatcher(KnownMap(grid))


def endpoints(pose, rng):
    scan = room_scan(pose, n=360, noise=0.01, rng=rng)
    return np.c_[scan.ranges * np.cos(scan.angles), scan.ranges * np.sin(scan.angles)]


@pytest.mark.parametrize("seed", [0, 1])
def test_the_spread_is_the_mean_squared_distance_of_the_beams_near_walls(seed):
    rng = np.random.default_rng(seed)
    poses, matcher = room_and_matcher(rng)
    known = matcher.map
    distance = np.minimum(known.distance, FIELD_CAP)
    for pose in poses[:10]:
        points = endpoints(pose, rng)
        match = matcher.match(pose, points, HELD)
        x, y, th = match.pose
        world = points @ np.array([[np.cos(th), np.sin(th)], [-np.sin(th), np.cos(th)]]) + (x, y)
        d = np.array([field_at(distance, known.origin[0], known.origin[1], known.resolution, px, py)[0]
                      for px, py in world])
        near = (d >= 0.0) & (d < CUTOFF_END)
        assert match.spread == pytest.approx(np.mean(d[near] ** 2), rel=1e-9, abs=1e-12)


@pytest.mark.parametrize("seed", [0, 1])
def test_a_turned_pose_that_explains_as_many_beams_spreads_more(seed):
    rng = np.random.default_rng(seed)
    poses, matcher = room_and_matcher(rng)
    for pose in poses[:20]:
        points = endpoints(pose, rng)
        right = matcher.match(pose, points, HELD)
        turned = matcher.match(pose + np.array([0.0, 0.0, np.radians(1.0)]), points, HELD)
        assert turned.fit >= right.fit - 0.02  # the fit cannot tell them apart (1.0 and 1.0 measured)
        assert turned.spread > 2.0 * right.spread, (pose, right, turned)  # measured 6-11 times


def test_a_match_with_no_beam_near_a_wall_has_no_spread():
    _, matcher = room_and_matcher(np.random.default_rng(3))
    far = np.array([[100.0, 0.0], [0.0, 100.0], [-100.0, 0.0]])  # endpoints beyond the map
    assert matcher.match(np.zeros(3), far, HELD).spread == np.inf
    assert matcher.match(np.zeros(3), np.zeros((0, 2)), HELD).spread == np.inf
