"""How well a localization run agrees with a reference trajectory (SLAM's or the ground truth).

The figures of issue #18, per scan of equal index in both trajectories:

- ``within``: fraction of scans after the first ``skip_travel`` metres of (reference)
  travel whose position is within ``xy_tol`` and heading within ``theta_tol``;
- ``max_jump``: largest distance between consecutive published positions, beyond
  what the reference itself moved between them;
- ``false_localized``: fraction of scans flagged localized while more than
  ``wrong_xy`` off (the flag must be right);
- ``travel_to_correct``: reference travel until the estimate is within
  ``xy_tol`` / ``theta_tol`` and stays so for ``settle`` scans (None if never).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam_core.geometry import wrap_angle


@dataclass(frozen=True)
class Agreement:
    """The figures above, plus the per-scan position and heading errors."""

    within: float
    max_jump: float
    false_localized: float
    localized: float
    travel_to_correct: float | None
    xy_error: np.ndarray
    theta_error: np.ndarray


def travel(poses: np.ndarray) -> np.ndarray:
    """Cumulative path length (m) at each pose."""
    steps = np.hypot(*np.diff(np.asarray(poses)[:, :2], axis=0).T)
    return np.concatenate([[0.0], np.cumsum(steps)])


def agreement(poses, reference, localized=None, skip_travel: float = 10.0, xy_tol: float = 0.10,
              theta_tol: float = np.radians(2.0), wrong_xy: float = 0.5, settle: int = 10) -> Agreement:
    """Score ``poses`` (n, 3) against ``reference`` (n, 3); ``localized`` (n,) flags if given."""
    poses = np.asarray(poses, dtype=np.float64)
    reference = np.asarray(reference, dtype=np.float64)
    if poses.shape != reference.shape or poses.ndim != 2 or poses.shape[1] != 3 or len(poses) < 2:
        raise ValueError(f"need two (n, 3) trajectories of equal length n >= 2, got {poses.shape} "
                         f"and {reference.shape}")
    flags = np.ones(len(poses), bool) if localized is None else np.asarray(localized, bool)
    xy = np.hypot(*(poses[:, :2] - reference[:, :2]).T)
    th = np.abs(wrap_angle(poses[:, 2] - reference[:, 2]))
    good = (xy <= xy_tol) & (th <= theta_tol)
    dist = travel(reference)
    after = dist >= min(skip_travel, dist[-1])
    ref_steps = np.hypot(*np.diff(reference[:, :2], axis=0).T)
    steps = np.hypot(*np.diff(poses[:, :2], axis=0).T)
    run = np.convolve(good.astype(np.int64), np.ones(settle, np.int64), "valid") == settle
    first = np.flatnonzero(run)
    return Agreement(
        within=float(good[after].mean()),
        max_jump=float(np.max(steps - ref_steps)),
        false_localized=float(np.mean(flags & (xy > wrong_xy))),
        localized=float(flags.mean()),
        travel_to_correct=float(dist[first[0]]) if len(first) else None,
        xy_error=xy,
        theta_error=th,
    )
