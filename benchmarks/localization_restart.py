"""Localization restarted halfway through a log: the tracker's odometry calibration learned afresh
against one resumed from the errors the first tracker measured (what a worker restart does).

The first localizer tracks the first half of the log from the reference's first pose; at the
middle, two new localizers start at its estimate (as a restarted worker starts at the pose it
finds): one with an empty calibration, one resumed from the first one's measured errors
(``OdometryCalibration.measured`` / ``resume``). Each is judged on the second half against the
reference: the share of scans within 0.10 m and 2 deg, and the mean position error, over all of
it and over its first 100 scans. References as in ``benchmarks/localization.py``: a stress log's
map built from its ground truth, a shipped log's ``homebot slam`` map and trajectory.

    python benchmarks/localization_restart.py [--logs intel mit-csail fhw ...] [--slam-maps DIR]
        [--stress ../shared/datasets/stress]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from localization import _reference_for_shipped, _reference_for_stress

from slam_core.datasets import resolve_log
from slam_core.geometry import wrap_angle
from slam_core.io.carmen import laser_records
from slam_core.localization.mcl import MonteCarloLocalizer

START_COVARIANCE = np.diag([0.05, 0.05, 0.02]) ** 2
FIRST = 100  # scans after the restart looked at apart


def _tracked(mcl: MonteCarloLocalizer, records) -> np.ndarray:
    poses = []
    for record in records:
        mcl.step(record.pose, record.scan)
        poses.append(mcl.estimate().pose)
    return np.array(poses)


def restart_rows(name: str, grid, reference: np.ndarray, records) -> list[str]:
    half = len(records) // 2
    first = MonteCarloLocalizer(grid, None, rng=np.random.default_rng(0), initial_pose=reference[0],
                                initial_covariance=START_COVARIANCE)
    _tracked(first, records[:half])
    odometry, start = first.tracker.odometry, first.estimate().pose
    errors, learned = odometry.measured(), odometry.summary()
    rows = []
    for calibration in ("learned afresh", "resumed"):
        mcl = MonteCarloLocalizer(grid, None, rng=np.random.default_rng(1), initial_pose=start,
                                  initial_covariance=START_COVARIANCE)
        if calibration == "resumed" and not mcl.tracker.odometry.resume(errors):
            raise SystemExit("the errors were measured with another motion model")
        poses = _tracked(mcl, records[half:])
        xy = np.hypot(*(poses[:, :2] - reference[half:, :2]).T)
        within = (xy <= 0.10) & (np.abs(wrap_angle(poses[:, 2] - reference[half:, 2])) <= np.radians(2.0))
        rows.append(f"| {name} | {half} | {learned['heading_drift_deg_per_m']} / "
                    f"{learned['translation_scale_error']} | {calibration} | {100 * within.mean():.1f} "
                    f"| {100 * within[:FIRST].mean():.0f} | {xy.mean():.4f} | {xy[:FIRST].mean():.4f} |")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--logs", nargs="+", default=["intel", "mit-csail"],
                        help="shipped logs by name, stress logs by folder name (with --stress)")
    parser.add_argument("--slam-maps", type=Path, help="earlier homebot slam outputs (DIR/LOG/map.yaml)")
    parser.add_argument("--stress", type=Path, help="the stress logs' folder")
    args = parser.parse_args()
    print("| log | restart at scan | first tracker's heading drift (deg/m) / scale error | calibration "
          "| within 0.10 m / 2 deg after (%) | ... first 100 scans (%) | mean error (m) "
          "| ... first 100 (m) |")
    print("|---|---:|---|---|---:|---:|---:|---:|")
    for name in args.logs:
        if name in ("intel", "mit-csail"):
            grid, trajectory = _reference_for_shipped(name, args.slam_maps)
            log = resolve_log(name)
        elif args.stress is not None:
            folder = args.stress / name
            grid, trajectory = _reference_for_stress(folder)
            log = folder / f"{name}.clf.bz2"
        else:
            raise SystemExit(f"{name}: a stress log needs --stress")
        for row in restart_rows(name, grid, trajectory.poses, list(laser_records(log))):
            print(row, flush=True)


if __name__ == "__main__":
    main()
