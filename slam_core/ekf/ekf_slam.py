"""Landmark EKF SLAM: the classic cycle, one scan at a time.

1. motion update: the pose moves by the increment since the last update (:meth:`EkfState.predict`):
   scan-to-scan ICP started from the odometry increment, with the ICP's Hessian covariance,
   or the odometry increment and the motion model's covariance when the match fails;
2. landmark extraction: spikes, corners and wall lines of the scan (:mod:`slam_core.ekf.landmarks`);
3. data association: chi-square gate + nearest neighbour (:mod:`slam_core.ekf.association`);
   a line observation may only match a line landmark whose mapped extent it overlaps;
4. re-observation update: one joint EKF update with every matched landmark (the innovations
   and their covariances are kept for display);
5. new landmarks: unmatched observations wait in a tentative list (world frame) and join the
   state only once seen ``confirm_hits`` times within ``tentative_max_age`` updates.

Lines (walls) are what an indoor corridor offers most: each pins the heading and the
distance across the wall, where a corridor has few point features.

The filter runs an update only after the odometry moved ``update_translation`` metres or
``update_rotation`` radians; in between the published pose is the filter's pose moved by the
odometry increment since.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from slam_core.ekf.association import CHI2_2_99, CHI2_2_9999, associate
from slam_core.ekf.landmarks import (
    CORNER,
    LINE,
    ExtractorConfig,
    Features,
    Lines,
    extract,
    fit_lines,
    line_segments,
)
from slam_core.ekf.models import (
    inverse_line_observation,
    inverse_observation,
    observe_lines_many,
    odometry_increment,
    to_range_bearing,
)
from slam_core.ekf.scan_odometry import IcpConfig, fuse_increments, match_scans
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
    scan_matching: bool = True  # the increment from scan-to-scan ICP (odometry as its guess)
    scan_match_gate: float = 16.27  # chi-square 3 dof, 0.999: with fusion, ICP this far off is refused
    scan_match_fuse: bool = False  # fuse ICP with the odometry; False: ICP replaces it when it converges
    icp: IcpConfig = field(default_factory=IcpConfig)
    line_point_sigma: float = 0.02  # floor on the scatter (m) of scan points about a wall line
    line_effective_points: int = 20  # a wall fit counts as at most this many independent points
    line_angle_sigma: float = np.radians(1.0)  # model error of a wall line, added to the fit's (rad) ...
    line_distance_sigma: float = 0.03  # ... and (m): walls are not perfectly straight nor one plane
    line_overlap_margin: float = 0.5  # a line observation must overlap the landmark's extent + this (m)
    line_tentative_angle: float = np.radians(5.0)  # a tentative line is the same within these ...
    line_tentative_distance: float = 0.15  # ... and this distance (m)


def _ends_to_world(pose, ends) -> np.ndarray:
    """Robot-frame segment end points ``(n, 2, 2)`` in the world frame."""
    return transform_points(pose, np.asarray(ends, float).reshape(-1, 2)).reshape(-1, 2, 2)


def _segment_ends(lines, extents, anchors) -> np.ndarray:
    """End points ``(l, 2, 2)`` of anchored lines ``(ρ, α)`` between positions ``[s0, s1]`` along them
    (``s = p·d`` from the world origin, ``d`` the line's direction)."""
    lines = np.asarray(lines, float).reshape(-1, 2)
    n = np.column_stack([np.cos(lines[:, 1]), np.sin(lines[:, 1])])
    d = np.column_stack([-n[:, 1], n[:, 0]])
    foot = (lines[:, :1] + np.einsum("ij,ij->i", anchors, n)[:, None]) * n
    return np.stack([foot + extents[:, :1] * d, foot + extents[:, 1:] * d], axis=1)


def _conjugation_jacobian(offset, u, eps: float = 1e-6) -> np.ndarray:
    """Derivative of ``offset ⊕ u ⊖ offset`` by ``u`` (central differences; 3 x 3)."""
    out = np.empty((3, 3))
    for k in range(3):
        d = np.zeros(3)
        d[k] = eps
        hi = compose(compose(offset, u + d), inverse(offset))
        lo = compose(compose(offset, u - d), inverse(offset))
        diff = hi - lo
        diff[2] = wrap_angle(diff[2])
        out[:, k] = diff / (2 * eps)
    return out


@dataclass(frozen=True)
class Innovations:
    """The last update's matched observations: landmark index, innovation (range-bearing ``(r, b)``
    for a point, ``(ρ, α)`` for a line) and its covariance."""

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
        self.line_extents = np.zeros((0, 2))  # per landmark: [s0, s1] along a line, NaN for points
        self._tentative_lines = np.zeros((0, 2))  # world (ρ, α)
        self._tentative_line_extents = np.zeros((0, 2))
        self._line_hits = np.zeros(0, dtype=int)
        self._line_seen = np.zeros(0, dtype=int)

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
        """The increment from ICP of the last update's scan against this one, or the odometry's.

        ICP starts from the odometry increment and runs in the laser frame; its increment and
        Hessian covariance are carried to the robot frame (``offset ⊕ u_laser ⊖ offset``, a
        fixed linear map of small perturbations). By default a converged match replaces the
        odometry: on real logs the odometry's errors are far from the white noise a fusion
        assumes (mit-csail's wheel heading lags the scans in every turn, by up to 15 degrees
        per update), so mixing them in biases the increment, and a chi-square gate against
        the odometry refuses good matches exactly in those turns; the match's own limits
        (:class:`IcpConfig` ``max_step_change``, ``max_turn_change``) guard against a bad one.
        ``scan_match_fuse`` fuses the two by information weight instead (:func:`fuse_increments`,
        refusing matches further than ``scan_match_gate`` from the odometry).
        """
        cfg = self.config
        offset = np.asarray(cfg.laser_offset, float)
        guess = compose(compose(inverse(offset), u), offset)
        result = match_scans(self._last_scan, scan, guess, cfg.icp)
        if not result.converged:
            self.icp_failures += 1
            return u, q
        to_robot = _conjugation_jacobian(offset, result.increment)
        u_scan = compose(compose(offset, result.increment), inverse(offset))
        q_scan = to_robot @ result.covariance @ to_robot.T
        if not cfg.scan_match_fuse:
            return u_scan, q_scan
        fused, q_fused, agreed = fuse_increments(u, q, u_scan, q_scan, cfg.scan_match_gate)
        self.icp_failures += not agreed
        return fused, q_fused

    @property
    def pose(self) -> np.ndarray:
        """The current pose: the filter's pose moved by the odometry since its last update."""
        if self._odom is None:
            return self.state.pose
        return compose(self.state.pose, relative(self._filter_odom, self._odom))

    def estimate(self) -> Estimate:
        """Pose and the point landmarks (lines are in :meth:`line_segments`)."""
        points = ~self.state.lines
        return Estimate(pose=self.pose, covariance=self.state.pose_covariance,
                        landmarks=self.state.landmarks[points],
                        landmark_covariances=self.state.landmark_covariances()[points])

    def line_segments(self) -> np.ndarray:
        """World end points ``(l, 2, 2)`` of the mapped extent of every line landmark."""
        is_line = self.state.lines
        return _segment_ends(self.state.landmarks[is_line], self.line_extents[is_line],
                             self.state.anchors[is_line])

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

    def line_observations(self, scan: Scan) -> Lines:
        """The scan's wall lines in the robot frame: ``(ρ, α)``, their noise and the segment ends."""
        cfg = self.config
        offset = np.asarray(cfg.laser_offset, float)
        segments = [transform_points(offset, seg) for seg in line_segments(scan, cfg.extractor)]
        lines = fit_lines(segments, cfg.line_point_sigma, cfg.line_effective_points)
        lines.covariances[:, 0, 0] += cfg.line_distance_sigma ** 2
        lines.covariances[:, 1, 1] += cfg.line_angle_sigma ** 2
        return lines

    def _line_compatible(self, ends_world: np.ndarray) -> np.ndarray:
        """``(n_obs, k)``: line observations (world end points) overlapping line landmarks' extents."""
        k = self.state.n_landmarks
        is_line = self.state.lines
        out = np.zeros((len(ends_world), k), dtype=bool)
        if not len(ends_world) or not is_line.any():
            return out
        alpha = self.state.landmarks[is_line, 1]
        d = np.column_stack([-np.sin(alpha), np.cos(alpha)])  # (l, 2)
        s = np.einsum("ijc,lc->ilj", ends_world, d)  # (n_obs, l, 2) positions along each line
        lo, hi = s.min(axis=2), s.max(axis=2)
        ext = self.line_extents[is_line]
        spread = np.sqrt(max(np.linalg.eigvalsh(self.state.cov[:2, :2]).max(), 0.0))
        margin = self.config.line_overlap_margin + 3.0 * spread
        out[:, is_line] = (hi >= ext[None, :, 0] - margin) & (lo <= ext[None, :, 1] + margin)
        return out

    def _compatible(self, kinds_a, directions_a, kinds_b, directions_b) -> np.ndarray:
        """``(len(a), len(b))``: same kind and, for corners, bisectors within the tolerance."""
        same = kinds_a[:, None] == kinds_b[None, :]
        turn = np.abs(wrap_angle(directions_a[:, None] - directions_b[None, :]))
        return same & ((kinds_a[:, None] != CORNER) | (turn < self.config.direction_tolerance))

    def _update(self, scan: Scan) -> None:
        cfg = self.config
        feats, z_pts, r_pts = self.observations(scan)
        lines = self.line_observations(scan) if cfg.extractor.lines else Lines.empty()
        n_pts = len(z_pts)
        # points and lines go through one association and one joint update
        z = np.vstack([z_pts, lines.params])
        r = np.concatenate([r_pts, lines.covariances])
        kinds = np.concatenate([feats.kinds, np.full(len(lines), LINE)])
        directions = wrap_angle(np.concatenate([feats.directions, np.full(len(lines), np.nan)])
                                + self.state.mean[2])
        compatible = self._compatible(kinds, directions, self.landmark_kinds, self.landmark_directions)
        compatible[n_pts:] &= self._line_compatible(_ends_to_world(self.state.pose, lines.ends))
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
        self.last_features = np.array([inverse_observation(pose, zi)[0] for zi in z_pts]).reshape(-1, 2)
        ends_world = _ends_to_world(pose, lines.ends)
        line_obs = obs >= n_pts
        self._extend_lines(lms[line_obs], ends_world[obs[line_obs] - n_pts])
        directions = wrap_angle(feats.directions + self.state.mean[2])
        new = assoc.new
        self._tentatives(z_pts, r_pts, feats.kinds, directions, new[new < n_pts])
        self._tentative_wall_lines(lines, ends_world, new[new >= n_pts] - n_pts)
        self.updates += 1

    def _extend_lines(self, landmarks, ends_world) -> None:
        """Grow matched lines' extents to cover the observed segments (world end points)."""
        for j, ends in zip(landmarks, ends_world, strict=True):
            alpha = self.state.mean[3 + 2 * j + 1]
            s = ends @ np.array([-np.sin(alpha), np.cos(alpha)])
            self.line_extents[j] = [min(self.line_extents[j, 0], s.min()),
                                    max(self.line_extents[j, 1], s.max())]

    def _tentative_wall_lines(self, lines: Lines, ends_world, new) -> None:
        """The tentative list for lines: the same line seen from the current pose (robot-frame
        ``(ρ, α)`` within a distance and an angle) with overlapping extents."""
        cfg = self.config
        pose = self.state.pose
        promoted = np.zeros(len(self._tentative_lines), dtype=bool)
        hit_now = np.zeros(len(self._tentative_lines), dtype=bool)
        seen_from_here = observe_lines_many(pose, self._tentative_lines)[0]
        alpha = self._tentative_lines[:, 1]
        along = np.column_stack([-np.sin(alpha), np.cos(alpha)])
        fresh = []
        for i in new:
            z = lines.params[i]
            s = ends_world[i] @ along.T  # (2, t): the observed ends along each tentative line
            same = ((np.abs(wrap_angle(seen_from_here[:, 1] - z[1])) < cfg.line_tentative_angle)
                    & (np.abs(seen_from_here[:, 0] - z[0]) < cfg.line_tentative_distance)
                    & (s.max(axis=0) >= self._tentative_line_extents[:, 0] - cfg.line_overlap_margin)
                    & (s.min(axis=0) <= self._tentative_line_extents[:, 1] + cfg.line_overlap_margin)
                    & ~hit_now & ~promoted)
            candidates = np.flatnonzero(same)
            world = inverse_line_observation(pose, z)[0]
            own = ends_world[i] @ np.array([-np.sin(world[1]), np.cos(world[1])])
            if not len(candidates):
                if cfg.confirm_hits <= 1:
                    self._add(z, lines.covariances[i], LINE, np.nan, (own.min(), own.max()))
                else:
                    fresh.append((world, own.min(), own.max()))
                continue
            k = int(candidates[np.argmin(np.abs(seen_from_here[candidates, 0] - z[0]))])
            hit_now[k] = True
            self._line_hits[k] += 1
            self._line_seen[k] = self.updates
            ext = self._tentative_line_extents[k]
            self._tentative_line_extents[k] = [min(ext[0], s[:, k].min()), max(ext[1], s[:, k].max())]
            if self._line_hits[k] >= cfg.confirm_hits:
                self._add(z, lines.covariances[i], LINE, np.nan, (own.min(), own.max()))
                promoted[k] = True
        keep = ~promoted & (self.updates - self._line_seen < cfg.tentative_max_age)
        self._tentative_lines = np.vstack([self._tentative_lines[keep]] + [w[None] for w, _, _ in fresh])
        self._tentative_line_extents = np.vstack([self._tentative_line_extents[keep]]
                                                 + [np.array([[lo, hi]]) for _, lo, hi in fresh])
        self._line_hits = np.concatenate([self._line_hits[keep], np.ones(len(fresh), dtype=int)])
        self._line_seen = np.concatenate([self._line_seen[keep], np.full(len(fresh), self.updates)])

    def _add(self, z, r, kind, direction, extent=(np.nan, np.nan)) -> None:
        self.state.add_landmark(z, r, line=kind == LINE)
        self.landmark_kinds = np.append(self.landmark_kinds, kind)
        self.landmark_directions = np.append(self.landmark_directions, direction)
        self.line_extents = np.vstack([self.line_extents, np.asarray(extent, float).reshape(1, 2)])

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
