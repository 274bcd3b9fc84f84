"""People in front of the laser are not a wrong pose: a confirmed track rides out a crowd on
odometry (flag off meanwhile), while a wrong pose sees through the map's walls."""

import numpy as np
from synthetic_room import room_scan

from slam_core.geometry import compose, relative
from slam_core.localization import MonteCarloLocalizer
from slam_core.localization.known_map import KnownMap
from slam_core.localization.scan_to_map import ScanToMapMatcher
from slam_core.localization.tracking import tracking_points
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.scan import Scan

MAPPING_POSES = [(x, y, th) for x in (-2.0, 0.0, 2.0) for y in (-1.0, 0.5, 2.0) for th in (0.0, 2.0)]


def room_map() -> OccupancyGrid:
    grid = OccupancyGrid(0.05)
    for pose in MAPPING_POSES:
        grid.integrate(room_scan(pose, n=720), np.array(pose))
    return grid


def crowded(scan: Scan, rng, fraction: float) -> Scan:
    """The scan with ``fraction`` of its beams cut short by people 0.3-1 m from the laser."""
    ranges = scan.ranges.copy()
    hide = rng.random(len(ranges)) < fraction
    ranges[hide] = np.minimum(ranges[hide], rng.uniform(0.3, 1.0, hide.sum()))
    return Scan(scan.angles, ranges, scan.range_min, scan.range_max)


def test_a_crowd_is_not_seen_through_walls_but_a_wrong_pose_is():
    matcher = ScanToMapMatcher(KnownMap(room_map()))
    rng = np.random.default_rng(0)
    for pose in [(-1.0, 0.0, 0.3), (1.5, 1.0, -2.0), (0.5, -1.2, 1.0)]:
        scan = room_scan(pose, noise=0.01, rng=rng)
        full = tracking_points(scan, (0, 0, 0), 180, 30.0)
        crowd = tracking_points(crowded(scan, rng, 0.7), (0, 0, 0), 180, 30.0)
        assert matcher.seen_through(pose, full) <= 0.05
        assert matcher.seen_through(pose, crowd) <= 0.05
        assert matcher.match(pose, crowd).fit <= 0.5  # the map explains the crowd's scan badly ...
        wrong = np.add(pose, (1.5, 0.8, 0.0))
        assert matcher.seen_through(wrong, full) >= 0.2  # ... but it fits the map, a wrong pose does not


def test_the_track_rides_out_a_crowd_and_says_so():
    grid = room_map()
    rng = np.random.default_rng(1)
    path = [np.array([-2.0 + 0.1 * k, -0.5 + 0.02 * k, 0.1]) for k in range(45)]
    mcl = MonteCarloLocalizer(grid, rng=rng, initial_pose=path[0],
                              initial_covariance=np.diag([0.05, 0.05, 0.02]) ** 2)
    odom = np.zeros(3)
    for k, truth in enumerate(path):
        if k:
            step = relative(path[k - 1], truth)
            odom = compose(odom, step * (1.03, 1.0, 1.0))  # odometry 3 % long
        scan = room_scan(truth, noise=0.01, rng=rng)
        in_crowd = 15 <= k < 25
        if in_crowd:
            scan = crowded(scan, rng, 0.75)
        mcl.step(odom, scan)
        e = mcl.estimate()
        error = float(np.hypot(*(e.pose[:2] - truth[:2])))
        assert mcl.tracker.tracking and error <= 0.1, (k, error)
        assert not (in_crowd and e.localized), k  # the pose is odometry's: not claimed localized
        assert e.localized or in_crowd, k


def test_a_confirmed_track_that_misses_a_few_scans_keeps_the_cloud_around_it():
    """Scans the map does not explain (here: seen from elsewhere) are misses, not a reason to scatter
    random particles over the whole map: a cloud that converged there could take the track away."""
    grid = room_map()
    rng = np.random.default_rng(2)
    path = [np.array([-2.0 + 0.15 * k, -0.5 + 0.02 * k, 0.1]) for k in range(30)]
    mcl = MonteCarloLocalizer(grid, rng=rng, initial_pose=path[0],
                              initial_covariance=np.diag([0.05, 0.05, 0.02]) ** 2)
    misses = 0
    for k, truth in enumerate(path):
        elsewhere = 20 <= k < 23
        seen_from = np.add(truth, (0.4, 1.5, 2.0)) if elsewhere else truth
        mcl.step(truth, room_scan(seen_from, noise=0.01, rng=rng))
        misses = max(misses, mcl.tracker.misses)
        if k >= 15:
            assert mcl.tracker.tracking and mcl.tracker.confirmed, k
            assert mcl.status.injection == 0.0, k
            spread = np.hypot(*(mcl.particles[:, :2] - mcl.tracker.pose[:2]).T)
            assert spread.max() < 1.0, (k, spread.max())
    assert misses >= 2  # the scans from elsewhere were rejected, not ridden out as a crowd
    assert np.hypot(*(mcl.estimate().pose[:2] - path[-1][:2])) < 0.1
