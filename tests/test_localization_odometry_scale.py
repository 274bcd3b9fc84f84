"""Wheels that over-report travel by 5 %: the tracker learns the scale from its matches where boxes
along the walls pin the position, so down a bare stretch of corridor, where a scan pins only the
position across it, the track follows the odometry as corrected, not as reported. Ground truth:
the simulated path."""

import dataclasses

import numpy as np
import pytest
from synthetic_room import cast

from slam_core.geometry import compose
from slam_core.localization import MclConfig, MonteCarloLocalizer
from slam_core.scan import Scan
from tests.corridor import mapped_along

SCALE = 1.05  # the odometry reports 5 % more travel than the robot makes
STEP = 0.2
SCANS = 200  # 40 m: boxes along the first 20 m, then bare walls
ANGLES = np.linspace(-np.pi / 2, np.pi / 2, 181)
RANGE = 8.0  # the laser's reach (ahead of it): past 20 m it sees no box, nor the far end wall
_BOXES = [seg for x, side in ((1.3, 1), (3.1, -1), (4.6, 1), (7.4, -1), (9.0, 1), (11.8, -1), (13.1, 1),
                              (15.9, -1), (17.2, 1), (19.5, -1))
          for seg in ([x, side * 1.0, x, side * 0.6], [x, side * 0.6, x + 0.5, side * 0.6],
                      [x + 0.5, side * 0.6, x + 0.5, side * 1.0])]
WORLD = np.array([[-1.0, -1.0, 60.0, -1.0], [-1.0, 1.0, 60.0, 1.0], [-1.0, -1.0, -1.0, 1.0], *_BOXES],
                 dtype=float) + np.array([0.013, 0.021, 0.013, 0.021])


def scan_at(pose, rng) -> Scan:
    ranges = cast(pose, ANGLES, WORLD, RANGE) + rng.normal(0.0, 0.01, len(ANGLES))
    return Scan(ANGLES, np.minimum(ranges, RANGE), 0.05, RANGE)


@pytest.fixture(scope="module")
def grid():
    return mapped_along(scan_at, 42.0)


def drive(grid, config: MclConfig, seed: int):
    """The localizer after the drive and the published position's errors along the path."""
    rng = np.random.default_rng(seed)
    truth = [np.array([STEP * k, 0.05 * np.sin(0.1 * k), 0.0]) for k in range(SCANS)]
    mcl = MonteCarloLocalizer(grid, config, rng=rng, initial_pose=truth[0],
                              initial_covariance=np.diag([0.05, 0.05, 0.02]) ** 2)
    odom, errors = truth[0].copy(), []
    for k, pose in enumerate(truth):
        if k:
            step = np.array([pose[0] - truth[k - 1][0], pose[1] - truth[k - 1][1], 0.0])
            odom = compose(odom, step * (SCALE, SCALE, 1.0) + rng.normal(0.0, (0.002, 0.001, 0.001)))
        mcl.step(odom, scan_at(pose, rng))
        errors.append(float(np.hypot(*(mcl.estimate().pose[:2] - pose[:2]))))
    return mcl, np.array(errors)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_tracker_learns_the_odometry_scale_and_predicts_with_it(grid, seed):
    mcl, errors = drive(grid, MclConfig(), seed)
    scale = mcl.tracker.odometry.bias()[2]
    assert abs(scale - (1.0 / SCALE - 1.0)) < 0.01, scale  # the truth: -0.0476
    one_metre = mcl.tracker.corrected(np.array([SCALE, 0.0, 0.0]))  # a metre, as the wheels report it
    assert abs(one_metre[0] - 1.0) < 0.01 and abs(one_metre[1]) < 1e-9, one_metre
    # the last 12 m of bare walls: on the reported travel alone it ends 1 m ahead (test below)
    assert errors[140:].max() < 0.15, (140 + int(errors[140:].argmax()), errors[140:].max())


def test_without_the_calibration_the_track_runs_ahead(grid):
    """The same drive with the calibration held off: what the bound above is set against."""
    base = MclConfig()
    never = dataclasses.replace(base, tracking=dataclasses.replace(base.tracking, calibration_min=10 ** 6))
    _, errors = drive(grid, never, 0)
    assert errors[-1] > 0.3, errors[-1]
