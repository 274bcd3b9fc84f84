"""The one place estimators are built: ``make_estimator(mode, settings, checkpoint)``.

Every estimator follows :class:`slam_core.estimator.Estimator`. The worker feeds them
odometry re-anchored so that the first reading after a (re)start equals the
checkpoint pose; the map frame is therefore continuous across worker restarts.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from app.worker.relocalize import Relocalizer
from slam_core.datasets import resolve_log
from slam_core.estimator import Estimate
from slam_core.io.carmen import laser_mount_of
from slam_core.localization.mcl import MclConfig, MonteCarloLocalizer
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.odometry_calibration import MeasuredErrors, OdometryCalibration
from slam_core.rbpf.config import RBPFConfig
from slam_core.rbpf.filter import RBPFSlam
from slam_core.rbpf.hit_render import SparseHits
from slam_core.rbpf.laser_mount import LaserMount
from slam_core.robot_config import RobotConfig
from slam_core.scan import Scan
from slam_core.session import MappingSession


class ModeUnavailable(RuntimeError):
    """The estimator for that mode cannot be built (missing map, not installed)."""


@dataclass
class Checkpoint:
    """What a restarted worker resumes from: the last map, pose and mode (in the published map
    frame), and the mapping session the loop-closing back end goes on from."""

    mode: str
    pose: np.ndarray
    grid: OccupancyGrid | None = None
    mapping: bool = True
    map_name: str | None = None
    ticks: tuple[int, int] | None = None  # the MCU's cumulative encoder counts at ``pose``
    hit_sums: SparseHits | None = None  # per-cell beam endpoint sums of ``grid`` (RBPF maps)
    session: MappingSession | None = None
    odometry_errors: MeasuredErrors | None = None  # what the estimator learned of the odometry


class FrozenMap:
    """Mapping stopped: the map stays as it is and the pose follows the (re-anchored) odometry."""

    def __init__(self, grid: OccupancyGrid | None, pose: np.ndarray):
        self.grid = grid
        self.pose = np.asarray(pose, float)

    def step(self, odometry: np.ndarray, scan: Scan) -> bool:
        self.pose = np.asarray(odometry, float)
        return True

    def estimate(self) -> Estimate:
        return Estimate(pose=self.pose.copy(), localized=False)

    def occupancy_map(self) -> OccupancyGrid | None:
        return self.grid


def laser_mount(settings) -> LaserMount:
    """Where the laser sits on the robot: a replayed log's own mount (from its laser and odometry
    poses) when it records one, else the robot description's."""
    logged = laser_mount_of(resolve_log(settings.replay)) if settings.replay else None
    return settings.robot_config().laser.mount if logged is None else LaserMount.of(logged)


def effective_robot(settings) -> RobotConfig:
    """The robot the estimators work with: the robot file's, with a replayed log's own laser mount."""
    robot = settings.robot_config()
    return dataclasses.replace(robot, laser=dataclasses.replace(robot.laser, mount=laser_mount(settings)))


def _rbpf(settings, pose: np.ndarray, grid: OccupancyGrid | None, hit_sums: SparseHits | None) -> RBPFSlam:
    """The RBPF SLAM, resumed on the checkpoint's map when there is one."""
    config = settings.slam()
    slam = RBPFSlam(config, seed=settings.seed, initial_pose=pose, laser_mount=laser_mount(settings))
    if grid is not None and grid.data.size and abs(grid.resolution - settings.resolution) < 1e-12:
        slam.maps.seed_from_grid(grid, None if hit_sums is None else hit_sums.dense())
    return slam


def map_with_hits(estimator) -> tuple[OccupancyGrid | None, SparseHits | None]:
    """The estimator's map and, for the RBPF, its hit sums (None for estimators that keep none)."""
    if isinstance(estimator, RBPFSlam):
        best = estimator.best_index()
        grid = estimator.maps.to_grid(best)
        return grid, SparseHits.from_dense(estimator.maps.hit_sums(best), grid.origin)
    return estimator.occupancy_map(), None


def make_estimator(mode: str, settings, checkpoint: Checkpoint | None):
    """The estimator for ``mode``, resuming from ``checkpoint`` (map, pose and the odometry's errors
    measured so far) when given."""
    estimator = _estimator(mode, settings, checkpoint)
    calibration = odometry_calibration(estimator)
    if calibration is not None and checkpoint is not None and checkpoint.odometry_errors is not None:
        calibration.resume(checkpoint.odometry_errors)  # measured with another motion model: starts empty
    return estimator


def odometry_calibration(estimator) -> OdometryCalibration | None:
    """The estimator's calibration of the odometry: the filter's, or the localization tracker's."""
    if isinstance(estimator, RBPFSlam):
        return estimator.calibration
    if isinstance(estimator, MonteCarloLocalizer):
        return estimator.tracker.odometry
    return None


def _estimator(mode: str, settings, checkpoint: Checkpoint | None):
    grid = checkpoint.grid if checkpoint is not None else None
    pose = checkpoint.pose if checkpoint is not None else np.zeros(3)
    if checkpoint is not None and not checkpoint.mapping:
        return FrozenMap(grid, pose)
    if mode == "mapping":
        return _rbpf(settings, pose, grid, checkpoint.hit_sums if checkpoint is not None else None)
    if mode == "localization":
        if grid is None or not grid.data.size:
            raise ModeUnavailable("localization needs a map: load a saved map or map first")
        config = MclConfig(min_particles=settings.mcl_min_particles, max_particles=settings.mcl_max_particles,
                           laser_pose=laser_mount(settings).as_tuple())
        return MonteCarloLocalizer(grid, config, rng=np.random.default_rng(settings.seed), initial_pose=pose)
    if mode == "ekf":
        # Landmarks only: the map shown stays the last occupancy map; landmarks are streamed.
        from slam_core.ekf.ekf_slam import EkfConfig, EkfSlam  # scipy: imported when the mode is used

        return EkfSlam(EkfConfig(laser_offset=laser_mount(settings).as_tuple()), initial_pose=pose)
    raise ModeUnavailable(f"unknown mode {mode!r}")


def dead_reckons(estimator) -> bool:
    """Whether ``estimate()`` already follows the odometry between filter updates (everything but
    the particle filters, which update only every so many centimetres)."""
    return not isinstance(estimator, RBPFSlam | MonteCarloLocalizer)


def available_modes() -> tuple[str, ...]:
    """Modes this build can run (the server refuses the others with a reason)."""
    return ("mapping", "localization", "ekf")


WARM_UP_BEAMS = 90


#: What :func:`warm_up` prepares in mapping mode, in order (shown while it runs).
WARM_UP_STAGES = ("particle filter: first scan", "particle filter: update",
                  "particle filter: update without a match", "re-localization")


def warm_up(settings, progress=None, mode: str = "mapping") -> None:
    """Compile (or load from numba's cache) the kernels of ``mode`` before its first real step.

    A first update compiled lazily would stall the live loop for a long time on a
    fresh install; in mapping mode a two-particle filter on a synthetic round room does it
    up front (then an update with no echo, whose particles are drawn from the motion model
    alone), and a re-localization in its map compiles the searches a restart needs. The
    other modes (their filters compile on their first step) prepare only the re-localization,
    in a map drawn from the same scan. ``progress(done, total, stage)`` is called before each stage.
    """
    config = RBPFConfig(particles=2, resolution=settings.resolution, linear_update=0.01, angular_update=0.01)
    angles = np.linspace(-np.pi, np.pi, WARM_UP_BEAMS, endpoint=False)
    scan = Scan(angles, np.full(WARM_UP_BEAMS, 2.0), 0.1, 8.0)
    guess = np.array([0.3, 0.0, 0.0])
    if mode == "mapping":
        slam = RBPFSlam(config, seed=0)
        no_echo = Scan(angles, np.full(WARM_UP_BEAMS, scan.range_max), scan.range_min, scan.range_max)
        stages = (lambda: slam.step(np.zeros(3), scan), lambda: slam.step(np.array([0.05, 0.0, 0.02]), scan),
                  lambda: slam.step(np.array([0.1, 0.0, 0.04]), no_echo),
                  lambda: Relocalizer(*map_with_hits(slam), config).locate(scan, guess))
        names = WARM_UP_STAGES
    else:
        def relocalize() -> None:
            grid = OccupancyGrid(settings.resolution)
            grid.integrate(scan, np.zeros(3))
            Relocalizer(grid, None, config).locate(scan, guess)

        stages, names = (relocalize,), WARM_UP_STAGES[-1:]
    for done, (name, stage) in enumerate(zip(names, stages, strict=True)):
        if progress is not None:
            progress(done, len(names), name)
        stage()
