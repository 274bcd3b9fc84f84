"""Rao-Blackwellized particle filter SLAM with the improved proposal (GMapping-class).

The joint posterior factors as ``p(x_1:t, m | z_1:t, u_1:t-1) =
p(m | x_1:t, z_1:t) p(x_1:t | z_1:t, u_1:t-1)``: particles sample trajectories,
and each carries the map that its trajectory implies. The filter updates when the
odometry has moved past a linear or angular threshold, or when the scan, seen from
the odometry's prediction, fits the leading map much worse than the last update's
did (the odometry missed a motion). One update:

0. find the odometry's error on the leading particle's map
   (:meth:`RBPFSlam._odometry_error`), which every particle's match starts from;
1. draw every particle's pose from the improved proposal and weight it
   (:mod:`slam_core.rbpf.proposal`); in an update the scan forced, the motion
   prior is widened by the error found in step 0, which the odometry just missed;
2. if ``N_eff`` fell below the threshold, resample (low variance); copies share
   their map tiles and their trajectory history;
3. integrate the scan into every particle's map at its new pose.

Loops the particles could not close are closed afterwards on the best
particle's trajectory by :mod:`slam_core.graph.loop_closure`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from slam_core.estimator import Estimate
from slam_core.geometry import compose, mean_pose, relative, wrap_angle
from slam_core.motion_model import decompose
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.odometry_calibration import OdometryCalibration
from slam_core.rbpf.config import RBPFConfig
from slam_core.rbpf.correlative import likelihood_window, search
from slam_core.rbpf.laser_mount import LaserMount
from slam_core.rbpf.proposal import improved_proposal, match_starts, motion_draws
from slam_core.rbpf.scan_matcher import P_OCCUPIED, beam_rows, match, pose_likelihood
from slam_core.rbpf.tiled_map import TiledMaps
from slam_core.rbpf.trajectory_tree import ROOT, TrajectoryTree
from slam_core.resampling import effective_sample_size, low_variance_resample, normalized
from slam_core.scan import Scan

#: Travel (m) between the starts that take back part of a reported motion.
TAKE_BACK_STEP = 0.05


@dataclass
class RBPFStats:
    """What the filter did so far."""

    scans: int = 0
    updates: int = 0
    resamplings: int = 0
    matched: int = 0
    fallbacks: int = 0
    coarse_searches: int = 0
    take_back_searches: int = 0
    forced_updates: int = 0
    last_neff: float = 0.0
    #: The odometry's calibration, summarised on demand (:attr:`odometry`): fitting it at every update
    #: took 1.7 s of intel's 25 s in the filter.
    calibration: OdometryCalibration | None = field(default=None, repr=False, compare=False)

    @property
    def odometry(self) -> dict:
        """The calibration's summary, empty before it measured an error."""
        summary = self.calibration.summary() if self.calibration is not None else {}
        return summary if summary.get("errors_measured") else {}

    def as_dict(self) -> dict:
        out = {k: v for k, v in self.__dict__.items() if k != "calibration"}
        return {**out, "odometry": self.odometry}


class RBPFSlam:
    """The incremental filter: feed ``step(odometry, scan)``; read ``estimate()`` and maps.

    ``laser_mount`` is the laser's pose ``(x, y, theta)`` in the robot frame. Particles
    carry the laser's pose (scans are matched and drawn from there); odometry in, poses
    out (``estimate``, ``best_path``, ``update_odometry``) are the robot's.
    """

    def __init__(self, config: RBPFConfig | None = None, seed: int = 0, initial_pose=(0.0, 0.0, 0.0),
                 laser_mount=(0.0, 0.0, 0.0)):
        self.config = config or RBPFConfig()
        self.mount = LaserMount.of(laser_mount)
        n = self.config.particles
        if n < 1:
            raise ValueError("need at least one particle")
        self.rng = np.random.default_rng(seed)
        self.maps = TiledMaps(n, self.config.resolution, self.config.sensor)
        self.poses = np.tile(self.mount.laser_poses(initial_pose), (n, 1))
        self.log_weights = np.zeros(n)
        self.path_scores = np.zeros(n)
        self.tree = TrajectoryTree()
        self.nodes = np.full(n, ROOT, np.int64)
        self.stats = RBPFStats()
        self.update_odometry: list[np.ndarray] = []
        self._last_odom: np.ndarray | None = None
        self._last_fit = 0.0
        self._after_forced = False  # the last update was one the scan forced (see _take_back)
        self._params = self.config.matcher.packed()
        c = self.config
        self.calibration = OdometryCalibration(c.motion.alphas, c.calibration_window,
                                               c.calibration_min_samples, c.calibration_min_scale)
        self.stats.calibration = self.calibration

    # -- the estimator interface --------------------------------------------------

    def step(self, odometry, scan: Scan) -> bool:
        """Process one odometry pose (the robot's) with its scan; True when the filter updated."""
        robot_odometry = np.asarray(odometry, dtype=float)
        updated = self._step(self.mount.laser_poses(robot_odometry), scan)
        if updated:
            self.update_odometry.append(robot_odometry.copy())
        return updated

    def _step(self, odometry: np.ndarray, scan: Scan) -> bool:
        """``step`` with the laser's odometry."""
        self.stats.scans += 1
        if self._last_odom is None:
            self._first_update(odometry, scan)
            return True
        moved = relative(self._last_odom, odometry)
        c = self.config
        if np.hypot(moved[0], moved[1]) < c.linear_update and abs(moved[2]) < c.angular_update:
            if not self._scan_disagrees(moved, scan):
                return False
            self.stats.forced_updates += 1
            self._update(self._last_odom, odometry, scan, forced=True)
            return True
        self._update(self._last_odom, odometry, scan)
        return True

    def estimate(self) -> Estimate:
        """Weighted mean robot pose (circular mean heading) with the particle cloud."""
        w = normalized(self.log_weights)
        robot = self.mount.robot_poses(self.poses)
        mean = mean_pose(robot, w)
        d = robot - mean
        d[:, 2] = wrap_angle(d[:, 2])
        cov = (d * w[:, None]).T @ d
        return Estimate(pose=mean, covariance=cov, particles=robot.copy(), weights=w, localized=True)

    def occupancy_map(self) -> OccupancyGrid:
        """The best particle's map."""
        return self.maps.to_grid(self.best_index())

    def map_extent(self) -> tuple[float, float, float, float] | None:
        """World bounds of :meth:`occupancy_map` (``None`` while it is empty), without making it."""
        return self.maps.extent(self.best_index())

    # -- results --------------------------------------------------------------------

    def best_index(self) -> int:
        """The particle whose whole trajectory has the highest importance weight."""
        return int(np.argmax(self.path_scores))

    def best_path(self) -> tuple[np.ndarray, np.ndarray]:
        """``(update indices, robot poses)`` of the best particle's trajectory at every update."""
        updates, poses = self.tree.path(int(self.nodes[self.best_index()]))
        return updates, self.mount.robot_poses(poses)

    def map_bytes(self) -> int:
        return self.maps.nbytes()

    # -- the filter -------------------------------------------------------------------

    def _first_update(self, odometry: np.ndarray, scan: Scan) -> None:
        self.maps.integrate(self.poses, scan)
        self.maps.resample(np.zeros(self.config.particles, np.int64))  # one shared map
        self._finish_update(odometry)

    def _update(self, odom0: np.ndarray, odom1: np.ndarray, scan: Scan, forced: bool = False) -> None:
        c = self.config
        m = c.matcher
        n = c.particles
        beams = self._matching_beams(scan, m.max_range, m.max_beams)
        motion = np.array(decompose(*odom0, *odom1))
        predicted = compose(self.poses, relative(odom0, odom1))
        error, trusted = self._odometry_error(predicted, motion, scan, beams)
        self._after_forced = forced
        if trusted:
            self.calibration.observe(motion, error)
        starts = compose(predicted, error)
        floor = m.motion_floor()
        if forced:
            # the odometry missed this motion: its prediction is only as good as its error
            floor = floor + np.array([error[0] ** 2 + error[1] ** 2] * 2 + [error[2] ** 2])
        noise = self.rng.standard_normal((n, 3))
        new_poses = np.empty((n, 3))
        log_eta = np.empty(n)
        matched = np.empty(n, np.bool_)
        min_matched = max(float(m.min_matched_beams), m.min_matched * len(beams))
        improved_proposal(*self._kernel_maps(), self.poses, starts, motion, c.motion.alphas, beams,
                          self._params, m.iterations, m.wide_iterations, min_matched, floor, noise, new_poses,
                          log_eta, matched)
        if not matched.all():  # the calibration is fitted only when a particle needs it
            motion_draws(*self._kernel_maps(), self.poses, np.flatnonzero(~matched),
                         self.calibration.corrected(motion), self.calibration.fallback_alphas(), beams,
                         self._params, noise, new_poses, log_eta)
        self.poses = new_poses
        log_eta = log_eta / m.gain
        self.log_weights = self.log_weights + log_eta
        self.log_weights -= self.log_weights.max()
        self.path_scores = self.path_scores + log_eta
        self.path_scores -= self.path_scores.max()
        self.stats.matched += int(matched.sum())
        self.stats.fallbacks += int((~matched).sum())
        neff = effective_sample_size(normalized(self.log_weights))
        self.stats.last_neff = neff
        if neff < c.resample_threshold * n:
            self._resample()
        lead = int(np.argmax(self.log_weights))
        self._last_fit = self._fit(lead, self.poses[lead], beams)
        self.maps.integrate(self.poses, scan)
        self._finish_update(odom1)

    def _kernel_maps(self, lead: int | None = None) -> tuple:
        """The particles' maps (map ``lead``'s alone if given) as the kernels take them. Not to be
        held while the maps integrate a scan: a pool that another reference views is copied when it
        grows, not remapped (:mod:`slam_core.mapped_pools`), which held freiburg-campus's pools twice
        (+150 MB)."""
        m = self.maps
        tables = m.tables if lead is None else m.tables[lead]
        return tables, m.lo, m.hits, m.origin[0], m.origin[1], m.resolution

    def _resample(self) -> None:
        idx = low_variance_resample(normalized(self.log_weights), self.rng)
        self.maps.resample(idx)
        self.poses = self.poses[idx]
        self.nodes = self.nodes[idx]
        self.path_scores = self.path_scores[idx]
        self.log_weights = np.zeros(len(idx))
        self.stats.resamplings += 1

    def _finish_update(self, odometry: np.ndarray) -> None:
        self.nodes = self.tree.add(self.nodes, self.stats.updates, self.poses)
        self._last_odom = odometry.copy()
        self.stats.updates += 1

    def _fit(self, lead: int, pose: np.ndarray, beams: np.ndarray) -> float:
        """Fraction of ``beams`` that find a surface on map ``lead`` from ``pose``."""
        if len(beams) == 0:
            return 0.0
        _, matched = pose_likelihood(*self._kernel_maps(lead), pose[0], pose[1], pose[2], beams, self._params)
        return matched / len(beams)

    def _scan_disagrees(self, moved: np.ndarray, scan: Scan) -> bool:
        """True when the scan, seen from the odometry's prediction, fits the leading map much
        worse than the last update's scan did: the odometry missed a motion (wheels that slip
        or report late), so the filter must update before the travel thresholds say so."""
        m = self.config.matcher
        lead = int(np.argmax(self.log_weights))
        predicted = compose(self.poses[lead], moved)
        fit = self._fit(lead, predicted, self._matching_beams(scan, m.max_range, m.check_beams))
        return fit < self._last_fit - m.mismatch_drop

    def _odometry_error(self, predicted: np.ndarray, motion: np.ndarray, scan: Scan,
                        beams: np.ndarray) -> tuple[np.ndarray, bool]:
        """The odometry's error (robot frame), found on the leading particle's map, and whether
        the match it comes from fits well (at least ``good_match`` of the beams, and
        ``min_matched_beams``).

        The leading particle is matched finely from its prediction turned to a few
        headings, and keeps the likeliest; when too few beams match after a large
        reported motion that follows a forced update, starts that take part of it back are
        tried too (:meth:`_take_back`). When still
        too few beams match, a coarse correlative search, whose window widens with
        the odometry's rotation (its worst errors come with fast turns), gives a
        second start; its fine match wins if it is likelier and fits well. The
        result defines the error applied to every particle's prediction.
        """
        m = self.config.matcher
        maps = self.maps
        lead = int(np.argmax(self.log_weights))
        pred = predicted[lead]
        res = maps.resolution
        fine = self._kernel_maps(lead)
        step = m.lead_rotation_step
        headings = np.tile(pred, (2 * m.lead_rotations + 1, 1))
        headings[:, 2] += step * np.arange(-m.lead_rotations, m.lead_rotations + 1)
        best, best_ll, matched = self._likeliest(fine, headings, beams, pred)
        reported = relative(self.poses[lead], pred)
        if matched < m.good_match * len(beams) and self._after_forced:
            best, best_ll, matched = self._take_back(fine, lead, reported, beams, best, best_ll, matched)
        trusted = self._fits_well(matched, len(beams))
        turn = abs(motion[0]) + abs(motion[2])
        angular = m.coarse_angular + 0.5 * turn
        if trusted:
            return relative(pred, best), True
        points = beam_rows(scan, min(m.coarse_range, self.config.sensor.usable_range), m.coarse_beams)[:, :2]
        if len(points) == 0:
            return self._kept(relative(pred, best), False, angular), False
        self.stats.coarse_searches += 1
        linear_cells = m.coarse_linear_cells + int(0.25 * abs(motion[1]) / res)
        half = int(np.ceil(m.coarse_range / res)) + linear_cells + m.coarse_reach_cells
        cx, cy = np.floor((pred[:2] - maps.origin) / res).astype(int)
        field = likelihood_window(maps.tables[lead], maps.lo, maps.origin[0], maps.origin[1], res, cx, cy,
                                  half, self._params[P_OCCUPIED], m.coarse_sigma, m.coarse_reach_cells)
        wx, wy = maps.origin + (np.array([cx, cy]) - half) * res
        sx, sy, sth, _ = search(field, res, wx, wy, pred[0], pred[1], pred[2], points, angular,
                                m.coarse_angular_step, linear_cells, m.coarse_prior_linear,
                                m.coarse_prior_angular + 0.5 * turn)
        x, y, th, _, _, ll, fitting = match(*fine, sx, sy, sth, beams, self._params, m.iterations,
                                            m.wide_iterations)
        if ll > best_ll and self._fits_well(fitting, len(beams)):
            return relative(pred, np.array([x, y, th])), True
        return self._kept(relative(pred, best), False, angular), False

    @staticmethod
    def _kept(error: np.ndarray, trusted: bool, angular: float) -> np.ndarray:
        """The odometry's ``error`` as applied to every particle: a trusted one whole; one from a
        match that does not fit well only if it turns the robot within the coarse search's
        ``angular`` window. A poor match that turned the leading particle further (onto the wrong
        structure, where nothing fits) would otherwise turn every particle with it."""
        return error if trusted or abs(error[2]) <= angular else np.zeros(3)

    def _fits_well(self, matched: int, beams: int) -> bool:
        """Whether a match of the leading particle is good enough to measure the odometry's error."""
        m = self.config.matcher
        return matched >= max(m.good_match * beams, m.min_matched_beams)

    def _take_back(self, fine: tuple, lead: int, reported: np.ndarray, beams: np.ndarray,
                   best: np.ndarray, best_ll: float, matched: int):
        """Try starts that take back part of a large reported motion, right after a forced update.

        An odometry that stalls and then catches up reports, in one step, motion the scans
        showed during the stall, which the filter followed then (forced updates). Without a
        forced update before it, the motion is the odometry's to report: taking it back would
        only pull the scan towards where the map was seen from (its best overlap). The
        starts are the reported motion scaled by ``1 - k / steps``, the steps fine enough
        for the matcher to capture (``lead_rotation_step`` in heading, 5 cm in travel); the
        likeliest wins where the scan then fits well.
        """
        m = self.config.matcher
        turn_steps = int(np.ceil(abs(reported[2]) / m.lead_rotation_step))
        travel = np.hypot(reported[0], reported[1])
        if turn_steps <= m.lead_rotations and travel <= 2.0 * self.config.linear_update:
            return best, best_ll, matched
        steps = max(turn_steps, int(np.ceil(travel / TAKE_BACK_STEP)))
        self.stats.take_back_searches += 1
        scales = 1.0 - np.arange(1, steps + 1) / steps
        starts = compose(self.poses[lead], reported[None, :] * scales[:, None])
        return self._likeliest(fine, starts, beams, best, best_ll, matched, m.good_match * len(beams))

    def _likeliest(self, fine: tuple, starts: np.ndarray, beams: np.ndarray, best: np.ndarray,
                   best_ll: float = -np.inf, matched: int = 0,
                   min_matched: float = 0.0) -> tuple[np.ndarray, float, int]:
        """The likeliest fine match ``(pose, ll, matched)`` from the ``starts`` among those
        matching at least ``min_matched`` beams, or the given best if none is likelier."""
        m = self.config.matcher
        starts = np.ascontiguousarray(starts, dtype=np.float64)
        poses = np.empty((len(starts), 3))
        lls = np.empty(len(starts))
        counts = np.empty(len(starts), np.int64)
        match_starts(*fine, starts, beams, self._params, m.iterations, m.wide_iterations, poses, lls, counts)
        for pose, ll, n in zip(poses, lls, counts.tolist(), strict=True):
            if ll > best_ll and n >= min_matched:
                best, best_ll, matched = pose, float(ll), n
        return best, best_ll, matched

    def _matching_beams(self, scan: Scan, max_range: float, max_beams: int) -> np.ndarray:
        return beam_rows(scan, self.config.sensor.beam_reach(scan, max_range), max_beams)
