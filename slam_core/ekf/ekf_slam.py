"""Landmark EKF SLAM: the classic cycle, one scan at a time.

1. odometry update: the pose moves by the odometry increment (:meth:`EkfState.predict`);
2. landmark extraction: spikes and corners of the scan (:mod:`slam_core.ekf.landmarks`);
3. data association: chi-square gate + nearest neighbour (:mod:`slam_core.ekf.association`);
4. re-observation update: one joint EKF update with every matched landmark (the innovations
   and their covariances are kept for display);
5. new landmarks: unmatched observations wait in a tentative list (world frame) and join the
   state only once seen ``confirm_hits`` times within ``tentative_max_age`` updates.

The filter runs an update only after the odometry moved ``update_translation`` metres or
``update_rotation`` radians; in between the published pose is the filter's pose moved by the
odometry increment since.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from slam_core.ekf.association import CHI2_2_99, CHI2_2_9999, associate
from slam_core.ekf.landmarks import SPIKE, ExtractorConfig, Features, extract
from slam_core.ekf.models import inverse_observation, odometry_increment, to_range_bearing
from slam_core.ekf.scan_odometry import IcpConfig, match_increment
from slam_core.ekf.state import EkfState
from slam_core.estimator import Estimate
from slam_core.geometry import compose, inverse, relative, transform_points, wrap_angle
from slam_core.motion_model import OdometryMotionModel
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.scan import Scan


@dataclass(frozen=True)
class EkfConfig:
    """Tunables of the landmark EKF (metres, radians)."""

    motion: OdometryMotionModel = field(default_factory=OdometryMotionModel)
    extractor: ExtractorConfig = field(default_factory=ExtractorConfig)
    laser_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)  # laser pose in the robot frame
    point_sigma: float = 0.05  # std of a feature's position along the beam (m)
    bearing_sigma: float = 0.01  # extra bearing std (rad) on top of point_sigma / range
    gate: float = CHI2_2_99
    new_gate: float = CHI2_2_9999
    confirm_hits: int = 3
    tentative_radius: float = 0.3
    tentative_max_age: int = 5
    update_translation: float = 0.05
    update_rotation: float = 0.05
    direction_tolerance: float = np.radians(40.0)  # corners facing further apart are different
    reject_ambiguous: bool = False  # drop observations with two landmarks in their gate
    scan_matching: bool = False  # refine each odometry increment by scan-to-scan ICP
    scan_matching_noise: float = 0.5  # ICP increments get the motion covariance times this
    icp: IcpConfig = field(default_factory=IcpConfig)


@dataclass(frozen=True)
class Innovations:
    """The last update's matched observations: landmark index, innovation ``(r, b)`` and its covariance."""

    landmarks: np.ndarray  # (m,) int
    innovations: np.ndarray  # (m, 2)
    covariances: np.ndarray  # (m, 2, 2)

    @classmethod
    def empty(cls) -> Innovations:
        return cls(np.zeros(0, dtype=int), np.zeros((0, 2)), np.zeros((0, 2, 2)))


class EkfSlam:
    """The landmark EKF as an :class:`~slam_core.estimator.Estimator`."""

    def __init__(self, config: EkfConfig | None = None, initial_pose=(0.0, 0.0, 0.0)):
        self.config = config or EkfConfig()
        self.state = EkfState(initial_pose)
        self.last_innovations = Innovations.empty()
        self.last_features = np.zeros((0, 2))  # world frame, every feature of the last update
        self.updates = 0
        self._filter_odom: np.ndarray | None = None
        self._last_scan: Scan | None = None
        self.icp_failures = 0
        self._odom: np.ndarray | None = None
        self.landmark_kinds = np.zeros(0, dtype=int)  # SPIKE / CORNER per landmark
        self.landmark_directions = np.zeros(0)  # world bearing of a corner's bisector, NaN for spikes
        self._tentative = np.zeros((0, 2))
        self._tentative_kinds = np.zeros(0, dtype=int)
        self._tentative_directions = np.zeros(0)
        self._hits = np.zeros(0, dtype=int)
        self._seen = np.zeros(0, dtype=int)

    def step(self, odometry, scan: Scan) -> bool:
        odometry = np.asarray(odometry, dtype=float)
        if odometry.shape != (3,) or not np.all(np.isfinite(odometry)):
            raise ValueError(f"odometry must be 3 finite numbers (x, y, theta), got {odometry!r}")
        self._odom = odometry
        if self._filter_odom is not None:
            moved = relative(self._filter_odom, odometry)
            if (np.hypot(moved[0], moved[1]) < self.config.update_translation
                    and abs(moved[2]) < self.config.update_rotation):
                return False
            u, q = odometry_increment(self._filter_odom, odometry, self.config.motion)
            if self.config.scan_matching and self._last_scan is not None:
                u, q = self._scan_matched(u, q, scan)
            self.state.predict(u, q)
        self._filter_odom = odometry
        self._last_scan = scan
        self._update(scan)
        return True

    def _scan_matched(self, u, q, scan):
        """The increment refined by ICP of the last update's scan against this one (laser frame)."""
        offset = np.asarray(self.config.laser_offset, float)
        guess = compose(compose(inverse(offset), u), offset)
        laser_u, ok = match_increment(self._last_scan, scan, guess, self.config.icp)
        if not ok:
            self.icp_failures += 1
            return u, q
        return compose(compose(offset, laser_u), inverse(offset)), q * self.config.scan_matching_noise

    @property
    def pose(self) -> np.ndarray:
        """The current pose: the filter's pose moved by the odometry since its last update."""
        if self._odom is None:
            return self.state.pose
        return compose(self.state.pose, relative(self._filter_odom, self._odom))

    def estimate(self) -> Estimate:
        return Estimate(pose=self.pose, covariance=self.state.pose_covariance,
                        landmarks=self.state.landmarks,
                        landmark_covariances=self.state.landmark_covariances())

    def occupancy_map(self) -> OccupancyGrid | None:
        return None

    @property
    def tentative_landmarks(self) -> np.ndarray:
        """World positions ``(t, 2)`` of candidates not yet confirmed."""
        return self._tentative.copy()

    def observations(self, scan: Scan) -> tuple[Features, np.ndarray, np.ndarray]:
        """The scan's features with range-bearing ``(n, 2)`` in the robot frame and noise ``(n, 2, 2)``."""
        offset = np.asarray(self.config.laser_offset, float)
        feats = extract(scan, self.config.extractor)
        feats = Features(feats.points, feats.kinds, feats.directions + offset[2])
        z = to_range_bearing(transform_points(offset, feats.points))
        r = np.zeros((len(z), 2, 2))
        ps = self.config.point_sigma
        r[:, 0, 0] = ps * ps
        r[:, 1, 1] = (ps / np.maximum(z[:, 0], ps)) ** 2 + self.config.bearing_sigma ** 2
        return feats, z, r

    def _compatible(self, kinds_a, directions_a, kinds_b, directions_b) -> np.ndarray:
        """``(len(a), len(b))``: same kind and, for corners, bisectors within the tolerance."""
        same = kinds_a[:, None] == kinds_b[None, :]
        turn = np.abs(wrap_angle(directions_a[:, None] - directions_b[None, :]))
        return same & ((kinds_a[:, None] == SPIKE) | (turn < self.config.direction_tolerance))

    def _update(self, scan: Scan) -> None:
        cfg = self.config
        feats, z, r = self.observations(scan)
        kinds = feats.kinds
        directions = wrap_angle(feats.directions + self.state.mean[2])
        compatible = self._compatible(kinds, directions, self.landmark_kinds, self.landmark_directions)
        assoc = associate(self.state, z, r, cfg.gate, cfg.new_gate, compatible, cfg.reject_ambiguous)
        obs, lms = assoc.matches[:, 0], assoc.matches[:, 1]
        if len(obs):
            pairs = [self.state.innovation(j, z[i], r[i]) for i, j in zip(obs, lms, strict=True)]
            self.last_innovations = Innovations(lms.copy(), np.array([p[0] for p in pairs]),
                                                np.array([p[1] for p in pairs]))
            self.state.update(lms, z[obs], r[obs])
        else:
            self.last_innovations = Innovations.empty()
        pose = self.state.pose
        self.last_features = np.array([inverse_observation(pose, zi)[0] for zi in z]).reshape(-1, 2)
        directions = wrap_angle(feats.directions + self.state.mean[2])
        self._tentatives(z, r, kinds, directions, assoc.new)
        self.updates += 1

    def _add(self, z, r, kind, direction) -> None:
        self.state.add_landmark(z, r)
        self.landmark_kinds = np.append(self.landmark_kinds, kind)
        self.landmark_directions = np.append(self.landmark_directions, direction)

    def _tentatives(self, z, r, kinds, directions, new) -> None:
        """Count unmatched observations in the tentative list; promote the consistent ones."""
        cfg = self.config
        promoted = np.zeros(len(self._tentative), dtype=bool)
        hit_now = np.zeros(len(self._tentative), dtype=bool)
        compatible = self._compatible(kinds, directions, self._tentative_kinds, self._tentative_directions)
        fresh = []
        for i in new:
            p = self.last_features[i]
            if len(self._tentative):
                d = np.hypot(*(self._tentative - p).T)
                d[hit_now | promoted | ~compatible[i]] = np.inf
                k = int(np.argmin(d))
                if d[k] < cfg.tentative_radius:
                    hit_now[k] = True
                    self._hits[k] += 1
                    self._seen[k] = self.updates
                    self._tentative[k] += (p - self._tentative[k]) / self._hits[k]
                    if self._hits[k] >= cfg.confirm_hits:
                        self._add(z[i], r[i], kinds[i], directions[i])
                        promoted[k] = True
                    continue
            if cfg.confirm_hits <= 1:
                self._add(z[i], r[i], kinds[i], directions[i])
            else:
                fresh.append(i)
        keep = ~promoted & (self.updates - self._seen < cfg.tentative_max_age)
        fresh = np.array(fresh, dtype=int)
        self._tentative = np.vstack([self._tentative[keep], self.last_features[fresh].reshape(-1, 2)])
        self._tentative_kinds = np.concatenate([self._tentative_kinds[keep], kinds[fresh]])
        self._tentative_directions = np.concatenate([self._tentative_directions[keep], directions[fresh]])
        self._hits = np.concatenate([self._hits[keep], np.ones(len(fresh), dtype=int)])
        self._seen = np.concatenate([self._seen[keep], np.full(len(fresh), self.updates)])
