"""Pose tracking between and on top of the particle filter's updates.

Cartographer's pure localization and slam_toolbox's localization mode publish a
pose that a scan matcher has pinned to the map; the particle filter alone
publishes the mean of a cloud that the motion noise keeps blurred. The tracker
does the former on every scan:

1. *predict*: the tracked pose moves with the odometry since the previous scan;
2. *match*: :class:`ScanToMapMatcher` refines it against the map, held to the
   prediction by a prior whose spread grows with the odometry's motion since the
   last accepted match (a robot that stands still does not slide along a corridor);
3. *judge*: the match is accepted when the map explains at least ``min_fit`` of
   the beams (see :mod:`slam_core.localization.scan_to_map`). Otherwise a
   correlative search around the prediction (``search_xy``, ``search_theta``:
   odometry that stalled, then caught up) gets a chance; a scan that neither
   explains keeps the predicted pose, and after ``patience`` of them in a row the
   track is *lost* and the particle filter decides again.

The tracker is (re)started from a pose the caller trusts: a known start, or the
particle filter's main cluster once it has converged and matches well there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam_core.geometry import compose, relative
from slam_core.localization.known_map import KnownMap
from slam_core.localization.scan_to_map import MatchResult, ScanToMapMatcher, prior_weights
from slam_core.scan import Scan


@dataclass(frozen=True)
class TrackingConfig:
    """When a match is good enough, how long a track survives bad ones, and which beams it uses."""

    #: Fraction of the beams the map must explain for a match to be accepted.
    min_fit: float = 0.35
    #: Rejected scans in a row after which the track is lost.
    patience: int = 10
    #: Beams matched per scan (evenly spaced over the valid ones) and the range cap (m).
    beams: int = 180
    max_range: float = 30.0
    #: Half-widths (m, rad) and heading step (rad) of the fallback search.
    search_xy: float = 0.3
    search_theta: float = np.radians(90.0)
    search_step: float = np.radians(1.5)
    #: Prior on the prediction: standard deviation at standstill (m, rad) and its growth per metre
    #: travelled and per radian turned.
    prior_xy: float = 0.01
    prior_theta: float = 0.005
    prior_xy_per_m: float = 0.2
    prior_xy_per_rad: float = 0.05
    prior_theta_per_m: float = 0.1
    prior_theta_per_rad: float = 0.2

    def __post_init__(self):
        if not 0 < self.min_fit <= 1 or self.patience < 1 or self.beams < 3 or self.max_range <= 0:
            raise ValueError(f"need 0 < min_fit <= 1, patience >= 1, beams >= 3, max_range > 0; got {self}")


def tracking_points(scan: Scan, laser_pose, beams: int, max_range: float) -> np.ndarray:
    """Endpoints ``(n, 2)`` in the robot frame of up to ``beams`` valid beams no longer than ``max_range``."""
    valid = scan.valid & (scan.ranges <= max_range)
    r, a = scan.ranges[valid], scan.angles[valid]
    if len(r) > beams:
        pick = np.round(np.linspace(0, len(r) - 1, beams)).astype(np.int64)
        r, a = r[pick], a[pick]
    lx, ly, lth = (float(v) for v in laser_pose)
    c, s = np.cos(a + lth), np.sin(a + lth)
    return np.column_stack([lx + r * c, ly + r * s])


class PoseTracker:
    """The tracked pose (``None`` while there is no track), fed odometry and scans."""

    def __init__(self, known_map: KnownMap, config: TrackingConfig | None = None):
        self.config = config or TrackingConfig()
        self.matcher = ScanToMapMatcher(known_map)
        self.pose: np.ndarray | None = None
        self.fit = 0.0
        self.misses = 0
        self._odom: np.ndarray | None = None
        self._moved = np.zeros(2)  # odometry distance and turn since the last accepted match

    @property
    def tracking(self) -> bool:
        return self.pose is not None

    def predict(self, odom: np.ndarray) -> None:
        """Move the tracked pose by the odometry since the previous call."""
        if self.pose is not None and self._odom is not None:
            step = relative(self._odom, odom)
            self.pose = compose(self.pose, step)
            self._moved += (np.hypot(step[0], step[1]), abs(step[2]))
        self._odom = np.array(odom, dtype=np.float64)

    def correct(self, points: np.ndarray) -> MatchResult | None:
        """Match the predicted pose against the map; returns the match (None without a track)."""
        if self.pose is None:
            return None
        cfg = self.config
        dist, turn = self._moved
        prior = prior_weights(cfg.prior_xy + cfg.prior_xy_per_m * dist + cfg.prior_xy_per_rad * turn,
                              cfg.prior_theta + cfg.prior_theta_per_m * dist + cfg.prior_theta_per_rad * turn)
        result = self.matcher.match(self.pose, points, prior)
        if result.fit < cfg.min_fit:
            wide = self.matcher.search(self.pose, points, cfg.search_xy, cfg.search_theta, cfg.search_step,
                                       prior)
            result = wide if wide.fit > result.fit else result
        if result.fit >= cfg.min_fit:
            self.pose, self.fit, self.misses = result.pose, result.fit, 0
            self._moved[:] = 0.0
        else:
            self.fit = result.fit
            self.misses += 1
            if self.misses >= self.config.patience:
                self.lose()
        return result

    def try_start(self, pose, points: np.ndarray) -> bool:
        """Start a track at ``pose`` refined by a match, if the map explains the scan there."""
        result = self.matcher.match(pose, points)
        if result.fit < self.config.min_fit:
            return False
        self.pose, self.fit, self.misses = result.pose, result.fit, 0
        self._moved[:] = 0.0
        return True

    def start(self, pose) -> None:
        """Track from ``pose`` as given (a known start)."""
        self.pose = np.array(pose, dtype=np.float64)
        self.misses = 0
        self._moved[:] = 0.0

    def lose(self) -> None:
        self.pose = None
        self.misses = 0
