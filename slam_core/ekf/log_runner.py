"""Run the landmark EKF over a CARMEN log: the per-scan trajectory and the landmark map files."""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from slam_core.ekf.ekf_slam import EkfConfig, EkfSlam
from slam_core.ekf.landmarks import CORNER, LINE, SPIKE
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
LINE_COLUMNS = ("id", "kind", "rho", "alpha", "var_rho", "cov_rho_alpha", "var_alpha", "anchor_x", "anchor_y",
                "x0", "y0", "x1", "y1")
KIND_NAMES = {SPIKE: "spike", CORNER: "corner", LINE: "line"}


def save_landmarks_csv(ekf: EkfSlam, path) -> Path:
    """One row per point landmark: id, kind (spike / corner), position and its 2x2 covariance.

    The wall lines go to ``<stem>_lines.csv`` beside it: id, kind, normal form ``(ρ, α)`` with its
    covariance, and the end points of the mapped extent. Ids are the state's landmark indices.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    covs = ekf.state.landmark_covariances()
    lines = ekf.state.lines
    ends = iter(ekf.line_segments())
    with open(path, "w", newline="") as f, open(lines_csv_path(path), "w", newline="") as g:
        writer, line_writer = csv.writer(f), csv.writer(g)
        writer.writerow(LANDMARK_COLUMNS)
        line_writer.writerow(LINE_COLUMNS)
        for i, ((x, y), c, kind) in enumerate(zip(ekf.state.landmarks, covs, ekf.landmark_kinds,
                                                   strict=True)):
            cov = [f"{c[0, 0]:.6g}", f"{c[0, 1]:.6g}", f"{c[1, 1]:.6g}"]
            if lines[i]:
                (x0, y0), (x1, y1) = next(ends)
                ax, ay = ekf.state.anchors[i]
                line_writer.writerow([i, "line", f"{x:.4f}", f"{y:.6f}", *cov,
                                      *(f"{v:.4f}" for v in (ax, ay, x0, y0, x1, y1))])
            else:
                writer.writerow([i, KIND_NAMES[int(kind)], f"{x:.4f}", f"{y:.4f}", *cov])
    return path


def lines_csv_path(path) -> Path:
    """Where :func:`save_landmarks_csv` writes the wall lines for a landmark table ``path``."""
    path = Path(path)
    return path.with_name(path.stem + "_lines.csv")


def load_landmarks_csv(path) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """``(positions (k, 2), covariances (k, 2, 2), kinds)`` of the point landmarks from
    :func:`save_landmarks_csv`."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    pos = np.array([[float(r["x"]), float(r["y"])] for r in rows]).reshape(-1, 2)
    cov = np.array([[[float(r["var_xx"]), float(r["cov_xy"])], [float(r["cov_xy"]), float(r["var_yy"])]]
                    for r in rows]).reshape(-1, 2, 2)
    return pos, cov, [r["kind"] for r in rows]
