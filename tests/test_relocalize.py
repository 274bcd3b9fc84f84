"""Re-localization in a restored map, against the simulator's ground truth."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from app.worker.relocalize import Relocalizer
from slam_core.geometry import wrap_angle
from slam_core.rbpf.hit_render import SparseHits
from slam_core.rbpf.laser_mount import LaserMount
from slam_core.rbpf.tiled_map import TiledMaps
from slam_core.robot_config import robot_from
from slam_core.sim.lidar import Lidar, LidarConfig
from slam_core.sim.world import load_world, parse_world
from tests.synthetic_room import room_scan

POSE_TOLERANCE_M = 0.05
HEADING_TOLERANCE = 0.03


@pytest.fixture(scope="module")
def flat_map():
    """The flat mapped from its tour's true poses: the world, grid, hit sums and poses."""
    world = load_world("flat")
    lidar = Lidar(world)
    rng = np.random.default_rng(0)
    maps = TiledMaps(1, 0.05)
    poses = world.tour_poses()
    for pose in poses:
        maps.integrate(pose[None, :], lidar.scan(pose, rng))
    grid = maps.to_grid(0)
    return world, grid, SparseHits.from_dense(maps.hit_sums(0), grid.origin), poses


@pytest.fixture(scope="module")
def flat(flat_map):
    """A relocalizer in the mapped flat, with a lidar to take test scans."""
    world, grid, hits, poses = flat_map
    return Relocalizer(grid, hits), Lidar(world), poses


def error(fix_pose, truth) -> tuple[float, float]:
    return float(np.hypot(*(fix_pose[:2] - truth[:2]))), abs(float(wrap_angle(fix_pose[2] - truth[2])))


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_nearby_guess_is_corrected_by_the_local_search(flat, seed):
    relocalizer, lidar, poses = flat
    rng = np.random.default_rng(seed)
    truth = poses[rng.integers(len(poses))] + [0.0, 0.0, rng.uniform(-np.pi, np.pi)]
    guess = truth + rng.uniform([-0.5, -0.5, -0.4], [0.5, 0.5, 0.4])
    fix = relocalizer.locate(lidar.scan(truth, rng), guess)
    assert fix is not None and fix.search == "local"
    d, dth = error(fix.pose, truth)
    assert d <= POSE_TOLERANCE_M and dth <= HEADING_TOLERANCE, (fix, truth)


@pytest.mark.parametrize("seed", [4, 5, 6])
def test_a_wrong_guess_is_replaced_by_the_global_search(flat, seed):
    """As after an MCU power cycle: the odometry says the robot is back at the start."""
    relocalizer, lidar, poses = flat
    rng = np.random.default_rng(seed)
    truth = poses[rng.integers(len(poses))] + [0.0, 0.0, rng.uniform(-np.pi, np.pi)]
    far = poses[np.argmax(np.hypot(*(poses[:, :2] - truth[:2]).T))]
    fix = relocalizer.locate(lidar.scan(truth, rng), far)
    assert fix is not None and fix.search == "global"
    d, dth = error(fix.pose, truth)
    assert d <= POSE_TOLERANCE_M and dth <= HEADING_TOLERANCE, (fix, truth)


@pytest.mark.parametrize("told", [True, False])
def test_a_laser_off_the_centre_is_found_at_the_robots_pose_when_its_mount_is_given(flat_map, told):
    world, grid, hits, poses = flat_map
    mount = LaserMount(-0.1, 0.04, 0.6)
    laser = robot_from(None).laser
    mounted = Lidar(world, LidarConfig(replace(laser, mount=mount)))
    located = Relocalizer(grid, hits, mount=mount if told else None)
    rng = np.random.default_rng(8)
    truth = poses[len(poses) // 3]
    fix = located.locate(mounted.scan(truth, rng), truth + np.array([0.2, -0.2, 0.2]))
    assert fix is not None
    d, dth = error(fix.pose, truth)
    if told:
        assert d <= POSE_TOLERANCE_M and dth <= HEADING_TOLERANCE, (fix, truth)
    else:  # it finds the laser, not the robot
        assert dth > 0.5, (fix, truth)


def test_a_scan_of_another_place_is_not_accepted(flat):
    relocalizer, _, poses = flat
    assert relocalizer.locate(room_scan((0.0, 0.0, 0.0)), poses[0]) is None


TWIN_ROOMS = """
start 1 1 0
room left 0 0 4 3
furniture cupboard 1.0  0.05 0.05  1.2 0.05  1.2 0.6  0.05 0.6
table t 2.2 1.6 3.2 2.4
room right 10 0 14 3
furniture cupboard 1.0  10.05 0.05  11.2 0.05  11.2 0.6  10.05 0.6
table t 12.2 1.6 13.2 2.4
"""


@pytest.fixture(scope="module")
def twins():
    """Two identical rooms 10 m apart, mapped from true poses in both: a relocalizer and a lidar."""
    world = parse_world(TWIN_ROOMS)
    lidar = Lidar(world)
    rng = np.random.default_rng(0)
    maps = TiledMaps(1, 0.05)
    room = [(x, y, th) for x in (1.0, 2.0, 3.0) for y in (1.0, 2.0) for th in (0.0, 2.0, 4.0)]
    for pose in np.array([(x + dx, y, th) for dx in (0.0, 10.0) for x, y, th in room]):
        maps.integrate(pose[None, :], lidar.scan(pose, rng))
    grid = maps.to_grid(0)
    return Relocalizer(grid, SparseHits.from_dense(maps.hit_sums(0), grid.origin)), lidar


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_global_search_does_not_choose_between_two_rooms_alike(twins, seed):
    """The scan fits both rooms: no pose is accepted from afar, the right one is from nearby."""
    relocalizer, lidar = twins
    rng = np.random.default_rng(seed)
    truth = np.array([rng.uniform(1.0, 3.0) + 10.0 * rng.integers(2), rng.uniform(0.9, 2.1),
                      rng.uniform(-np.pi, np.pi)])
    scan = lidar.scan(truth, rng)
    assert relocalizer.locate(scan, truth + np.array([5.0, 0.0, 0.0])) is None  # beyond the local search
    fix = relocalizer.locate(scan, truth + np.array([0.3, -0.3, 0.2]))
    assert fix is not None and fix.search == "local"
    d, dth = error(fix.pose, truth)
    assert d <= POSE_TOLERANCE_M and dth <= HEADING_TOLERANCE, (fix, truth)
