"""Sparse scans trust their far echoes: `SensorModel.reach`, and how the maps trace such beams."""

import math

import numpy as np
import pytest

from slam_core.occupancy_grid import OccupancyGrid, SensorModel
from slam_core.rbpf import RBPFConfig, RBPFSlam
from slam_core.scan import Scan
from tests import naive
from tests.large_world import box, drifted, rectangle
from tests.synthetic_room import cast

MODEL = SensorModel(sparse_echoes=90)


def scan_of(ranges, range_max=81.0):
    ranges = np.asarray(ranges, float)
    return Scan(np.linspace(-math.pi / 2, math.pi / 2, len(ranges)), ranges, 0.1, range_max)


@pytest.mark.parametrize("seed", range(20))
def test_reach_is_the_usable_range_unless_the_scan_is_sparse(seed):
    rng = np.random.default_rng(seed)
    near = int(rng.integers(0, 200))
    far = int(rng.integers(0, 200))
    ranges = np.concatenate([rng.uniform(0.2, MODEL.usable_range, near),
                             rng.uniform(MODEL.usable_range + 0.01, 79.0, far),
                             np.full(int(rng.integers(0, 50)), 81.0)])  # no return
    scan = scan_of(rng.permutation(ranges))
    reach = MODEL.reach(scan)
    if near >= MODEL.sparse_echoes or near >= far:
        assert reach == MODEL.usable_range
        return
    trusted = np.sort(ranges[ranges < 81.0])
    # out to the range within which the scan has sparse_echoes echoes (all of them if fewer)
    assert reach == trusted[min(MODEL.sparse_echoes, len(trusted)) - 1]
    assert np.count_nonzero(trusted <= reach) == min(MODEL.sparse_echoes, len(trusted))
    assert MODEL.beam_reach(scan, 10.0) == reach


def test_reach_stops_at_the_far_range_and_dense_scans_keep_the_matchers_cap():
    assert SensorModel().reach(scan_of([50.0] * 100)) == SensorModel().usable_range  # off by default
    model = SensorModel(far_range=30.0, sparse_echoes=90)
    sparse = scan_of([5.0] * 10 + [25.0] * 30 + [50.0] * 100)
    assert model.reach(sparse) == 25.0  # its 40 echoes within 30 m: fewer than 90, so all of them
    dense = scan_of([5.0] * 100 + [50.0] * 100)
    assert model.reach(dense) == model.usable_range
    assert model.beam_reach(dense, 10.0) == 10.0 and model.beam_reach(dense, 40.0) == model.usable_range
    few_beams = scan_of([5.0] * 30 + [50.0] * 10)  # a sensor with few beams, most of them near
    assert MODEL.reach(few_beams) == MODEL.usable_range
    assert MODEL.reach(scan_of([5.0] * 10 + [50.0] * 30)) == 50.0  # ... most of them far


def test_a_far_echo_marks_its_wall_and_clears_only_near_the_robot_and_before_itself():
    model = SensorModel(usable_range=4.0, sparse_echoes=10)
    grid = OccupancyGrid(0.1, model=model)
    scan = Scan(np.zeros(3), np.array([12.0, 12.0, 12.0]), 0.1, 30.0)  # three echoes at 12 m, none near
    assert model.reach(scan) == 12.0
    grid.integrate(scan, (0.0, 0.0, 0.0))

    def value(x):
        ix, iy = grid.world_to_cell([x, 0.0])
        return grid.data[iy, ix]

    assert value(12.05) > 0  # the wall
    assert value(2.0) < 0 and value(3.8) < 0  # near the robot: free
    assert value(6.0) == 0 and value(11.0) == 0  # out there: left unknown
    assert value(11.75) < 0  # just before the echo: free


@pytest.mark.parametrize("seed", range(3))
def test_sparse_random_scans_match_the_reference_exactly(seed):
    rng = np.random.default_rng(seed)
    model = SensorModel(usable_range=2.0, no_return_range=1.5, sparse_echoes=30, far_range=9.0)
    grid = OccupancyGrid(0.1, model=model)
    sparse = 0
    for _ in range(10):
        n = 60
        ranges = np.where(rng.random(n) < 0.2, rng.uniform(0.05, 2.0, n), rng.uniform(2.0, 12.0, n))
        ranges[rng.random(n) < 0.1] = 12.0  # no return
        scan = Scan(np.sort(rng.uniform(-math.pi, math.pi, n)), ranges, 0.1, 12.0)
        sparse += model.reach(scan) > model.usable_range
        pose = np.array([rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-math.pi, math.pi)])
        naive.check_integrate(grid, scan, pose)
    assert sparse >= 8


def test_the_filter_crossing_an_open_square_holds_on_its_far_walls():
    """A 60 m square with pillars along its walls, crossed 20-40 m from them: fewer than 20 echoes
    within 20 m. The odometry's heading creeps by 1.1 deg a metre. Trusting the far echoes of
    such scans (out to where each has the matcher's 180), the filter updating at every scan (0.4 m
    apart) tracks the robot to a few centimetres; capped at 20 m it has nothing to match and
    follows the odometry metres off. (At the default thresholds, an update every 0.8 m here, the
    heading drifts 0.015 rad between updates, 0.3-0.6 m at these walls: 0.29 m off at the end.)"""
    pillars = [s for k in range(-25, 30, 10) for s in box(k, -29.0, 1.0, 1.0) + box(29.0, k, 1.0, 1.0)]
    segments = np.array(rectangle(-30.0, -30.0, 30.0, 30.0) + pillars + box(-29.0, 5.0, 1.0, 3.0), float)
    leg = np.arange(0.0, 20.0, 0.4)
    truth = np.vstack([np.c_[leg - 10.0, np.full_like(leg, -10.0), np.zeros_like(leg)],
                       np.c_[np.full_like(leg, 10.0), leg - 10.0, np.full_like(leg, np.pi / 2)]])
    odometry = drifted(truth, turn_bias=0.0045)
    rng = np.random.default_rng(0)
    angles = np.linspace(-np.pi, np.pi, 360, endpoint=False)
    scans = [Scan(angles, cast(p, angles, segments, 81.0) + rng.normal(0, 0.01, 360), 0.1, 81.0)
             for p in truth]
    assert all(np.count_nonzero(s.ranges <= 20.0) < 20 for s in scans)

    def final_error(model):
        config = RBPFConfig(particles=8, sensor=model, linear_update=0.4, angular_update=0.1)
        slam = RBPFSlam(config, seed=0, initial_pose=odometry[0])
        last = 0
        for k, (odom, scan) in enumerate(zip(odometry, scans, strict=True)):
            if slam.step(odom, scan):
                last = k
        _, poses = slam.best_path()
        return np.hypot(*(poses[-1, :2] - truth[last, :2]))

    assert final_error(SensorModel(sparse_echoes=180)) < 0.15
    assert final_error(SensorModel()) > 1.0  # off by default
