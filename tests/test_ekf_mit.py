"""Regression: landmark EKF on the full MIT CSAIL log, scored by the relation error (Kümmerle 2009).

Raw odometry scores 1.68 ± 5.29 m and 5.07 ± 8.24 deg. The EKF (default config: scan-to-scan ICP
motion, wall lines + spikes + corners; deterministic) scores 0.070 ± 0.170 m and 1.29 ± 4.34 deg,
24x and 3.9x better. Neighbouring settings scored 0.07-0.29 m and 0.84-1.46 deg (ICP covariance
scale 30 / 300: 0.29 m, 1.09 deg / 0.077 m, 0.95 deg; line overlap margin 2 m: 0.20 m, 1.27 deg;
see benchmarks/RESULTS.md), so the bounds leave room for that spread while still demanding a wide
margin: at least 5x better than odometry in translation and 2x in rotation.
"""

import numpy as np
import pytest

from slam_core.datasets import resolve_log, resolve_relations
from slam_core.ekf.log_runner import run_log
from slam_core.evaluation import load_relations, relation_error
from slam_core.io.carmen import laser_records

TRANS_BOUND_M = 0.3
ROT_BOUND_DEG = 2.5


@pytest.fixture(scope="module")
def mit():
    log = resolve_log("mit-csail")
    result = run_log(log)
    odom = np.array([r.odom for r in laser_records(log)])
    return result, odom, load_relations(resolve_relations("mit-csail"))


def test_trajectory_has_one_pose_per_laser_record(mit):
    result, odom, _ = mit
    assert len(result.trajectory.poses) == len(odom) == result.scans
    assert np.all(np.isfinite(result.trajectory.poses))


def test_ekf_beats_raw_odometry_by_a_wide_margin_in_translation_and_rotation(mit):
    result, odom, relations = mit
    traj = result.trajectory
    ekf = relation_error(traj.times, traj.poses, relations).summary()
    raw = relation_error(traj.times, odom, relations).summary()
    assert raw["trans_mean_m"] > 1.6 and raw["rot_mean_deg"] > 5.0  # the baseline the issue quotes
    assert ekf["unmatched"] == 0
    assert ekf["trans_mean_m"] < TRANS_BOUND_M < 0.2 * raw["trans_mean_m"]
    assert ekf["rot_mean_deg"] < ROT_BOUND_DEG < 0.5 * raw["rot_mean_deg"]


def test_the_map_has_wall_lines_and_few_scan_matching_failures(mit):
    result, _, _ = mit
    ekf = result.ekf
    assert ekf.state.lines.sum() >= 30
    assert ekf.icp_failures < 0.02 * ekf.updates
