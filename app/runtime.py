"""The running robot as the server sees it: simulator, robot link, worker, navigator, stream pumps, storage.

Built in the app's lifespan. Everything that takes time (the worker's steps, map
encoding, planning, image files, serial I/O) happens off the event loop: in the worker
process or in threads. The pose is the worker's ``map -> odom`` correction composed with
the robot link's newest odometry (:mod:`app.worker.frames`).
"""

from __future__ import annotations

import asyncio
import contextlib
import gc
import logging
import os
import signal
import time
from collections import deque
from collections.abc import Callable

import numpy as np

from app.core.config import Settings
from app.core.rate import SlidingRate
from app.db.rooms import LIVE, RoomStore
from app.db.store import Store
from app.db.zones import ZoneStore
from app.navigation.navigator import Navigator
from app.robot.odometry_ring import OdometryRing
from app.robot.simulator import SimHandles, start_simulator, wait_ready
from app.robot_link.link import RobotLink
from app.rooms.service import RoomService
from app.streaming import map_frames
from app.streaming.hub import Hub
from app.worker.frames import pose_in_map
from app.worker.messages import ResumeSession, WorkerMessage, WorkerState
from app.worker.shared_map import MapSnapshot
from app.worker.supervisor import WorkerSupervisor
from app.zones.service import ZoneService
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.sim.world import load_world

log = logging.getLogger(__name__)

EVENTS_KEPT = 50
#: The simulated robot's serial device, a symlink to its pty in the data dir.
SIM_SERIAL_LINK = "robot.tty"
SCAN_DECIMALS = 2
POSE_DECIMALS = 4


def _rounded(array, decimals: int):
    return None if array is None else np.round(np.asarray(array, float), decimals).tolist()


def _pose_fields(pose) -> dict:
    return dict(zip(("x", "y", "yaw"), (round(float(v), POSE_DECIMALS) for v in pose), strict=True))


def _terminate_self() -> None:
    os.kill(os.getpid(), signal.SIGTERM)  # uvicorn shuts down gracefully


class Runtime:
    """Owns the robot pipeline for one server run."""

    def __init__(self, settings: Settings, token: str, stop_server: Callable[[], None] | None = None):
        self.settings = settings
        self.token = token
        self.stop_server = stop_server or _terminate_self
        settings.data_dir.mkdir(parents=True, exist_ok=True)
        settings.maps_dir.mkdir(parents=True, exist_ok=True)
        self.store = Store(settings.db_path)
        self.hub = Hub(self.full_map_frame, settings.client_send_timeout_s)
        tour = load_world(settings.world).tour if settings.simulation else None
        self.navigator = Navigator(settings, self.current_grid, self.current_pose, self.send_velocity, tour,
                                   touring=settings.sim_tour)
        self.rooms = RoomService(self.current_grid, self.map_cells, RoomStore(settings.db_path))
        self.zones = ZoneService(ZoneStore(settings.db_path))
        self.navigator.restrictions = self.zones.restrictions
        self.sim: SimHandles | None = None
        self.supervisor: WorkerSupervisor | None = None
        self.odometry_ring = OdometryRing.create()  # written by the robot link (or a replay's feed)
        self.link: RobotLink | None = None  # the serial port; none while a log is replayed
        self.latest: WorkerState | None = None
        self.mode = settings.mode
        self.mapping = True
        self.replay: dict | None = None  # the worker's replay progress (see app.replay.recording)
        self.events: deque[dict] = deque(maxlen=EVENTS_KEPT)
        self.map_snapshot: MapSnapshot | None = None
        self._full_cache: tuple[int, bytes] | None = None
        self._grid_cache: tuple[int, OccupancyGrid] | None = None
        self._last_stream = 0.0
        self._published_states = 0
        self._state_rate = SlidingRate()
        self._tasks: list[asyncio.Task] = []
        self._loop: asyncio.AbstractEventLoop | None = None
        self.started_at = time.time()
        self.preparing: dict | None = None  # the worker's warm-up stage while it prepares its kernels

    # lifecycle
    async def start(self) -> None:
        self._loop = asyncio.get_running_loop()
        s = self.settings
        start = (0.0, 0.0, 0.0)
        ready = None
        if s.simulation:
            self.sim, ready = start_simulator(s.world, s.seed, s.data_dir / SIM_SERIAL_LINK, s.robot_config())
            port, slot = self.sim.port, self.sim.scans
            start = load_world(s.world).start  # map frame = world frame in simulation
        else:
            port, slot = s.serial_port, None
        self.supervisor = WorkerSupervisor(s, self.odometry_ring, slot, self._from_relay, start,
                                           self._correction)
        self.supervisor.start()
        if s.resume_session is not None:  # `homebot serve --resume NAME` (checked before the start)
            self.supervisor.send(ResumeSession(str(s.session_file(s.resume_session))))
        if ready is not None:
            await asyncio.to_thread(wait_ready, self.sim, ready)  # the simulated robot's pty exists now
        if not s.replay:
            self.link = RobotLink(port, self.odometry_ring, s.serial_baud, s.robot_config()).start()
        for coro in (self._stream_ticker(), self._map_pump(), self._status_ticker(), self.navigator.run(),
                     self.rooms.run()):
            self._tasks.append(asyncio.create_task(coro))

    async def stop(self) -> None:
        for task in self._tasks:
            task.cancel()
        for task in self._tasks:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
        await self.hub.close_all()
        with contextlib.suppress(Exception):
            self.navigator.cancel()
        if self.link is not None:
            await asyncio.to_thread(self.link.stop)
        if self.supervisor is not None:
            await asyncio.to_thread(self.supervisor.stop)
        if self.sim is not None:
            await asyncio.to_thread(self.sim.shutdown)
        # Drop the children's semaphores now: uvicorn ends the process by re-raising SIGTERM,
        # which skips the finalizers that would otherwise unlink them (a "leaked" warning).
        self.sim = None
        gc.collect()

    # worker messages (the relay thread hands them to the loop)
    def _from_relay(self, message: WorkerMessage) -> None:
        loop = self._loop
        if loop is not None and not loop.is_closed():
            with contextlib.suppress(RuntimeError):
                loop.call_soon_threadsafe(self._on_worker_message, message)

    def _on_worker_message(self, message: WorkerMessage) -> None:
        if isinstance(message, WorkerState):
            self.latest = message
            self.replay = message.replay or self.replay
            self.mode, self.mapping = message.mode, message.mapping
            self._state_rate.tick(time.monotonic())
            self._publish_state()
            return
        event = {k: v for k, v in message.dict().items() if k != "trace"}
        if event["event"] == "warming":
            self._preparing(event)
            return
        if event["event"] == "started":
            self.preparing = None
        self.events.append(event)
        if event["event"] in ("replay_optimising", "replay_finished"):
            self._on_replay_event(event)
        if event["event"] == "loop_closed":
            self.hub.publish("loop_closure", event)
        if event["event"] in ("started", "changed") and "mode" in event:
            self.mode = event["mode"]
            self.mapping = event.get("mapping", self.mapping)
        if event["event"] in ("started", "changed") and "map_name" in event:
            self._follow_worker_map(event["map_name"] or LIVE)
        if event["event"] == "error":
            self.hub.publish("error", {"detail": event.get("detail")})
        if event["event"] in ("restarted", "started", "changed", "crashed"):
            self.hub.publish("status", self.status())

    def _follow_worker_map(self, key: str) -> None:
        """Rooms and zones follow the map the worker uses, also after a restart or on a new map."""
        if key != self.rooms.key or key != self.zones.key:
            self._tasks.append(asyncio.create_task(self.use_map(key)))

    async def use_map(self, key: str) -> None:
        """The rooms and zones of the saved map ``key`` (:data:`~app.db.rooms.LIVE`: the live map's)."""
        await self.rooms.use_map(key)
        await asyncio.to_thread(self.zones.use_map, key)

    def _on_replay_event(self, event: dict) -> None:
        self.replay = event["replay"]
        self.hub.publish("status", self.status())
        if event["event"] == "replay_finished" and self.settings.replay_exit_at_end:
            log.warning("replay finished; stopping the server (--exit-at-end)")
            self.stop_server()

    def _preparing(self, event: dict) -> None:
        """Show the worker's warm-up (numba compiles its kernels on the first start) on the console
        (first worker only) and in the dashboard's status."""
        self.preparing = {k: event[k] for k in ("done", "total", "stage")}
        if self.supervisor is not None and self.supervisor.health.restarts == 0:
            print(f"homebot: preparing the estimator {event['done'] + 1}/{event['total']}: {event['stage']} "
                  "(numba compiles it once, about a minute, then loads it from its cache)", flush=True)
        self.hub.publish("status", self.status())

    def _publish_state(self) -> None:
        m = self.latest
        if m is None:
            return
        pose = m.pose
        base = {"t": m.t, "seq": m.seq}
        hub = self.hub
        self._publish_pose()
        hub.publish("map_to_odom", {**base, **_pose_fields(m.map_to_odom), "odom_t": m.odom_stamp})
        hub.publish("particles", {**base, "particles": _rounded(m.particles, 3),
                                  "weights": _rounded(m.weights, 6)})
        hub.publish("scan", {**base, "pose": _rounded(pose, POSE_DECIMALS),
                             "points": _rounded(m.points, SCAN_DECIMALS)})
        if m.landmarks is not None:
            hub.publish("landmarks", {**base, "landmarks": _rounded(m.landmarks, 3),
                                      "covariances": _rounded(m.landmark_covariances, 5)})
        hub.publish("path", {"t": time.time(), **self.navigator.snapshot()})
        self._last_stream = time.monotonic()

    def _publish_pose(self) -> None:
        """The current pose (:meth:`current_pose`), stamped now; ``seq`` is the worker step whose
        correction it uses, ``odom_t`` the stamp of the odometry it is composed with."""
        m = self.latest
        pose, odom_t = self._composed_pose()
        self.hub.publish("pose", {"t": time.time(), "seq": m.seq, **_pose_fields(pose), "odom_t": odom_t,
                                  "localized": m.localized})

    # pumps
    async def _stream_ticker(self) -> None:
        """The pose at ``stream_hz`` whatever the worker does (it moves with the odometry); particles,
        scan and path again whenever the worker published nothing for a period."""
        period = 1.0 / self.settings.stream_hz
        due = time.monotonic()
        while True:
            due += period
            await asyncio.sleep(max(0.0, due - time.monotonic()))
            now = time.monotonic()
            due = max(due, now - period)  # far behind (a busy machine): no burst to catch up
            if now - self._last_stream >= period:
                if self.latest is not None:
                    self._publish_state()
                else:
                    self.hub.publish("path", {"t": time.time(), **self.navigator.snapshot()})
                    self._last_stream = now
            elif self.latest is not None:
                self._publish_pose()

    async def _status_ticker(self) -> None:
        while True:
            await asyncio.sleep(1.0 / self.settings.status_hz)
            self.hub.publish("status", self.status())

    async def _map_pump(self) -> None:
        """Read the shared map at ``map_hz``; send changed tiles (FULL on a new layout, none if unchanged)."""
        tile = self.settings.tile_size
        while True:
            await asyncio.sleep(1.0 / self.settings.map_hz)
            snapshot = await asyncio.to_thread(self.supervisor.shared_map.snapshot)
            last = self.map_snapshot
            if snapshot is None:
                continue
            if last is not None and snapshot.seq == last.seq:
                # Unchanged: a zero-tile delta, so clients see the map is current (>= 1 Hz).
                self.hub.publish_map(map_frames.encode(last, tile, np.zeros(0, np.int64)), empty=True)
                continue
            if last is None or snapshot.epoch != last.epoch or len(snapshot.stamps) != len(last.stamps):
                self.map_snapshot = snapshot
                self.hub.publish_map(None)
                continue
            changed = np.flatnonzero(snapshot.stamps > last.seq)
            delta = await asyncio.to_thread(map_frames.encode, snapshot, tile, changed)
            self.map_snapshot = snapshot
            self.hub.publish_map(delta)

    def full_map_frame(self) -> bytes | None:
        snapshot = self.map_snapshot
        if snapshot is None:
            return None
        if self._full_cache is None or self._full_cache[0] != snapshot.seq:
            self._full_cache = (snapshot.seq, map_frames.encode(snapshot, self.settings.tile_size))
        return self._full_cache[1]

    # what routes and the navigator read
    def current_grid(self) -> OccupancyGrid | None:
        snapshot = self.map_snapshot
        if snapshot is None:
            return None
        if self._grid_cache is None or self._grid_cache[0] != snapshot.seq:
            self._grid_cache = (snapshot.seq, snapshot.grid())
        return self._grid_cache[1]

    def map_cells(self) -> int:
        """The current map's cell count (0 without a map)."""
        snapshot = self.map_snapshot
        return 0 if snapshot is None else snapshot.width * snapshot.height

    def current_pose(self) -> np.ndarray | None:
        """The worker's ``map -> odom`` correction composed with the newest odometry (REP-105): fresh
        at odometry rate between SLAM steps, across worker restarts, and at once after a loop closure."""
        return None if self.latest is None else self._composed_pose()[0]

    def _composed_pose(self) -> tuple[np.ndarray, float]:
        """:meth:`current_pose` and the stamp of the odometry it is made of (with a worker state)."""
        latest = self.latest
        odometry = self.odometry_ring.newest()
        if odometry is None:
            return np.asarray(latest.pose, float), latest.odom_stamp
        return pose_in_map(latest.map_to_odom, odometry.pose), odometry.stamp

    def _correction(self) -> np.ndarray | None:
        """The newest ``map -> odom`` (for a restarted worker; none while a log is replayed)."""
        latest = self.latest
        return None if latest is None or self.settings.replay else latest.map_to_odom

    def frames(self) -> dict | None:
        """The transforms behind :meth:`current_pose`, for the status."""
        latest, odometry = self.latest, self.odometry_ring.newest()
        if latest is None:
            return None
        return {"map_to_odom": _rounded(latest.map_to_odom, POSE_DECIMALS), "map_to_odom_seq": latest.seq,
                "odom": None if odometry is None else _rounded(odometry.pose, POSE_DECIMALS),
                "odom_t": None if odometry is None else odometry.stamp}

    def send_velocity(self, v: float, w: float) -> None:
        """Straight to the robot link (a replayed log cannot be steered: dropped)."""
        if self.link is not None:
            self.link.send_velocity(float(v), float(w))

    def state_rate(self) -> float:
        """Worker states received per second over the last few seconds."""
        return self._state_rate.rate(time.monotonic())

    def status(self) -> dict:
        latest = self.latest
        pose = self.current_pose()
        snap = self.map_snapshot
        health = self.supervisor.health.dict() if self.supervisor else {}
        health["steps"] = latest.steps if latest else 0
        health["rate_hz"] = round(latest.rate_hz, 2) if latest else 0.0
        health["state_t"] = latest.t if latest else None  # when the worker last published a pose
        health["relocalizing"] = latest.relocalizing if latest else False
        nav = self.navigator
        return {
            "mode": self.mode,
            "mapping": self.mapping,
            "pose": None if pose is None else dict(zip(("x", "y", "yaw"), map(float, pose), strict=True)),
            "localized": latest.localized if latest else False,
            "room": None if pose is None else self.rooms.name_at(float(pose[0]), float(pose[1])),
            "worker": health,
            "map": None if snap is None else {"width": snap.width, "height": snap.height,
                                              "resolution": snap.resolution, "origin": list(snap.origin),
                                              "seq": snap.seq},
            "goal": nav.goal.dict() if nav.goal else None,
            "nav": {"state": nav.state, "reason": nav.reason, "touring": nav.touring},
            "path_length": nav.path_length(),
            "rates": {"state_hz": round(self.state_rate(), 2), "stream_hz": self.settings.stream_hz,
                      "map_hz": self.settings.map_hz},
            "clients": len(self.hub.clients),
            "sim": self.settings.simulation,
            "replay": self.replay,
            "loops": latest.loops if latest else None,
            "odometry": latest.odometry if latest else None,
            "frames": self.frames(),
            "true_pose": None if self.sim is None else [float(v) for v in self.sim.true_pose()],
            "events": list(self.events)[-5:],
            "preparing": self.preparing,
            "time": time.time(),
        }
