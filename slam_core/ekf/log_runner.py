"""Run the landmark EKF over a CARMEN log: the per-scan trajectory and the landmark map files."""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from slam_core.ekf.ekf_slam import EkfConfig, EkfSlam
from slam_core.ekf.landmarks import CORNER
from slam_core.io.carmen import laser_records
from slam_core.io.trajectory import Trajectory


@dataclass
class EkfLogResult:
    ekf: EkfSlam
    trajectory: Trajectory  # one pose per laser record, odometry-filled between updates
    scans: int


def run_log(path, config: EkfConfig | None = None, max_scans: int | None = None,
            progress=None) -> EkfLogResult:
    """Feed every laser record's odometry and scan to a fresh :class:`EkfSlam`."""
    ekf: EkfSlam | None = None
    stamps, poses = [], []
    for record in laser_records(path, progress=progress):
        if max_scans is not None and len(stamps) >= max_scans:
            break
        if ekf is None:
            ekf = EkfSlam(config, initial_pose=record.odom)
        ekf.step(record.odom, record.scan)
        stamps.append(record.stamp.ipc_text)
        poses.append(ekf.pose)
    if ekf is None:
        raise ValueError(f"{path}: no laser records in the log")
    return EkfLogResult(ekf, Trajectory(stamps, np.array(poses).reshape(-1, 3)), len(stamps))


LANDMARK_COLUMNS = ("id", "kind", "x", "y", "var_xx", "cov_xy", "var_yy")


def save_landmarks_csv(ekf: EkfSlam, path) -> Path:
    """One row per landmark: id, kind (spike / corner), position and its 2x2 covariance."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    covs = ekf.state.landmark_covariances()
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(LANDMARK_COLUMNS)
        for i, ((x, y), c, kind) in enumerate(zip(ekf.state.landmarks, covs, ekf.landmark_kinds,
                                                   strict=True)):
            writer.writerow([i, "corner" if kind == CORNER else "spike", f"{x:.4f}", f"{y:.4f}",
                             f"{c[0, 0]:.6g}", f"{c[0, 1]:.6g}", f"{c[1, 1]:.6g}"])
    return path


def load_landmarks_csv(path) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """``(positions (k, 2), covariances (k, 2, 2), kinds)`` from :func:`save_landmarks_csv`."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    pos = np.array([[float(r["x"]), float(r["y"])] for r in rows]).reshape(-1, 2)
    cov = np.array([[[float(r["var_xx"]), float(r["cov_xy"])], [float(r["cov_xy"]), float(r["var_yy"])]]
                    for r in rows]).reshape(-1, 2, 2)
    return pos, cov, [r["kind"] for r in rows]
