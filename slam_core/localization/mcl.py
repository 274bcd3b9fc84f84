"""Monte Carlo localization in a known map, AMCL-class.

Thrun, Burgard & Fox, *Probabilistic Robotics*: MCL (table 8.2) with the
odometry motion model (5.4), the likelihood-field or beam sensor model (6.3 / 6.4),
low-variance resampling only when the effective sample size falls below a
threshold, KLD-sampling for the particle count (Fox 2003), and augmented MCL
(table 8.3) for recovery: short- and long-term averages ``w_fast`` / ``w_slow``
of the measurement likelihood; each resampled particle is replaced by a random
pose in free space with probability ``max(0, 1 - w_fast / w_slow)``.

The published pose is the tracked one (:mod:`slam_core.localization.tracking`:
odometry, then scan-to-map matching on every scan) while there is a track; while the filter
searches around a lost track (below), the heaviest cluster's mean if it lies within the search's
reach of that track's pose moved on by the odometry, else that pose; else the weighted mean of
the heaviest particle cluster. Along a confirmed track, and from a lost
track to the one that resumes it, and to a confirmed track's move by the cloud, it moves
smoothly: per scan its position moves at most
``smooth_xy`` farther than the odometry moved, or while it is frozen may have moved (a correction
is spread over the next scans)
(a jump only when a track starts after a global start, which is not yet *localized*). The
filter runs on its own and checks the track: a track starts from a known pose or from the
converged main cluster, and moves there when the converged cloud disagrees with it and
the scan fits there at least as well.
While the track holds no random particles are injected (nor while a confirmed one rides out a
few scans the map does not explain), and once it is confirmed the robot is *localized*.

A confirmed track lost because the map explained too little of the scans (ranges beyond what it
holds, fog) is not a wrong pose: as AMCL users expect, the robot is still about where the
odometry says. The filter restarts *around* that pose (the lost track's pose moved on by the
odometry), with a spread growing with the odometry's travel since the track's last match
(``recover_xy``, ``recover_theta`` and their growth per metre), random particles are injected
there rather than anywhere, and on each filter update a new track is tried at that pose (where
the scan fits as well as the lost track's usually did, see :meth:`PoseTracker.try_resume`) or
at the converged cloud's; the new track must confirm itself like any other before the robot is
localized again (while it is not confirmed, the search goes on from its pose if it is dropped).
Only after ``recover_travel`` metres without a track, or when the scan that lost the track
contradicts the map around that pose and fits it well far from there (a kidnapping), does the
filter start over globally. A confirmed track that a converged cloud moved more than ``switch_xy``
must confirm itself again; dropped before it does, it is lost like a confirmed one (searched for
around its pose).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from slam_core.estimator import Estimate
from slam_core.geometry import compose, relative, wrap_angle
from slam_core.localization.beam_model import BeamModel, BeamModelParams
from slam_core.localization.beams import select_beams
from slam_core.localization.clustering import Cluster, main_cluster
from slam_core.localization.global_search import GlobalSearch
from slam_core.localization.kld import adaptive_count, pose_bins
from slam_core.localization.known_map import KnownMap
from slam_core.localization.likelihood_field import LikelihoodFieldModel, LikelihoodFieldParams
from slam_core.localization.tracking import PoseTracker, TrackingConfig, tracking_points
from slam_core.motion_model import OdometryMotionModel
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.resampling import effective_sample_size, low_variance_resample
from slam_core.scan import Scan

SENSOR_MODELS = ("likelihood_field", "beam")


@dataclass(frozen=True)
class MclConfig:
    """Tunables, named as in AMCL where AMCL has them."""

    min_particles: int = 500
    max_particles: int = 20000
    #: KLD-sampling: bound ``epsilon`` on the K-L error, ``1 - delta`` its confidence, histogram bins.
    kld_epsilon: float = 0.05
    kld_delta: float = 0.01
    kld_xy_bin: float = 0.5
    kld_theta_bin: float = np.radians(10.0)
    #: Resample when N_eff < resample_threshold * n.
    resample_threshold: float = 0.5
    #: Filter update only after this much travel (m) or turn (rad) since the last update.
    update_min_d: float = 0.1
    update_min_a: float = 0.1
    #: Augmented MCL averaging rates (0 < alpha_slow << alpha_fast); alpha_slow = 0 disables recovery.
    alpha_slow: float = 0.02
    alpha_fast: float = 0.3
    #: The beams of one scan share the map's errors: their joint log-likelihood is weighed as this
    #: many independent beams (a tempered likelihood; the cloud does not collapse on one scan).
    effective_beams: float = 10.0
    #: Beams scored per scan (evenly spaced) and the sensor model.
    max_beams: int = 60
    sensor_model: str = "likelihood_field"
    likelihood_field: LikelihoodFieldParams = field(default_factory=LikelihoodFieldParams)
    beam_model: BeamModelParams = field(default_factory=BeamModelParams)
    motion: OdometryMotionModel = field(default_factory=OdometryMotionModel)
    #: Pose of the laser in the robot (odometry) frame.
    laser_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    #: Clustering for the published pose: bin size in x, y (m) and number of heading bins.
    cluster_xy: float = 0.5
    cluster_theta_bins: int = 12
    #: The cloud has converged when its main cluster carries this much weight and its spread is
    #: this small ...
    localized_weight: float = 0.9
    localized_xy_std: float = 0.15
    localized_theta_std: float = np.radians(8.0)
    #: ... and the filter is not injecting more than this fraction of random particles,
    #: and has corrected at least this many times since it was (re)initialized.
    localized_max_injection: float = 0.3
    localized_min_updates: int = 5
    tracking: TrackingConfig = field(default_factory=TrackingConfig)
    #: A converged cloud this far (m, rad) from the track is checked against it (see ``_track``).
    disagree_xy: float = 0.3
    disagree_theta: float = np.radians(6.0)
    #: Filter updates a converged cloud may sit where the scan fits badly before a global restart.
    relocalize_after: int = 10
    #: Without a track: how many distinct heavy particles (among the ``hypothesis_pool`` heaviest)
    #: the matcher refines, and by how much the best fit must beat the others to start a track.
    hypotheses: int = 20
    hypothesis_pool: int = 2000
    hypothesis_margin: float = 0.05
    #: A global start seeds ``global_seeded`` of the particles around the ``global_candidates`` best
    #: poses of the first scan over the whole map (:mod:`slam_core.localization.global_search`,
    #: with ``global_beams`` beams up to ``global_range`` m); the rest stay uniform.
    global_candidates: int = 100
    global_seeded: float = 0.5
    global_beams: int = 60
    global_range: float = 15.0
    #: A lost confirmed track (see the module doc) restarts the filter around its odometry pose with
    #: standard deviations ``recover_xy + recover_xy_per_m * d`` (m) and ``recover_theta +
    #: recover_theta_per_m * d`` (rad), ``d`` the odometry travel since its last match, before a
    #: global restart after ``recover_travel`` (m) of that travel without a new track.
    recover_xy: float = 0.3
    recover_xy_per_m: float = 0.1
    recover_theta: float = np.radians(5.0)
    recover_theta_per_m: float = np.radians(1.0)
    recover_travel: float = 30.0
    #: Along a confirmed track the published position moves per scan at most this much (m) more
    #: than the odometry did (the heading is corrected at once: holding it back would carry the
    #: position off).
    smooth_xy: float = 0.2

    def __post_init__(self):
        if not 1 <= self.min_particles <= self.max_particles:
            raise ValueError(f"need 1 <= min_particles <= max_particles, got "
                             f"{self.min_particles}, {self.max_particles}")
        if self.sensor_model not in SENSOR_MODELS:
            raise ValueError(f"sensor_model must be one of {SENSOR_MODELS}, got {self.sensor_model!r}")
        if not 0 <= self.alpha_slow <= self.alpha_fast <= 1:
            raise ValueError(f"need 0 <= alpha_slow <= alpha_fast <= 1, got "
                             f"{self.alpha_slow}, {self.alpha_fast}")
        if not 0 < self.resample_threshold <= 1:
            raise ValueError(f"resample_threshold is a fraction in (0, 1], got {self.resample_threshold}")
        if self.max_beams < 1 or self.update_min_d < 0 or self.update_min_a < 0:
            raise ValueError("need max_beams >= 1 and non-negative update thresholds")


@dataclass(frozen=True)
class MclStatus:
    """What the last update did, for dashboards and logs."""

    particles: int
    effective_sample_size: float
    resampled: bool
    w_slow: float
    w_fast: float
    injection: float
    beams: int


class MonteCarloLocalizer:
    """Monte Carlo localization against a known :class:`OccupancyGrid` (an :class:`Estimator`).

    Starts from ``initial_pose`` with ``initial_covariance`` (3x3, default 0.25 m and
    15 deg standard deviation) or, without a pose, globally (uniform over free space).
    """

    def __init__(self, grid: OccupancyGrid, config: MclConfig | None = None,
                 rng: np.random.Generator | None = None, initial_pose=None, initial_covariance=None):
        self.config = config or MclConfig()
        self.rng = rng if rng is not None else np.random.default_rng()
        self.map = KnownMap(grid)
        if self.config.sensor_model == "beam":
            self.sensor = BeamModel(self.map, self.config.beam_model)
        else:
            self.sensor = LikelihoodFieldModel(self.map, self.config.likelihood_field)
        self._last_odom: np.ndarray | None = None
        self._raw_odom: np.ndarray | None = None  # the odometry as reported at the previous scan
        self._odom = np.zeros(3)  # and as corrected by the tracker's calibration since the first
        self._estimate: Estimate | None = None
        self._published: np.ndarray | None = None  # the position published, smoothed (see _publish)
        self._published_odom = np.zeros(3)  # and the odometry then
        self._track_confirmed = False  # whether the track was confirmed after the previous scan
        self._switched = False  # the track was a confirmed one moved far, not confirmed again since
        self._global_search: GlobalSearch | None = None  # built at the first global start
        self._seed_pending = False  # a global start waits for a scan to seed the particles
        self._lost: np.ndarray | None = None  # a lost track's pose moved on by the odometry (recovery)
        self._lost_travel = 0.0  # odometry travel since that track's last match
        self._lost_fit = 0.0  # and its usual fit
        self.tracker = PoseTracker(self.map, self.config.tracking)
        self._badly_converged = 0
        self.filter_updated = False
        self.status = MclStatus(0, 0.0, False, 0.0, 0.0, 0.0, 0)
        if initial_pose is None:
            self.global_localization()
        else:
            self.set_pose(initial_pose, initial_covariance)

    # -- initialization -------------------------------------------------------------------
    def global_localization(self) -> None:
        """Forget the pose: ``max_particles`` uniform over free space, any heading (part of them
        moved where the next scan fits best, see ``global_seeded``)."""
        self._reset(self.map.sample_free_poses(self.config.max_particles, self.rng))
        self.tracker.lose()
        self._seed_pending = True
        self._lost = None
        self._switched = False
        self._published = None

    def _recover(self, pose: np.ndarray, travel: float, fit: float) -> None:
        """Restart the filter around the lost track's ``pose``, ``travel`` m of odometry after its
        last match, where it usually fitted at ``fit`` (see the module doc)."""
        self._lost, self._lost_travel, self._lost_fit = pose.copy(), travel, fit
        self._reset(self._around_lost(self.config.max_particles))
        self._seed_pending = False

    def _recover_spread(self, travel: float) -> tuple[float, float]:
        """Standard deviations (m, rad) of a restart around a track lost ``travel`` m ago."""
        cfg = self.config
        return (cfg.recover_xy + cfg.recover_xy_per_m * travel,
                cfg.recover_theta + cfg.recover_theta_per_m * travel)

    def _around_lost(self, n: int) -> np.ndarray:
        """``n`` poses drawn around the lost track's odometry pose, spread by the travel since."""
        xy, theta = self._recover_spread(self._lost_travel)
        poses = self._lost + self.rng.normal(0.0, 1.0, (n, 3)) * (xy, xy, theta)
        poses[:, 2] = wrap_angle(poses[:, 2])
        return poses

    def set_pose(self, pose, covariance=None) -> None:
        """"I am here": particles drawn from a Gaussian around ``pose`` (x, y, theta)."""
        pose = np.asarray(pose, dtype=np.float64).reshape(-1)
        if pose.shape != (3,) or not np.all(np.isfinite(pose)):
            raise ValueError(f"pose must be three finite numbers (x, y, theta), got {pose}")
        if covariance is None:
            covariance = np.diag([0.25 ** 2, 0.25 ** 2, np.radians(15.0) ** 2])
        cov = np.asarray(covariance, dtype=np.float64)
        if cov.shape != (3, 3) or not np.allclose(cov, cov.T) or np.any(np.linalg.eigvalsh(cov) < -1e-12):
            raise ValueError(f"covariance must be a symmetric positive semi-definite 3x3 matrix, got {cov}")
        n = self.config.max_particles
        particles = self.rng.multivariate_normal(pose, cov, size=n, method="eigh")
        particles[:, 2] = wrap_angle(particles[:, 2])
        self._reset(particles)
        self.tracker.start(pose)
        self._seed_pending = False
        self._lost = None
        self._switched = False
        self._published = None

    def _reset(self, particles: np.ndarray) -> None:
        self.particles = np.ascontiguousarray(particles, dtype=np.float64)
        self.weights = np.full(len(particles), 1.0 / len(particles))
        self._fresh = np.zeros(len(particles), bool)
        self.updates_since_reset = 0
        self.w_slow = 0.0
        self.w_fast = 0.0
        self._badly_converged = 0
        self._estimate = None

    # -- the filter -----------------------------------------------------------------------
    def step(self, odometry, scan: Scan) -> bool:
        """Track the pose on every scan; run the particle filter when the robot moved enough.

        The filter's first call only corrects; later calls wait until the robot moved
        ``update_min_d`` or turned ``update_min_a`` (``filter_updated`` says whether it
        ran). Returns True when the published pose is up to date with ``odometry`` (a
        track, or a filter update), False when it is the filter's last estimate.
        """
        odom = np.asarray(odometry, dtype=np.float64).reshape(-1)
        if odom.shape != (3,) or not np.all(np.isfinite(odom)):
            raise ValueError(f"odometry must be three finite numbers (x, y, theta), got {odom}")
        raw, odom = odom, self._corrected(odom)
        if self._lost is not None:  # move the lost track's pose on (the previous scan's odometry)
            step = relative(self._published_odom, odom)
            self._lost = compose(self._lost, step)
            self._lost_travel += float(np.hypot(step[0], step[1]))
            if not self.tracker.tracking and self._lost_travel > self.config.recover_travel:
                self.global_localization()
        self.tracker.predict(raw)  # it corrects the odometry itself, and learns from it as reported
        self.filter_updated = self._filter_step(odom, scan)
        self._track(scan, self.filter_updated)
        self._publish(odom)
        self._estimate = None
        return self.filter_updated or self.tracker.tracking

    def _corrected(self, odom: np.ndarray) -> np.ndarray:
        """The odometry with each step since the previous scan corrected by the odometry's systematic
        errors the tracker has measured: what the filter, a lost track and the smoothing move by."""
        if self._raw_odom is None:
            self._odom = odom.copy()
        else:
            self._odom = compose(self._odom, self.tracker.corrected(relative(self._raw_odom, odom)))
        self._raw_odom = odom
        return self._odom

    def _publish(self, odom: np.ndarray) -> None:
        """Move the published position towards the confirmed track, or while the filter searches
        around a lost track towards a new track or else :meth:`_searching_pose`, at most
        ``smooth_xy`` farther than the odometry moved since the previous scan (or, while it is
        frozen, may have moved: :attr:`PoseTracker.unseen_step`); any other track
        (after a global start) is published as it is."""
        t = self.tracker
        smooth = self._lost is not None or (t.tracking and (t.confirmed or self._switched))
        if not smooth:
            self._published = None
            self._published_odom = odom
            return
        target = t.pose if t.tracking else self._searching_pose(self.main_cluster())
        if self._published is None:
            self._published = target[:2].copy()
        else:
            step = target[:2] - self._published
            dist = float(np.hypot(step[0], step[1]))
            moved = float(np.hypot(*(odom[:2] - self._published_odom[:2]))) + t.unseen_step
            limit = moved + self.config.smooth_xy
            self._published = self._published + step * min(1.0, limit / dist if dist > 0 else 1.0)
        self._published_odom = odom

    def _searching_pose(self, cluster: Cluster) -> np.ndarray:
        """Where the robot is while the filter searches around a lost track: the main cluster if it
        lies within three of the search's standard deviations of the lost track's pose moved on by
        the odometry (the cloud weighs what the scans still say), else that pose."""
        xy, theta = self._recover_spread(self._lost_travel)
        off = relative(self._lost, cluster.pose)
        near = np.hypot(off[0], off[1]) <= 3.0 * xy and abs(off[2]) <= 3.0 * theta
        return cluster.pose if near else self._lost

    def _filter_step(self, odom: np.ndarray, scan: Scan) -> bool:
        cfg = self.config
        if self._last_odom is not None:
            delta = relative(self._last_odom, odom)
            if np.hypot(delta[0], delta[1]) < cfg.update_min_d and abs(delta[2]) < cfg.update_min_a:
                return False
            self.particles = cfg.motion.sample(self.particles, self._last_odom, odom, self.rng)
        self._last_odom = odom
        if self._seed_pending:
            self._seed(scan)
        self._correct(scan)
        self.updates_since_reset += 1
        return True

    def _seed(self, scan: Scan) -> None:
        """Move ``global_seeded`` of the particles close to the poses where the scan fits the whole
        map best (within a lattice stride and half a heading step)."""
        cfg = self.config
        self._seed_pending = False
        poses = self._global_best(scan)
        n = int(cfg.global_seeded * len(self.particles))
        if len(poses) == 0 or n == 0:
            return
        pick = poses[self.rng.integers(0, len(poses), n)]
        spread = (self._global_search.stride / 2, self._global_search.stride / 2,
                  self._global_search.heading_step / 2)
        seeded = pick + self.rng.uniform(-1.0, 1.0, (n, 3)) * spread
        seeded[:, 2] = wrap_angle(seeded[:, 2])
        self.particles[:n] = seeded

    def _global_best(self, scan: Scan) -> np.ndarray:
        """The ``global_candidates`` poses where ``scan`` fits the whole map best (the
        :class:`GlobalSearch` is built at its first use)."""
        cfg = self.config
        if self._global_search is None:
            self._global_search = GlobalSearch(self.map)
        points = tracking_points(scan, cfg.laser_pose, cfg.global_beams, cfg.global_range)
        return self._global_search.best(points, cfg.global_candidates)[0]

    def _track(self, scan: Scan, filter_updated: bool) -> None:
        """Match the tracked pose, and settle it with the filter after each filter update.

        A converged cloud that the track disagrees with wins when the scan fits the map
        there at least as well as at the track (the filter weighs many scans, the track
        one), or well (``start_fit``); against a track resumed after a loss (the cloud
        weighed scans the map did not explain), only when it fits ``hypothesis_margin``
        better. Without a track, a converged cloud starts one
        where the scan fits well; else the filter's best distinct hypotheses are refined
        by the matcher and one that fits well, clearly better than any other, starts it.
        A cloud that stays converged where it fits badly for ``relocalize_after`` updates
        is wrong, and the filter starts over globally, as it does when a confirmed track
        is lost (a kidnapping) where the cloud does not fit well either. When a track is
        confirmed, the cloud is drawn again around it.
        """
        cfg = self.config
        t = self.tracker
        points = tracking_points(scan, cfg.laser_pose, cfg.tracking.beams, cfg.tracking.max_range)
        if t.tracking:
            was_confirmed, predicted, usual = t.confirmed, t.pose.copy(), t.usual_fit or 0.0
            t.correct(points, cfg.laser_pose[:2], scan.timestamp)
            if not t.tracking:  # lost (or carried off): the cloud's pose, or start over
                found = self._converged() and t.try_start(self.main_cluster().pose, points)
                if not found and (was_confirmed or self._switched):
                    self._switched = False
                    if self._fits_elsewhere(scan, points, predicted, t.unmatched_travel):
                        self.global_localization()
                    else:
                        self._recover(predicted, t.unmatched_travel, usual)
                elif not found and self._lost is not None:  # a new track dropped: look on from it
                    self._lost, self._lost_travel = predicted, t.unmatched_travel
                return
            if t.confirmed and not self._track_confirmed:
                self._surround(t.pose)
                self._lost = None
                self._switched = False
            elif self._lost is not None:  # a new track, not confirmed yet: if it is dropped, look there
                self._lost, self._lost_travel = t.pose.copy(), t.unmatched_travel
            self._track_confirmed = t.confirmed
        if not filter_updated:
            return
        converged = self._converged()
        if t.tracking:
            if converged and not t.occluded and self._disagrees(self.main_cluster().pose, t.pose):
                # a track resumed after a loss outweighs a cloud that weighed scans the map did not
                # explain: the cloud must fit clearly better
                margin = cfg.hypothesis_margin if self._lost is not None else 0.0
                confirmed = t.confirmed
                if t.try_switch(self.main_cluster().pose, points, margin) and confirmed and not t.confirmed:
                    self._switched = True  # dropped before it confirms itself, it is lost like one
            self._badly_converged = 0
        elif ((self._lost is not None and (t.try_resume(self._lost, points, self._lost_fit) or (
                converged and t.try_resume(self.main_cluster().pose, points, self._lost_fit))))
              or (converged and t.try_start(self.main_cluster().pose, points))
              or self._start_from_hypotheses(points)):
            self._badly_converged = 0
        elif converged:
            self._badly_converged += 1
            if self._badly_converged >= cfg.relocalize_after:
                if self._lost is not None:
                    self._reset(self._around_lost(cfg.max_particles))
                else:
                    self.global_localization()

    def _fits_elsewhere(self, scan: Scan, points: np.ndarray, pose: np.ndarray, travel: float) -> bool:
        """Whether the robot was carried off, rather than the map explaining too little of what it
        sees: the scan does not fit the map near ``pose`` (at the best pose of the tracker's fallback
        search around it, the map explains less than ``min_fit`` of it, or more than ``max_through``
        of its beams pass through walls; a track that slid off the walls, or a scan the map explains
        in part, do neither) and it fits the map well (``start_fit``) at one of the best poses of a
        global search (refined by the matcher) that a restart around ``pose`` after ``travel`` m
        would not consider (more than three of its standard deviations off). A look-alike that fits
        elsewhere is no kidnapping by itself."""
        cfg = self.config
        t, matcher = cfg.tracking, self.tracker.matcher
        near = matcher.search(pose, points, t.search_xy, t.search_theta, t.search_step)
        if near.fit >= t.min_fit and (matcher.seen_through(near.pose, points, cfg.laser_pose[:2])
                                      <= t.max_through):
            return False
        xy, theta = self._recover_spread(travel)
        for candidate in self._global_best(scan):
            match = matcher.match(candidate, points)
            off = relative(pose, match.pose)
            if match.fit >= t.start_fit and (np.hypot(off[0], off[1]) > 3.0 * xy
                                             or abs(off[2]) > 3.0 * theta):
                return True
        return False

    def _start_from_hypotheses(self, points: np.ndarray) -> bool:
        """Refine the heaviest distinct particles by matching; start the track at the best if it fits
        well (``start_fit``) and ``hypothesis_margin`` better than any other more than
        ``cluster_xy`` away."""
        cfg = self.config
        matches = [self.tracker.matcher.match(p, points) for p in self._hypotheses()]
        if not matches:
            return False
        matches.sort(key=lambda m: -m.fit)
        best = matches[0]
        rivals = [m.fit for m in matches[1:] if np.hypot(*(m.pose[:2] - best.pose[:2])) > cfg.cluster_xy]
        if rivals and best.fit < rivals[0] + cfg.hypothesis_margin:
            return False
        return self.tracker.try_start(best.pose, points)

    def _hypotheses(self) -> list[np.ndarray]:
        """Up to ``hypotheses`` of the heaviest particles, each ``cluster_xy`` or 30 deg from the others."""
        cfg = self.config
        picked: list[np.ndarray] = []
        for i in np.argsort(-self.weights)[:cfg.hypothesis_pool]:
            p = self.particles[i]
            if all(np.hypot(p[0] - q[0], p[1] - q[1]) > cfg.cluster_xy
                   or abs(wrap_angle(p[2] - q[2])) > np.radians(30.0) for q in picked):
                picked.append(p)
                if len(picked) == cfg.hypotheses:
                    break
        return picked

    def _surround(self, pose: np.ndarray) -> None:
        """Draw the cloud again around the (confirmed) track, keeping the track."""
        cov = np.diag([self.config.localized_xy_std, self.config.localized_xy_std,
                       self.config.localized_theta_std]) ** 2
        particles = self.rng.multivariate_normal(pose, cov, size=self.config.min_particles, method="eigh")
        particles[:, 2] = wrap_angle(particles[:, 2])
        self._reset(particles)
        self.updates_since_reset = self.config.localized_min_updates

    def _converged(self) -> bool:
        """The cloud has one tight dominant cluster and is not busy injecting random guesses."""
        cfg = self.config
        c = self.main_cluster()
        xy_std = float(np.sqrt(max(c.covariance[0, 0], c.covariance[1, 1])))
        return (c.weight >= cfg.localized_weight and xy_std <= cfg.localized_xy_std
                and np.sqrt(c.covariance[2, 2]) <= cfg.localized_theta_std
                and self.status.injection <= cfg.localized_max_injection
                and self.updates_since_reset >= cfg.localized_min_updates)

    def _disagrees(self, mean: np.ndarray, tracked: np.ndarray) -> bool:
        """Whether a converged cloud's mean and the track are too far apart to be the same pose."""
        off = relative(mean, tracked)
        cfg = self.config
        return bool(np.hypot(off[0], off[1]) > cfg.disagree_xy or abs(off[2]) > cfg.disagree_theta)

    def _correct(self, scan: Scan) -> None:
        cfg = self.config
        beams = select_beams(scan, cfg.max_beams)
        log_lik, used = self.sensor.log_likelihood(self.particles, beams, cfg.laser_pose)
        if used == 0:  # nothing to compare with the map: keep the prediction
            self.status = MclStatus(len(self.particles), effective_sample_size(self.weights), False,
                                    self.w_slow, self.w_fast, 0.0, 0)
            self._estimate = None
            return
        # Augmented MCL averages a per-beam (geometric mean) likelihood, independent of beam count,
        # over the particles that were not just injected: random guesses would otherwise keep the
        # average low and the injection going after the filter has recovered.
        kept = self.weights * ~self._fresh
        if kept.sum() <= 0.0:
            kept = self.weights
        w_avg = float(kept @ np.exp(log_lik / used) / kept.sum())
        if self.w_slow == 0.0:
            self.w_slow = self.w_fast = w_avg
        else:
            self.w_slow += cfg.alpha_slow * (w_avg - self.w_slow)
            self.w_fast += cfg.alpha_fast * (w_avg - self.w_fast)
        injection = max(0.0, 1.0 - self.w_fast / self.w_slow) if cfg.alpha_slow > 0 else 0.0
        if self.tracker.tracking and (self.tracker.misses == 0 or self.tracker.confirmed):
            injection = 0.0  # the map explains the scans, or a confirmed track rides out a miss
        log_w = np.log(self.weights) + log_lik * (cfg.effective_beams / used)
        w = np.exp(log_w - log_w.max())
        self.weights = w / w.sum()
        neff = effective_sample_size(self.weights)
        resample = neff < cfg.resample_threshold * len(self.weights) or injection > 0.0
        if resample:
            self._resample(injection)
        self.status = MclStatus(len(self.particles), neff, resample, self.w_slow, self.w_fast,
                                injection, used)
        self._estimate = None

    def _resample(self, injection: float) -> None:
        """Low-variance resampling to a KLD-sampling count, replacing some draws by random poses."""
        cfg = self.config
        idx = low_variance_resample(self.weights, self.rng, cfg.max_particles)
        self.rng.shuffle(idx)  # KLD keeps a prefix: it must be a fair subsample
        drawn = self.particles[idx]
        fresh = self.rng.random(len(drawn)) < injection
        if fresh.any():
            k = int(fresh.sum())  # anywhere, or around a lost track's odometry pose
            drawn[fresh] = (self._around_lost(k) if self._lost is not None
                            else self.map.sample_free_poses(k, self.rng))
        keys = pose_bins(drawn, cfg.kld_xy_bin, cfg.kld_theta_bin)
        n = adaptive_count(keys, cfg.kld_epsilon, cfg.kld_delta, cfg.min_particles, cfg.max_particles)
        self.particles = np.ascontiguousarray(drawn[:n])
        self.weights = np.full(n, 1.0 / n)
        self._fresh = fresh[:n]

    # -- what it publishes ----------------------------------------------------------------
    def main_cluster(self) -> Cluster:
        cfg = self.config
        return main_cluster(self.particles, self.weights, cfg.cluster_xy, cfg.cluster_theta_bins)

    def estimate(self) -> Estimate:
        """The published pose while there is a track (see the module doc); without one, while the
        filter searches around a lost track, :meth:`_searching_pose` (with the search's spread),
        else the main cluster's mean. ``localized`` while the track is confirmed,
        the last scan fitted (not missed, not occluded) and the published pose is within
        ``disagree_xy`` of the track."""
        if self._estimate is None:
            c = self.main_cluster()
            t = self.tracker
            covariance = c.covariance
            if t.tracking:
                pose = t.pose.copy()
            elif self._lost is not None:
                pose = self._searching_pose(c).copy()
                xy, theta = self._recover_spread(self._lost_travel)
                covariance = np.diag([xy * xy, xy * xy, theta * theta])
            else:
                pose = c.pose.copy()
            if self._published is not None:
                pose[:2] = self._published
            caught_up = not t.tracking or np.hypot(*(pose[:2] - t.pose[:2])) <= self.config.disagree_xy
            self._estimate = Estimate(pose=pose, covariance=covariance, particles=self.particles,
                                      weights=self.weights, localized=t.tracking and t.confirmed
                                      and t.misses == 0 and not t.occluded and bool(caught_up))
        return self._estimate

    def occupancy_map(self) -> OccupancyGrid:
        return self.map.grid
