"""The correlative global search finds where one scan fits the whole map, from nothing."""

import numpy as np
from synthetic_room import room_scan

from slam_core.geometry import wrap_angle
from slam_core.localization import MonteCarloLocalizer
from slam_core.localization.global_search import GlobalSearch
from slam_core.localization.known_map import KnownMap
from slam_core.localization.tracking import tracking_points
from slam_core.occupancy_grid import OccupancyGrid

MAPPING_POSES = [(x, y, th) for x in (-2.0, 0.0, 2.0) for y in (-1.0, 0.5, 2.0) for th in (0.0, 2.0)]


def room_map() -> OccupancyGrid:
    grid = OccupancyGrid(0.05)
    for pose in MAPPING_POSES:
        grid.integrate(room_scan(pose, n=720), np.array(pose))
    return grid


def test_the_true_pose_is_among_the_best_lattice_poses():
    search = GlobalSearch(KnownMap(room_map()))
    rng = np.random.default_rng(3)
    for _ in range(10):
        truth = np.array([rng.uniform(-2.5, 3.5), rng.uniform(-1.5, 2.5), rng.uniform(-np.pi, np.pi)])
        points = tracking_points(room_scan(truth, noise=0.01, rng=rng), (0, 0, 0), 60, 15.0)
        poses, scores = search.best(points, 20)
        assert np.all(np.diff(scores) <= 0)
        near = (np.hypot(*(poses[:, :2] - truth[:2]).T) <= search.stride
                ) & (np.abs(wrap_angle(poses[:, 2] - truth[2])) <= search.heading_step)
        assert near.any(), truth


def test_a_global_start_is_right_and_flagged_only_when_right():
    grid = room_map()
    rng = np.random.default_rng(4)
    for seed in range(3):
        mcl = MonteCarloLocalizer(grid, rng=np.random.default_rng(seed))
        path = [np.array([-2.0 + 0.1 * k, -1.0 + 0.05 * k, 0.4]) for k in range(40)]
        errors = []
        for truth in path:
            mcl.step(truth, room_scan(truth, noise=0.01, rng=rng))  # odometry frame = map frame, unknown
            e = mcl.estimate()
            error = float(np.hypot(*(e.pose[:2] - truth[:2])))
            errors.append(error)
            assert not (e.localized and error > 0.5)
        assert max(errors[5:]) <= 0.1, (seed, errors)
