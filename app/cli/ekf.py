"""``homebot ekf LOG --out DIR``: landmark EKF SLAM on a log (landmark map + per-scan trajectory)."""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

from app.cli.progress import fraction_bar
from slam_core.datasets import CREDIT, is_bundled, resolve_log
from slam_core.ekf.ekf_slam import EkfConfig
from slam_core.ekf.log_runner import run_log, save_landmarks_csv
from slam_core.ekf.render import save_landmark_png


def register(sub) -> None:
    p = sub.add_parser("ekf", help="landmark EKF SLAM on a log",
                       description="Run landmark EKF SLAM (wall lines, spikes and corners, chi-square "
                                   "gated nearest-neighbour association, scan-to-scan ICP motion) on a "
                                   "CARMEN log; write the landmark map (CSV + PNG with 3-sigma ellipses "
                                   "and wall segments) and the per-scan trajectory.")
    p.add_argument("log", help="CARMEN log (.clf, .bz2, .gz) or a bundled name: intel, mit-csail")
    p.add_argument("--out", required=True, type=Path, help="output folder")
    p.add_argument("--max-scans", type=int, default=None, help="stop after this many laser records")
    p.add_argument("--scan-matching", action=argparse.BooleanOptionalAction, default=True,
                   help="take each motion increment from scan-to-scan ICP (default); with "
                        "--no-scan-matching the raw odometry increment")
    p.set_defaults(run=run)


def run(args) -> int:
    log = resolve_log(args.log)
    if args.max_scans is not None and args.max_scans < 1:
        raise ValueError(f"--max-scans must be at least 1, got {args.max_scans}")
    config = replace(EkfConfig(), scan_matching=args.scan_matching)
    started = time.perf_counter()
    with fraction_bar(f"EKF on {log.name}") as progress:
        result = run_log(log, config, args.max_scans, progress)
    elapsed = time.perf_counter() - started
    ekf = result.ekf
    traj = result.trajectory.save(args.out / "trajectory.txt")
    table = save_landmarks_csv(ekf, args.out / "landmarks.csv")
    estimate = ekf.estimate()
    segments = ekf.line_segments()
    png = save_landmark_png(args.out / "landmarks.png", estimate.landmarks, estimate.landmark_covariances,
                            result.trajectory.poses, segments=segments,
                            caption=f"landmark EKF: {len(estimate.landmarks)} points (3-sigma ellipses), "
                                    f"{len(segments)} wall lines"
                            + (" - " + CREDIT if is_bundled(log) else ""))
    print(f"processed {result.scans} scans ({ekf.updates} updates) from {log} in {elapsed:.1f} s")
    print(f"landmarks: {ekf.state.n_landmarks} ({len(segments)} wall lines); "
          f"scan-matching failures: {ekf.icp_failures}")
    print(f"wrote {table}, {png}, {traj}")
    if is_bundled(log):
        print(CREDIT)
    return 0

