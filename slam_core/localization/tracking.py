"""Pose tracking between and on top of the particle filter's updates.

Cartographer's pure localization and slam_toolbox's localization mode publish a
pose that a scan matcher has pinned to the map; the particle filter alone
publishes the mean of a cloud that the motion noise keeps blurred. The tracker
does the former on every scan:

1. *predict*: the tracked pose moves with the odometry since the previous scan, corrected by the
   odometry's systematic errors (travel scale, heading drift per metre and per radian turned:
   :mod:`slam_core.odometry_calibration`) that the accepted matches fitting at least
   ``calibration_fit`` measured since the last one (a robot whose wheels over-report travel runs
   ahead along a corridor where the scan cannot pull it back). An odometry whose position
   freezes (a *stall*: steps shorter than ``stall_xy``) may not have seen the robot stop.
   While its heading is frozen too (turning less than ``stall_theta``), right after a step of
   at least ``stall_min_step`` the prediction goes on with that step, for up to ``stall_travel``
   metres; when the odometry reports nothing at all, a short step right after one at cruising
   speed is a stale reading, passed over. A robot may also stop within one scan (Intel's does):
   a bridged scan is matched from where the odometry puts it too, and the better fit wins (the
   odometry's on a tie). The step that ends a stall *catches
   up* when it is longer than ``catch_up`` times the odometry's mean step (its running mean
   over the steps that moved, rate ``speed_rate``; no robot doubles its speed within a scan):
   it holds all the motion since the stall began, which the matches have partly followed, so
   the prediction is the track's pose where the stall began moved by that motion;
   odometry read a little early or late (mit-csail's turns: 23 deg in one scan, 4 in the next)
   puts the prediction off the robot's own pace: after two accepted matches on consecutive scans,
   a scan whose paced pose (their step, scaled by the time since) lies more than ``pace_gap_xy``
   or ``pace_gap_theta`` from the prediction is matched from there too. Where the pace's matches
   have explained more of the scans than the odometry's, on this robot so far, the match that
   explains ``pace_gain`` more of the beams is taken, and between two that explain about as many
   the one whose beams lie closer to the walls (the smaller spread); elsewhere the odometry's is
   taken. Wheels read in step with the laser predict far better than the pace does (the stress
   logs, intel: a pace that wins on a single scan's fit puts intel's track off), mit-csail's worse;
2. *match*: :class:`ScanToMapMatcher` refines it against the map, held to the
   prediction by a prior whose spread grows with the odometry's motion since the
   last accepted match (a robot that stands still does not slide along a corridor), and
   for the first ``stall_scans`` scans of a stall with a frozen heading by the odometry's
   mean step (and mean turn) times the scans frozen so far (the track may lag by more than
   one: the reading before a freeze is often stale too): the scans, not the frozen odometry,
   tell whether the robot stopped;
3. *judge*: the match is accepted when the map explains at least ``min_fit`` of
   the beams (see :mod:`slam_core.localization.scan_to_map`) and ``keep_ratio``
   of the track's usual fit. Below that, or when the fit drops by
   ``search_on_drop``, a correlative search around the prediction (``search_xy``,
   ``search_theta``: odometry that stalled, then caught up) gets a chance; a scan
   that neither explains keeps the predicted pose, and after ``patience`` of them
   in a row the track is *lost* and the particle filter decides again;
4. *occlusion*: a scan the map explains only in part (``occluded_fit``) whose other
   beams end short of the map's walls, not beyond them (at most ``max_through`` see
   through a wall, see :meth:`ScanToMapMatcher.seen_through`), is people or furniture in
   front of the robot, not a wrong pose: a confirmed track keeps its predicted pose for
   up to ``occluded_travel`` metres of odometry without counting a miss (but says it is
   *occluded*: the pose is odometry's, not the map's).

The tracker is (re)started from a known start, from the particle filter's main
cluster once it has converged and matches well there, or from the best of the
filter's heaviest particles refined by the matcher. A track started from the
filter is *confirmed* only after ``confirm_travel`` metres of odometry and
``confirm_matches`` accepted matches during
which its usual fit stayed at least ``start_fit`` (it is dropped as soon as it
does not): in a look-alike corridor the filter can converge on the wrong one
while the robot barely moves. A track *resumed* where odometry puts a lost one
(:meth:`PoseTracker.try_resume`) needs, instead of ``start_fit``, the fit the lost track
usually had (where the map explains a scan at 0.6 at best, a track there never fits at 0.8).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam_core.geometry import compose, paced_pose, relative
from slam_core.localization.known_map import KnownMap
from slam_core.localization.scan_to_map import MatchResult, ScanToMapMatcher, prior_weights
from slam_core.motion_model import OdometryMotionModel, decompose
from slam_core.odometry_calibration import OdometryCalibration
from slam_core.scan import Scan


@dataclass(frozen=True)
class TrackingConfig:
    """When a match is good enough, how long a track survives bad ones, and which beams it uses."""

    #: Fraction of the beams the map must explain for a match to be accepted, and the fraction of
    #: the track's usual fit (a running mean, rate ``usual_rate``) it must keep: a robot carried
    #: elsewhere still fits a rectilinear home by half, but far worse than it used to.
    min_fit: float = 0.35
    keep_ratio: float = 0.6
    usual_rate: float = 0.1
    #: ... and for a track to start from a pose the particle filter proposes.
    start_fit: float = 0.8
    #: A switch of the track to the filter's pose farther than this (m) must confirm itself again
    #: (as far as the filter must disagree to be heard: the track was that wrong while confirmed).
    switch_xy: float = 0.3
    #: Odometry travel (m) a track started by the filter must survive before it is confirmed.
    confirm_travel: float = 3.0
    #: ... and this many accepted matches (a log with a scan per metre needs more than 3 of them).
    confirm_matches: int = 10
    #: Odometry stalls (see the module doc): steps shorter than ``stall_xy`` (m), their heading
    #: frozen when turning less than ``stall_theta`` (rad); bridged right after a step of
    #: ``stall_min_step`` (m) for up to ``stall_travel`` (m); the prior widens for the first
    #: ``stall_scans`` scans; the odometry's mean step is a running mean (rate ``speed_rate``), and
    #: a step ``catch_up`` times longer ends a stall by catching up; a step at least ``cruise`` times
    #: it is at cruising speed; a step moving less than ``still_xy`` (m) and turning less than
    #: ``still_theta`` (rad) reports nothing.
    stall_xy: float = 0.01
    stall_theta: float = 0.1
    stall_min_step: float = 0.05
    stall_travel: float = 1.0
    stall_scans: int = 10
    speed_rate: float = 0.2
    catch_up: float = 2.0
    cruise: float = 0.75
    still_xy: float = 0.001
    still_theta: float = 0.002
    #: The paced start (see the module doc): how far from the prediction (m, rad) it is matched too,
    #: and the fraction of the beams by which one match outweighs the other's spread where the pace
    #: is preferred: once it has been tried ``pace_samples`` times and its match's fit, less the
    #: odometry's, is positive on average (a running mean of rate ``pace_rate``).
    pace_gap_xy: float = 0.05
    pace_gap_theta: float = 0.035
    pace_gain: float = 0.05
    pace_rate: float = 0.02
    pace_samples: int = 20
    #: Rejected scans in a row after which the track is lost.
    patience: int = 5
    #: Occlusion: the least fit, the largest fraction of beams seen through a wall, and the odometry
    #: travel (m) since the last accepted match for which a confirmed track rides it out.
    occluded_fit: float = 0.15
    max_through: float = 0.1
    occluded_travel: float = 3.0
    #: Odometry calibration: accepted matches that fit at least this measure the odometry's error,
    #: the last ``calibration_window`` of them are fitted, and none is applied before
    #: ``calibration_min`` are known.
    calibration_fit: float = 0.7
    calibration_window: int = 200
    calibration_min: int = 50
    #: Beams matched per scan (evenly spaced over the valid ones) and the range cap (m).
    beams: int = 180
    max_range: float = 30.0
    #: The fallback search also runs when the fit drops by this much from the previous scan's.
    search_on_drop: float = 0.2
    #: ... and replaces the match only when it explains this much more of the scan, after both pay
    #: ``search_cost`` times their squared offset from the prediction in units of the half-widths
    #: (a pose farther from the prediction that fits just as well is no better evidence).
    search_gain: float = 0.05
    search_cost: float = 0.2
    #: Half-widths (m, rad) and heading step (rad) of the fallback search.
    search_xy: float = 0.3
    search_theta: float = np.radians(90.0)
    search_step: float = np.radians(1.5)
    #: Prior on the prediction: standard deviation at standstill (m, rad) and its growth per metre
    #: travelled and per radian turned (of the odometry as calibrated: its systematic errors are
    #: taken out, so 0.1 m a metre holds where uncalibrated wheels needed 0.2, benchmarks/RESULTS.md).
    prior_xy: float = 0.01
    prior_theta: float = 0.005
    prior_xy_per_m: float = 0.1
    prior_xy_per_rad: float = 0.05
    prior_theta_per_m: float = 0.1
    prior_theta_per_rad: float = 0.2

    def __post_init__(self):
        if not 0 < self.min_fit <= self.start_fit <= 1 or self.patience < 1 or self.beams < 3 \
                or self.max_range <= 0:
            raise ValueError(f"need 0 < min_fit <= start_fit <= 1, patience >= 1, beams >= 3, "
                             f"max_range > 0; got {self}")


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
        self.usual_fit: float | None = None  # running mean of the accepted fits
        self.misses = 0
        self.occluded = False
        self._odom: np.ndarray | None = None
        self._last_step: np.ndarray | None = None  # the last odometry step that moved (robot frame)
        self._cruising = False  # the last step that moved was at least cruise x the mean step
        # the step before the last one that moved, if that one was short right after cruising
        self._before_stale: np.ndarray | None = None
        self._speed = np.zeros(2)  # the odometry's mean step (m, rad) while it moves
        self._stalled = 0  # steps the odometry's position has been frozen for
        self._frozen = False  # the last step was frozen in heading too
        self._stall_start: tuple[np.ndarray, np.ndarray] | None = None  # the track and odometry then
        self._moved = np.zeros(2)  # odometry distance and turn since the last accepted match
        # the odometry's systematic error (its noise scales, which need a motion model, are not used)
        self.odometry = OdometryCalibration(OdometryMotionModel().alphas, self.config.calibration_window,
                                            self.config.calibration_min, 1.0)
        self._anchor: np.ndarray | None = None  # the pose of the last accepted match
        self._raw_since = np.zeros(3)  # and the odometry's motion since, uncorrected (stalls bridged)
        # in a bridged stall: the pose and the raw motion since the anchor as if the robot stopped
        self._unbridged: tuple[np.ndarray, np.ndarray] | None = None
        self._paced: list[tuple[np.ndarray, float]] = []  # the last two scans' accepted (pose, time)
        self._pace_advantage = 0.0  # the pace's match's fit less the odometry's, where both were tried
        self._pace_tries = 0
        self._unconfirmed_travel = 0.0  # odometry travel since an unconfirmed start
        self._unconfirmed_matches = 0  # and accepted matches
        self._confirm_fit = self.config.start_fit  # the usual fit an unconfirmed track must keep
        self.confirmed = False

    @property
    def tracking(self) -> bool:
        return self.pose is not None

    @property
    def unmatched_travel(self) -> float:
        """Odometry travel (m) since the last accepted match (or the start)."""
        return float(self._moved[0])

    def predict(self, odom: np.ndarray) -> None:
        """Move the tracked pose by the odometry since the previous call (see the module doc)."""
        odom = np.array(odom, dtype=np.float64)
        if self._odom is not None:
            raw = relative(self._odom, odom)
            caught_up = self._stall_start is not None and self._caught_up(raw)
            stalled = self._stall_step(raw)
            if self.pose is not None:
                previous, self._unbridged = self.pose, None
                if caught_up and not stalled:
                    start, start_odom = self._stall_start
                    moved = self.corrected(relative(start_odom, odom))
                    self.pose = compose(start, moved)
                    self._anchor = None  # the odometry's motion since the last match is not known
                else:
                    bridged = self._bridge(raw)
                    if bridged is not raw:
                        still = compose(self.pose, self.corrected(raw))
                        self._unbridged = still, compose(self._raw_since, raw)
                    self._raw_since = compose(self._raw_since, bridged)
                    moved = self.corrected(bridged)
                    self.pose = compose(self.pose, moved)
                self._moved += (np.hypot(moved[0], moved[1]), abs(moved[2]))
                if not self.confirmed:
                    self._unconfirmed_travel += float(np.hypot(*(self.pose[:2] - previous[:2])))
                    self.confirmed = (self._unconfirmed_travel >= self.config.confirm_travel
                                      and self._unconfirmed_matches >= self.config.confirm_matches)
            if not stalled:
                self._stall_start = None
        self._odom = odom

    def corrected(self, step: np.ndarray) -> np.ndarray:
        """An odometry ``step`` (robot frame) with the odometry's systematic errors taken out."""
        return self.odometry.corrected_step(step)

    def _stall_step(self, step: np.ndarray) -> bool:
        """Whether the odometry's ``step`` is frozen; counts the stall, and where it began."""
        cfg = self.config
        moved = float(np.hypot(step[0], step[1]))
        self._frozen = moved < cfg.stall_xy and abs(step[2]) < cfg.stall_theta
        if moved >= cfg.stall_xy:
            self._stalled = 0
            self._speed += cfg.speed_rate * (np.array([moved, abs(step[2])]) - self._speed)
            return False
        if self._stalled == 0 and self.pose is not None:
            self._stall_start = (self.pose.copy(), self._odom)
        self._stalled += 1
        return True

    def _stall_scans(self) -> int:
        """Scans the odometry has been frozen for, while that may be a stall (``stall_scans``), else 0."""
        return self._stalled if self._frozen and self._stalled <= self.config.stall_scans else 0

    @property
    def unseen_step(self) -> float:
        """How far (m) the robot may have moved since the previous scan unreported: in a stall's
        first ``stall_scans`` scans the odometry's mean step, else 0."""
        return float(self._speed[0]) if self._stall_scans() else 0.0

    def _caught_up(self, step: np.ndarray) -> bool:
        """Whether the step that ends a stall holds the motion the stall missed: longer than
        ``catch_up`` times the odometry's mean step (no robot doubles its speed within a scan)."""
        return float(np.hypot(step[0], step[1])) > self.config.catch_up * self._speed[0]

    def _bridge(self, step: np.ndarray) -> np.ndarray:
        """The odometry's step, or in a stall (heading frozen too) right after moving, the step before
        it. The reading just before a freeze is often stale too: while the odometry reports nothing
        at all (moving less than ``still_xy`` and turning less than ``still_theta``), a step shorter
        than ``stall_min_step`` right after one at cruising speed is passed over (a robot that stops
        slows down first, or creeps)."""
        cfg = self.config
        moved = float(np.hypot(step[0], step[1]))
        silent = moved < cfg.still_xy and abs(step[2]) < cfg.still_theta
        if not silent and moved < cfg.stall_xy:
            self._before_stale = None
        last = self._before_stale if silent and self._before_stale is not None else self._last_step
        speed = 0.0 if last is None else float(np.hypot(last[0], last[1]))
        if self._frozen and speed >= cfg.stall_min_step and self._stalled * speed <= cfg.stall_travel:
            return np.array([last[0], last[1], step[2]])
        if moved >= cfg.stall_xy:
            self._before_stale = self._last_step if moved < cfg.stall_min_step and self._cruising else None
            self._last_step = step
            self._cruising = moved >= max(cfg.stall_min_step, cfg.cruise * self._speed[0])
        return step

    def correct(self, points: np.ndarray, laser_xy=(0.0, 0.0),
                stamp: float | None = None) -> MatchResult | None:
        """Match the predicted pose against the map (endpoints in the robot frame, laser at
        ``laser_xy``, the scan taken at ``stamp`` seconds); returns the match (None without a track)."""
        if self.pose is None:
            return None
        cfg = self.config
        dist, turn = self._moved
        stall_xy, stall_theta = self._speed * self._stall_scans()
        prior = prior_weights(
            cfg.prior_xy + cfg.prior_xy_per_m * dist + cfg.prior_xy_per_rad * turn + stall_xy,
            cfg.prior_theta + cfg.prior_theta_per_m * dist + cfg.prior_theta_per_rad * turn + stall_theta)
        result = self.matcher.match(self.pose, points, prior)
        if self._unbridged is not None:  # a bridged stall: the robot may have stopped after all
            still_pose, still_since = self._unbridged
            still = self.matcher.match(still_pose, points, prior)
            if still.fit >= result.fit:
                result, self.pose, self._raw_since = still, still_pose, still_since
            self._unbridged = None
        elif stamp is not None and len(self._paced) == 2:
            result = self._paced_match(result, points, prior, stamp)
        usual = result.fit if self.usual_fit is None else self.usual_fit
        needed = max(cfg.min_fit, cfg.keep_ratio * usual)
        if result.fit < max(needed, usual - cfg.search_on_drop):
            wide = self.matcher.search(self.pose, points, cfg.search_xy, cfg.search_theta, cfg.search_step,
                                       prior, cfg.search_cost)
            if self._penalized(wide) >= self._penalized(result) + cfg.search_gain:
                result = wide
        self.fit = result.fit
        self.occluded = False
        if result.fit >= needed:
            self._calibrate(result)
            self.pose, self.misses = result.pose, 0
            self.usual_fit = usual + cfg.usual_rate * (result.fit - usual)
            self._moved[:] = 0.0
            self._unconfirmed_matches += 1
            self._paced = [] if stamp is None else [*self._paced[-1:], (self.pose, stamp)]
        elif self._occluded(result.fit, points, laser_xy):
            self.occluded = True
        else:
            self.misses += 1
        if result.fit < needed:
            self._paced = []
        if self.misses >= cfg.patience or (not self.confirmed and self.usual_fit < self._confirm_fit):
            self.lose()
        return result

    def _paced_match(self, result: MatchResult, points: np.ndarray, prior, stamp: float) -> MatchResult:
        """The match from the odometry's start (``result``) or from the robot's pace, whichever wins
        (see the module doc)."""
        cfg = self.config
        (before, t_before), (last, t_last) = self._paced
        paced = paced_pose(before, last, t_before, t_last, stamp)
        if paced is None:
            return result
        gap = relative(self.pose, paced)
        if np.hypot(gap[0], gap[1]) <= cfg.pace_gap_xy and abs(gap[2]) <= cfg.pace_gap_theta:
            return result
        other = self.matcher.match(paced, points, prior)
        self._pace_tries += 1
        self._pace_advantage += max(cfg.pace_rate, 1.0 / self._pace_tries) * (
            other.fit - result.fit - self._pace_advantage)
        preferred = self._pace_tries >= cfg.pace_samples and self._pace_advantage > 0.0
        if preferred and (result.fit < other.fit - cfg.pace_gain or (
                result.fit < other.fit + cfg.pace_gain and other.spread <= result.spread)):
            self.pose = paced
            return other
        return result

    def _calibrate(self, result: MatchResult) -> None:
        """Record the odometry's error since the last accepted match, if this one fits well."""
        moved = np.array(decompose(0.0, 0.0, 0.0, *self._raw_since))
        if self._anchor is not None and result.fit >= self.config.calibration_fit and abs(moved[1]) > 0.02:
            self.odometry.observe(moved, relative(compose(self._anchor, self._raw_since), result.pose))
        self._anchor, self._raw_since = result.pose, np.zeros(3)

    def _penalized(self, result: MatchResult) -> float:
        """A match's fit less the fallback search's cost of its offset from the prediction."""
        cfg = self.config
        off = relative(self.pose, result.pose)
        return result.fit - cfg.search_cost * ((np.hypot(off[0], off[1]) / cfg.search_xy) ** 2
                                               + (off[2] / cfg.search_theta) ** 2)

    def _occluded(self, fit: float, points: np.ndarray, laser_xy) -> bool:
        """Whether a scan that does not fit is occluded at the predicted pose (see the module doc)."""
        cfg = self.config
        return (self.confirmed and fit >= cfg.occluded_fit and self._moved[0] <= cfg.occluded_travel
                and self.matcher.seen_through(self.pose, points, laser_xy) <= cfg.max_through)

    def try_start(self, pose, points: np.ndarray) -> bool:
        """Start the track at ``pose`` refined by a match, if the map explains the scan well there
        (``start_fit``)."""
        return self._start_if(pose, points, self.config.start_fit, confirmed=False)

    def try_resume(self, pose, points: np.ndarray, fit: float) -> bool:
        """Start the track at ``pose`` (where odometry puts a lost track) refined by a match, if the map
        explains the scan there as well as ``fit`` (the lost track's usual fit, at most ``start_fit``,
        at least ``min_fit``); it confirms itself keeping that fit."""
        fit = min(max(fit, self.config.min_fit), self.config.start_fit)
        return self._start_if(pose, points, fit, confirmed=False, confirm_fit=fit)

    def try_switch(self, pose, points: np.ndarray, margin: float = 0.0) -> bool:
        """Move the track to ``pose`` refined by a match, if the scan fits there well or as well as
        here (with a ``margin``: that much better than here), and as well as the track needs (a
        scan the map explains badly everywhere moves nothing). A correction within ``switch_xy``
        keeps the track confirmed if it was; a longer one is a new start that must confirm itself."""
        cfg = self.config
        floor = max(cfg.min_fit, cfg.keep_ratio * (self.usual_fit or 0.0))
        needed = max(self.fit + margin, floor) if margin > 0.0 else max(min(cfg.start_fit, self.fit), floor)
        near = float(np.hypot(*(np.asarray(pose[:2]) - self.pose[:2]))) <= cfg.switch_xy
        return self._start_if(pose, points, needed, self.confirmed and near)

    def _start_if(self, pose, points: np.ndarray, min_fit: float, confirmed: bool,
                  confirm_fit: float | None = None) -> bool:
        result = self.matcher.match(pose, points)
        if result.fit < min_fit:
            return False
        self._confirm_fit = self.config.start_fit if confirm_fit is None else confirm_fit
        usual = self.usual_fit if confirmed and self.confirmed and self.usual_fit is not None else result.fit
        if self._stall_start is not None and self.pose is not None:  # moved where the stall began too
            start, start_odom = self._stall_start
            self._stall_start = (compose(result.pose, relative(self.pose, start)), start_odom)
        self.pose, self.fit, self.usual_fit, self.misses = result.pose, result.fit, usual, 0
        self._unbridged = None
        self._paced = []
        self._anchor, self._raw_since = result.pose, np.zeros(3)
        self.occluded = False
        self._moved[:] = 0.0
        self._unconfirmed_travel = 0.0
        self._unconfirmed_matches = 0
        self.confirmed = confirmed
        return True

    def start(self, pose) -> None:
        """Track from ``pose`` as given (a known start)."""
        self.pose = np.array(pose, dtype=np.float64)
        self._unbridged = None
        self._paced = []
        self.usual_fit = None
        self.misses = 0
        self.occluded = False
        self._anchor = None
        self._stall_start = None
        self._moved[:] = 0.0
        self.confirmed = True

    def lose(self) -> None:
        self.pose = None
        self._unbridged = None
        self._paced = []
        self._anchor = None
        self._stall_start = None
        self.misses = 0
        self.occluded = False
        self.confirmed = False
