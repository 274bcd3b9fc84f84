"""The SLAM worker process: synchronised estimator steps, published state, map and checkpoints.

Each new scan is stepped once, with the odometry at its own stamp (:mod:`app.worker.pairing`),
read from the server's odometry ring (the worker never opens the serial port);
with ``settings.replay`` a CARMEN log takes the robot's place (:mod:`app.replay`). A mapping
filter has the loop-closing back end beside it (:mod:`app.worker.live_back_end`). After each
step a :class:`~app.worker.messages.WorkerState` (pose, its ``map -> odom`` correction, particle
cloud, scan) goes to the server on a small queue; the map goes into
shared memory at ``map_hz``, with per-tile change stamps (:mod:`app.worker.shared_map`), so
the map is never pickled.
"""

from __future__ import annotations

import contextlib
import logging
import math
import queue
import signal
import threading
import time
import traceback
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from app.core.config import Settings
from app.core.rate import SlidingRate
from app.grabbers.odometry_history import OdometryHistory
from app.grabbers.ring_odometry_grabber import RingOdometryGrabber
from app.grabbers.scan_grabber import ScanGrabber, load_sensor_source
from app.grabbers.shared import Backlog
from app.worker.checkpoint import load_checkpoint, save_exit_map, save_pose, save_snapshot
from app.worker.estimators import (
    Checkpoint,
    FrozenMap,
    ModeUnavailable,
    dead_reckons,
    laser_mount,
    make_estimator,
    map_with_hits,
    odometry_calibration,
    warm_up,
)
from app.worker.frames import map_to_odom
from app.worker.lifeline import bind_to_parent
from app.worker.lockfile import acquire_worker_lock
from app.worker.loop_closing import LoopClosing
from app.worker.map_limits import check_room, map_box, scan_reach
from app.worker.messages import (
    Command,
    ResumeSession,
    SaveSession,
    SetMapping,
    SetMode,
    SetPose,
    Shutdown,
    WorkerEvent,
    WorkerState,
    waiting_commands,
)
from app.worker.pairing import SCAN_BACKLOG, Pair, StampedPairing
from app.worker.relocalize import Relocalizer
from app.worker.relocalizing import Relocalizing
from app.worker.replay_driver import ReplayDriver
from app.worker.shared_map import MapTooLarge, SharedMap, grid_cells
from app.worker.startup_clock import StartupClock
from app.worker.warm_start import BackgroundWarmUp, PreviewMap
from slam_core.estimator import Estimate
from slam_core.geometry import compose, relative, transform_points
from slam_core.io.ros_map import load_map
from slam_core.occupancy_grid import OccupancyGrid, SensorModel
from slam_core.rbpf.config import RBPFConfig
from slam_core.rbpf.filter import RBPFSlam
from slam_core.session import MappingSession, load_session, save_session

log = logging.getLogger(__name__)

WAIT_S = 0.05
#: The pose (without the map) is checkpointed this often (s).
POSE_SAVE_S = 0.2
#: Keep this many poses of the trajectory drawn on the exit PNG.
TRAJECTORY_KEEP = 20000
#: A worker that has taken this many steps and published its map reports itself healthy.
HEALTHY_STEPS = 10


@dataclass
class WorkerSpec:
    """Everything the worker process needs (picklable)."""

    settings: dict
    shm_name: str
    restart: int = 0
    initial_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    parent_pid: int = 0  # the server; the worker ends when it dies
    #: The last worker's ``map -> odom`` correction: with the odometry, where a restarted worker
    #: first looks for the robot (the link kept the odometry going, and maybe the robot driving).
    map_to_odom: tuple[float, float, float] | None = None


def put_newest(q, item) -> None:
    """Non-blocking put that drops the item when the server is not keeping up."""
    with contextlib.suppress(queue.Full):
        q.put_nowait(item)


class Worker:
    """The loop run by :func:`worker_main` (a class so its parts stay small)."""

    def __init__(self, spec: WorkerSpec, commands, states, scan_slot, odometry_ring,
                 clock: StartupClock | None = None):
        self.settings = Settings(**spec.settings)
        self.clock = clock or StartupClock()  # until the first pose (an event then)
        self.spec = spec
        self.commands = commands
        self.states = states
        self.stop = threading.Event()
        s = self.settings
        self.shm = SharedMap(s.map_capacity_cells, s.tile_size, name=spec.shm_name)
        self.scans = Backlog(SCAN_BACKLOG)
        self.replay: ReplayDriver | None = None
        self.anchor: tuple[np.ndarray, np.ndarray] | None = None
        self.mount = laser_mount(s)  # the scan's points are drawn from the laser's pose
        if s.replay:
            self.replay = ReplayDriver(s, self.scans, odometry_ring)
            self.sources, self.pairing = [self.replay.feed], self.replay.pairing
            self.anchor = (np.zeros(3), np.zeros(3))  # the log's odometry frame is the map frame, as offline
            initial_pose = self.replay.start_odometry
            # a replay starts afresh and leaves the robot's checkpoints alone
            checkpoint, self.generation = None, 0
        else:
            history = OdometryHistory()
            odometry_grabber = RingOdometryGrabber(odometry_ring, history)
            if scan_slot is not None:
                scan_grabber = ScanGrabber(slot=scan_slot, output=self.scans)
            else:
                scan_grabber = ScanGrabber(source=load_sensor_source(s.sensor_source), output=self.scans)
            self.sources = [odometry_grabber, scan_grabber]
            self.pairing = StampedPairing(history, self.scans)
            initial_pose = spec.initial_pose
            restored = load_checkpoint(s.checkpoint_dir, s.map_capacity_cells)
            for path, reason in restored.quarantined:
                self._event("checkpoint_quarantined", path=str(path), detail=reason)
            checkpoint, self.generation = restored.checkpoint, restored.generation
        was_restored = checkpoint is not None
        self.mode = checkpoint.mode if checkpoint else s.mode
        self.mapping = checkpoint.mapping if checkpoint else True
        self.map_name = checkpoint.map_name if checkpoint else None
        self.pose = checkpoint.pose.copy() if checkpoint else np.array(initial_pose, float)
        checkpoint = checkpoint or Checkpoint(self.mode, self.pose.copy())
        self.odometry_errors = checkpoint.odometry_errors
        try:
            self.estimator = make_estimator(self.mode, s, checkpoint)
        except ModeUnavailable as exc:
            self._event("error", detail=str(exc))
            self.mode = "mapping"
            self.estimator = make_estimator("mapping", s, checkpoint)
        self.loops = LoopClosing()
        self.loops.attach(self.estimator, seeded=checkpoint.grid is not None,
                          prior=self._usable(checkpoint.session))
        self.updated_at: np.ndarray | None = None  # re-anchored odometry at the estimator's last update
        self.ticks: tuple[int, int] | None = None  # encoder counts of the last step
        self.odom_t: float | None = None  # the stamp of the last step's odometry
        self.steps = 0
        self.rate_hz = 0.0
        self._step_rate = SlidingRate()
        self.trajectory: list[np.ndarray] = []
        self.map_written = False
        # The map as last restored or handed over: estimators without a map of their own (EKF)
        # or without hit sums (MCL, frozen) are checkpointed with it, so a mode switch keeps it.
        self.kept_grid, self.kept_hits = checkpoint.grid, checkpoint.hit_sums
        self.map_changed = False  # since the last snapshot
        # A restored map: find the robot in it before anything is written (app.worker.relocalize).
        correction = None if spec.map_to_odom is None else np.array(spec.map_to_odom, float)
        self.relocalizing = self._relocalizing(correction) if was_restored else None
        self.warming: BackgroundWarmUp | None = None  # kernels compiling; meanwhile a preview (warm_start)
        self.preview: PreviewMap | None = None
        self.deferred: list[Command] = []  # commands that wait for the kernels

    def _usable(self, session: MappingSession | None) -> MappingSession | None:
        """A checkpoint's session, unless it was mapped at another resolution than the server's now."""
        if session is not None and abs(session.config.resolution - self.settings.resolution) > 1e-12:
            self._event("error", detail=f"the checkpoint's mapping session is at {session.config.resolution} "
                        f"m, the server maps at {self.settings.resolution} m: loops close from now on only")
            return None
        return session

    # messages to the server
    def _event(self, event: str, **fields) -> None:
        put_newest(self.states, WorkerEvent(event, time.time(), fields))

    def _publish_state(self, scan, estimate, odometry) -> None:
        """The estimate after a step with ``odometry`` (the raw reading it used, in the link's odom
        frame), and the ``map -> odom`` correction between the two (:mod:`app.worker.frames`)."""
        s = self.settings
        particles = estimate.particles
        weights = estimate.weights
        if particles is not None and len(particles) > s.max_particles_streamed:
            stride = math.ceil(len(particles) / s.max_particles_streamed)
            particles = particles[::stride]
            weights = weights[::stride] if weights is not None else None
        pose = np.asarray(estimate.pose, float)
        points = transform_points(self.mount.laser_poses(pose), scan.points()).astype(np.float32)
        put_newest(self.states, WorkerState(
            t=time.time(), seq=self.steps, pose=pose, localized=bool(estimate.localized),
            map_to_odom=map_to_odom(pose, odometry.pose), odom_stamp=float(odometry.stamp),
            mode=self.mode, mapping=self.mapping, steps=self.steps, rate_hz=self.rate_hz,
            relocalizing=self.relocalizing is not None,
            particles=None if particles is None else np.asarray(particles, np.float32),
            weights=None if weights is None else np.asarray(weights, np.float32),
            points=points, landmarks=estimate.landmarks, landmark_covariances=estimate.landmark_covariances,
            replay=self._replay_progress(), loops=self.loops.stats(), odometry=self._odometry_summary(),
        ))

    def _odometry_summary(self) -> dict | None:
        calibration = odometry_calibration(self.estimator)
        return None if calibration is None else calibration.summary()

    def _replay_progress(self) -> dict | None:
        return None if self.replay is None else self.replay.progress()

    # estimator management
    def _checkpoint(self, with_map: bool = True) -> Checkpoint:
        """What to resume from, in the published (map) frame: after a loop-closing solve, the
        optimised map with its hit sums and the corrected pose; with the map, the mapping session
        and the odometry errors measured."""
        grid = hits = session = errors = None
        if with_map:
            errors = self.odometry_errors  # the last estimator's, until this one has learned as much
            calibration = odometry_calibration(self.estimator)
            if calibration is not None:
                measured = calibration.measured()
                if len(measured.rows) and (errors is None or len(measured.rows) >= len(errors.rows)):
                    errors = measured
            session = self.loops.session(self.estimator, self.pose)
            if self.loops.solved is not None:
                grid, hits = self.loops.published_grid, self.loops.published_hits(session)
            else:
                grid, hits = map_with_hits(self.estimator)
                if grid is None or not grid.data.size:
                    grid, hits = self.kept_grid, self.kept_hits
                elif hits is None and self.kept_hits is not None and self.kept_hits.fits(grid):
                    hits = self.kept_hits
        return Checkpoint(self.mode, self.loops.map_pose(self.pose), grid, self.mapping, self.map_name,
                          self.ticks, hits, session, errors)

    def _save(self, with_map: bool) -> None:
        """A snapshot (map and pose) or just the pose; see :mod:`app.worker.checkpoint`."""
        directory = self.settings.checkpoint_dir
        if with_map:
            self.generation = save_snapshot(directory, self._checkpoint())
            self.map_changed = False
        else:
            save_pose(directory, self._checkpoint(with_map=False), self.generation)

    def _rebuild(self, mode: str, grid=None, pose=None, mapping=None, map_name=None, hit_sums=None) -> None:
        """Swap the estimator, keeping the map frame continuous (odometry re-anchored). With the
        back end's optimised map the new estimator goes on in it, and the mapping session so far
        is carried over (a new ``grid``, with its ``hit_sums`` if known, drops it)."""
        current = self._checkpoint()
        prior = current.session if grid is None else None
        checkpoint = Checkpoint(
            mode, current.pose if pose is None else np.asarray(pose, float),
            current.grid if grid is None else grid,
            current.mapping if mapping is None else mapping,
            map_name if map_name is not None else current.map_name,
            hit_sums=current.hit_sums if grid is None else hit_sums, odometry_errors=current.odometry_errors)
        estimator = make_estimator(mode, self.settings, checkpoint)  # ModeUnavailable: keep the old one
        self.estimator, self.mode, self.mapping = estimator, mode, checkpoint.mapping
        self.odometry_errors = checkpoint.odometry_errors
        self.pose, self.map_name = checkpoint.pose, checkpoint.map_name
        self.kept_grid, self.kept_hits = checkpoint.grid, checkpoint.hit_sums
        self.map_changed = True
        seeded = checkpoint.grid is not None and checkpoint.grid.data.size > 0  # a new map is empty
        self.loops.attach(self.estimator, seeded=seeded, prior=prior)
        self.anchor = None
        self.updated_at = None
        self.map_written = False

    def _handle(self, command: Command) -> None:
        if isinstance(command, Shutdown):
            self.stop.set()
            return
        try:
            if isinstance(command, SetMode):
                grid = load_map(command.yaml_path) if command.yaml_path else None
                if command.new_map:
                    grid = OccupancyGrid(self.settings.resolution)  # empty: mapping starts afresh
                # A new map is no saved map's ("" rather than None, which would keep the old name).
                name = "" if command.new_map else command.map_name
                self._rebuild(command.mode, grid=grid, mapping=True, map_name=name)
                # Back to mapping: register the scans before drawing them (other modes need no map
                # or, on a loaded map, localize by themselves).
                self._start_relocalizing(command.mode == "mapping" and not command.new_map)
            elif isinstance(command, SetPose):
                pose = np.array([command.x, command.y, command.yaw], float)
                self._check_room(pose, SensorModel().usable_range)
                if self.relocalizing is not None:  # the person's pose becomes the search's guess
                    self.pose = pose
                    self.relocalizing.restart()
                else:
                    self._rebuild(self.mode, pose=pose)
            elif isinstance(command, SetMapping):
                self._rebuild("mapping", mapping=command.enabled)
                self._start_relocalizing(command.enabled)
            elif isinstance(command, SaveSession):
                self._save_session(Path(command.path))
            elif isinstance(command, ResumeSession):
                self._resume_session(load_session(Path(command.path)))
            self._event("changed", mode=self.mode, mapping=self.mapping, map_name=self.map_name or None)
        except (ModeUnavailable, ValueError, OSError) as exc:
            self._event("error", detail=f"{type(command).__name__}: {exc}")

    def _save_session(self, path: Path) -> None:
        session = self.loops.session(self.estimator, self.pose)
        if session is None:
            raise ValueError("no mapping session to save: the loop-closing back end runs from a new map "
                             "or a resumed session on")
        save_session(session, path)
        self._event("session_saved", name=path.name, updates=len(session.scans))

    def _resume_session(self, session: MappingSession) -> None:
        """Map on in a saved session's map: find the robot in it first (its end pose is the guess)."""
        if abs(session.config.resolution - self.settings.resolution) > 1e-12:
            raise ValueError(f"the session's resolution {session.config.resolution} m is not the server's "
                             f"{self.settings.resolution} m")
        grid = session.grid()
        self._rebuild("mapping", grid=grid, pose=session.end_pose, mapping=True,
                      hit_sums=session.hit_sums(grid))
        self.loops.attach(self.estimator, seeded=True, prior=session)
        self._start_relocalizing()
        self._event("session_resumed", updates=len(session.scans))

    def _check_room(self, pose, reach: float) -> None:
        """:class:`MapTooLarge` if a scan from ``pose`` would grow the map past its limit."""
        s = self.settings
        check_room(map_box(self.estimator, self.kept_grid), pose, reach, s.resolution, s.map_capacity_cells)

    def _room_to_map(self, pose, scan) -> bool:
        """Whether mapping may go on at ``pose``; at the map's limit mapping pauses, with an error event."""
        if not isinstance(self.estimator, RBPFSlam):
            return True
        try:
            self._check_room(pose, scan_reach(scan, self.estimator.maps.model))
            return True
        except MapTooLarge as exc:
            self._event("error", detail=f"mapping paused: {exc}")
            self._rebuild("mapping", mapping=False)
            return False

    def _start_relocalizing(self, needed: bool = True) -> None:
        """Find the robot in the current map before the next scan is drawn (or stop looking)."""
        self.relocalizing = self._relocalizing() if needed else None

    def _relocalizing(self, correction: np.ndarray | None = None) -> Relocalizing | None:
        current = self._checkpoint()
        if current.grid is None or not current.grid.data.size:
            return None
        config = RBPFConfig(resolution=current.grid.resolution)
        return Relocalizing(Relocalizer(current.grid, current.hit_sums, config, self.mount), correction)

    def _relocalize(self, reading, scan) -> bool:
        """Look for the robot in the restored map; until found, publish the guess and map nothing
        (:mod:`app.worker.relocalizing`). Once found, the estimator is rebuilt at the pose found, so
        mapping continues the same map, in register."""
        fix, guess = self.relocalizing.locate(reading.pose, scan, self.pose)
        if fix is None:
            self.pose = guess
            self._publish_state(scan, Estimate(pose=guess, localized=False), reading)
            return False
        self.relocalizing = None
        self._rebuild(self.mode, pose=fix.pose)
        self._event("relocalized", search=fix.search, fit=round(fix.fit, 3),
                    pose=[round(float(v), 4) for v in fix.pose])
        return True

    def _drain_commands(self) -> None:
        for command in waiting_commands(self.commands):
            if self.warming is not None and not isinstance(command, Shutdown):
                self.deferred.append(command)  # they would rebuild the estimator under the preview
            else:
                self._handle(command)

    # start-up
    def _start_warm_up(self) -> None:
        """Compile (or load) the kernels: in the background with a preview meanwhile
        (:mod:`app.worker.warm_start`), except for a replay, whose feed waits for every step."""
        s = self.settings

        def progress(done, total, stage):
            self._event("warming", done=done, total=total, stage=stage)

        mode = "mapping" if isinstance(self.estimator, RBPFSlam) else self.mode
        if self.replay is not None:
            warm_up(s, progress, mode)
            return
        if mode == "mapping" and self.relocalizing is None:
            self.preview = PreviewMap(s.resolution, self.estimator.mount, s.map_capacity_cells)
        self.warming = BackgroundWarmUp(s, mode, progress)

    def _warmed(self) -> None:
        """The kernels are ready: the filter catches up on the preview's scans, deferred commands run."""
        self.warming = None
        preview, self.preview = self.preview, None
        for pair in preview.pairs if preview is not None else ():
            self._step(pair, publish=False)
        self._event("started", restart=self.spec.restart, mode=self.mode, map_name=self.map_name or None)
        commands, self.deferred = self.deferred, []
        for command in commands:
            self._handle(command)

    def _preview_step(self, pair: Pair) -> None:
        """While the kernels compile: publish the odometry's pose (not localized) and draw the preview."""
        if self.clock is not None:
            self.clock.mark("first scan")
        self.pose = self._anchored(pair.odometry.pose)  # not checkpointed: the filter has not started
        if self.preview is not None:
            self.preview.add(pair, self.pose)
        self._publish_state(pair.scan, Estimate(pose=self.pose.copy(), localized=False), pair.odometry)
        self._startup_done()

    def _anchored(self, odometry) -> np.ndarray:
        """The odometry in the map frame: re-anchored at the pose the worker (re)started from."""
        if self.anchor is None:
            self.anchor = (np.asarray(odometry, float).copy(), self.pose.copy())
        odo0, pose0 = self.anchor
        return compose(pose0, relative(odo0, odometry))

    # the loop
    def run(self) -> None:
        s = self.settings
        self.clock.mark("checkpoint, estimator, relocalizer")
        self._start_warm_up()
        self.clock.mark("kernels needed first")
        for source in self.sources:
            source.start()
        if self.warming is None:
            self._event("started", restart=self.spec.restart, mode=self.mode, map_name=self.map_name or None)
        reported_healthy = False
        next_map = next_checkpoint = next_pose_save = time.monotonic()
        try:
            while not self.stop.is_set():
                self._drain_commands()
                if self.warming is not None and self.warming.done():
                    self._warmed()
                pair = self.pairing.next(WAIT_S)
                if pair is not None and self.warming is not None:
                    self._preview_step(pair)
                elif pair is not None:
                    self._step(pair)
                    if self.replay is not None:
                        self.replay.taken(pair.scan_seq)  # stepped or skipped, the feed goes on
                self._take_back_end()
                if self.replay is not None and self.replay.played_all():
                    self._finish_replay()
                now = time.monotonic()
                if now >= next_map:
                    self._publish_map()
                    next_map = now + 1.0 / s.map_hz
                if self.replay is not None:
                    continue  # a replay keeps no checkpoint
                if now >= next_checkpoint and self.map_changed:
                    self._save(with_map=True)
                    next_checkpoint = next_pose_save = now + s.checkpoint_s
                elif now >= next_pose_save and self.ticks is not None:
                    self._save(with_map=False)
                    next_pose_save = now + POSE_SAVE_S
                if not reported_healthy and self.steps >= HEALTHY_STEPS and self.map_written:
                    self._event("healthy")  # the checkpoint it resumed from does not make it crash
                    reported_healthy = True
        finally:
            self._exit()

    def _step(self, pair: Pair, publish: bool = True) -> None:
        reading, scan = pair.odometry, pair.scan
        odometry = reading.pose
        self.ticks = reading.ticks
        self.odom_t = float(reading.stamp)
        relocalizing = self.relocalizing is not None
        if self.clock is not None:
            self.clock.mark("first scan")
        if relocalizing and not self._relocalize(reading, scan):
            self._startup_done()
            return
        if relocalizing and self.clock is not None:
            self.clock.mark("relocalization")
        odometry = self._anchored(odometry)
        if not self._room_to_map(odometry, scan):
            return
        updated = self.estimator.step(odometry, scan)
        if updated or self.updated_at is None:
            self.updated_at = odometry
            self.map_changed = True
        if updated:
            self.loops.updated(self.estimator, scan)
        if self.replay is not None:
            self.replay.stepped(pair.scan_seq, updated, self.estimator.stats.updates - 1)
        estimate = self.estimator.estimate()
        if not dead_reckons(self.estimator):
            estimate = self._dead_reckoned(estimate, relative(self.updated_at, odometry))
        self.pose = np.asarray(estimate.pose, float)
        self.steps += 1
        now = time.monotonic()
        self._step_rate.tick(now)
        self.rate_hz = self._step_rate.rate(now)
        self.trajectory.append(self.pose.copy())
        del self.trajectory[:-TRAJECTORY_KEEP]
        if publish:
            self._publish_state(scan, self.loops.corrected(estimate), reading)
            self._startup_done()

    def _startup_done(self) -> None:
        """After the first published pose: where the start-up's time went (an event)."""
        if self.clock is not None:
            self.clock.mark("first pose")
            self._event("startup", stages=self.clock.stages())
            self.clock = None

    def _take_back_end(self) -> None:
        """Use a finished solve (:class:`~app.worker.loop_closing.LoopClosing`); one that closed a
        loop is an event with the published pose's jump (at the last step's odometry, ``odom_t``),
        one that failed an error event."""
        failure = self.loops.failure()
        if failure is not None:
            self._event("error", detail=f"loop closing failed ({failure}); the next submap solves again")
        jump = self.loops.take(self.estimator, self.pose)
        if jump is not None:
            self._event("loop_closed", closures=self.loops.closures, loop_edges=self.loops.solved.loop_edges,
                        seq=self.steps, odom_t=self.odom_t, jump=[round(float(v), 4) for v in jump])

    def _finish_replay(self) -> None:
        """The final optimisation: publish and write the optimised map and trajectory; mapping stops."""
        recording = self.replay.recording
        recording.phase = "optimising"
        self._event("replay_optimising", replay=self._replay_progress())
        self.loops.wait()
        if not isinstance(self.estimator, RBPFSlam):  # mapping paused: the map outgrew its limit
            recording.phase = "failed"
            self._event("replay_finished", replay=self._replay_progress(), loop_edges=0, paths=[])
            return
        self.loops.attach(self.estimator, seeded=True)  # the live back end's maps go before the final solve
        result = recording.finish(self.estimator)
        self.pose = result.poses[-1].copy()
        self.estimator, self.mapping = FrozenMap(result.grid, self.pose), False
        self.map_written = False
        self._publish_map()
        last = self.replay.records[-1]
        self._publish_state(last.scan, self.estimator.estimate(), self.replay.last_odometry())
        self._event("replay_finished", replay=self._replay_progress(), loop_edges=result.loop_edges,
                    paths=[str(p) for p in result.paths])

    @staticmethod
    def _dead_reckoned(estimate: Estimate, motion: np.ndarray) -> Estimate:
        """The estimate moved on by the odometry since the estimator's last update.

        Filters update only every so many centimetres; between updates the published
        pose and particles follow the odometry so the stream and the controller stay live.
        """
        if not np.any(motion):
            return estimate
        particles = estimate.particles
        if particles is not None:
            particles = np.array([compose(p, motion) for p in particles])
        return replace(estimate, pose=compose(estimate.pose, motion), particles=particles)

    def _published_map(self) -> OccupancyGrid | None:
        if self.preview is not None:
            return self.preview.grid
        return self.loops.published_map(self.estimator)

    def _publish_map(self) -> None:
        grid = self._published_map()
        if grid is None or not grid.data.size:
            return
        self.shm.publish(grid_cells(grid), grid.origin, grid.resolution, force_full=not self.map_written)
        self.map_written = True

    def _exit(self) -> None:
        """Save the last map (PGM + YAML + PNG) and a final checkpoint; stop the grabbers."""
        s = self.settings
        grid = self.loops.published_grid if self.loops.published_grid is not None else self._checkpoint().grid
        if grid is not None and grid.data.size:
            if self.replay is None:
                self._save(with_map=True)
            paths = save_exit_map(grid, s.last_map_stem, np.array(self.trajectory).reshape(-1, 3))
            self._event("saved", paths=[str(p) for p in paths])
        for source in self.sources:
            source.stop()
        self.shm.close()


def worker_main(spec: WorkerSpec, commands, states, scan_slot, odometry_ring) -> None:
    """Process entry point: SIGINT/SIGTERM stop the loop, which then saves the map."""
    logging.basicConfig(level=logging.WARNING)
    worker = None

    def _stop(signum, frame):
        if worker is not None:
            worker.stop.set()

    signal.signal(signal.SIGTERM, _stop)
    signal.signal(signal.SIGINT, _stop)
    clock = StartupClock()
    clock.mark("spawn and imports")
    bind_to_parent(spec.parent_pid)
    try:
        lock = acquire_worker_lock(Path(spec.settings["data_dir"]))
        if lock.ended_pid is not None:
            put_newest(states, WorkerEvent("ended_stale_worker", time.time(), {"pid": lock.ended_pid}))
        worker = Worker(spec, commands, states, scan_slot, odometry_ring, clock)
        worker.run()
    except Exception as exc:
        put_newest(states, WorkerEvent("crashed", time.time(), {"detail": f"{type(exc).__name__}: {exc}",
                                                                 "trace": traceback.format_exc()}))
        raise
