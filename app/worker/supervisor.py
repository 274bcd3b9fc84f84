"""Runs the worker process, restarts it when it dies, and relays its messages to the server.

Workers are forked from a fork server that has already imported the worker's modules
(numpy, numba, the estimators: over a second of CPU), so a restarted worker runs within a
fraction of a second instead of starting a new interpreter. Queues are made anew for every
worker generation: a process killed while holding a queue's internal lock would otherwise
wedge its successor. The shared map outlives
the workers (the server owns it), so the map stays visible across a restart.
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing as mp
import os
import queue
import re
import signal
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from app.core.config import Settings
from app.robot.odometry_ring import OdometryRing
from app.robot.scan_slot import ScanSlot
from app.worker.checkpoint import quarantine_newest
from app.worker.messages import Command, WorkerEvent, WorkerMessage, accepted
from app.worker.process import WorkerSpec, worker_main
from app.worker.shared_map import SharedMap

log = logging.getLogger(__name__)

STATES_MAX = 256
COMMANDS_MAX = 256
POLL_S = 0.1
STOP_TIMEOUT_S = 15.0
#: Restart delays double with every failure in a row, up to this (s).
RESTART_DELAY_CAP_S = 30.0
#: Exits kept in the restart history.
HISTORY_KEPT = 20
#: Failures in a row (workers that died before they were healthy) that make a crash loop.
CRASH_LOOP_FAILURES = 2
#: The wait before replacing a worker that stopped cleanly without being told to by the supervisor (s).
CLEAN_EXIT_GRACE_S = 2.0
#: What the fork server imports once, so that every worker forked from it starts with it; the
#: first module makes the fork server itself ignore SIGTERM (see it).
FORK_SERVER_PRELOAD = ["app.worker.fork_server", "app.worker.process"]


def without_data_dir(text: str, data_dir: Path) -> str:
    """``text`` with the server's data folder written as ``DATA``: events and errors reach clients
    (status, stream, health, 409s), server paths must not."""
    text = text.replace(str(data_dir.resolve()), "DATA")
    if data_dir.is_absolute():
        return text.replace(str(data_dir), "DATA")
    # A relative data dir: only where it starts a path (``data/maps/x``, not ``metadata/``).
    return re.sub(rf"(?<![\w./-]){re.escape(str(data_dir))}(?=/)", "DATA", text)


def restart_delay(base_s: float, failures: int, cap_s: float = RESTART_DELAY_CAP_S) -> float:
    """The wait before the next start after ``failures`` (>= 1) failures in a row: ``base * 2**(n-1)``."""
    return min(cap_s, base_s * 2.0 ** max(0, failures - 1))


@dataclass
class WorkerHealth:
    """What the status route reports about the worker."""

    alive: bool = False
    pid: int | None = None
    restarts: int = 0
    started_at: float | None = None
    last_error: str | None = None
    last_exit_code: int | None = None
    #: Workers in a row that died before they reported healthy (reset by a healthy worker).
    failures: int = 0
    healthy: bool = False
    history: deque[dict] = field(default_factory=lambda: deque(maxlen=HISTORY_KEPT))

    @property
    def crash_looping(self) -> bool:
        return self.failures >= CRASH_LOOP_FAILURES

    def dict(self) -> dict:
        return {"alive": self.alive, "pid": self.pid, "restarts": self.restarts,
                "started_at": self.started_at, "last_error": self.last_error,
                "last_exit_code": self.last_exit_code, "failures": self.failures,
                "healthy": self.healthy, "crash_looping": self.crash_looping}


class WorkerSupervisor:
    """Start/stop the worker; ``on_message`` is called from the relay thread for each
    :class:`~app.worker.messages.WorkerState` and :class:`~app.worker.messages.WorkerEvent`."""

    def __init__(self, settings: Settings, odometry_ring: OdometryRing, scan_slot: ScanSlot | None,
                 on_message: Callable[[WorkerMessage], None], initial_pose=(0.0, 0.0, 0.0),
                 correction: Callable[[], np.ndarray | None] = lambda: None):
        self.settings = settings
        self.odometry_ring = odometry_ring
        self.scan_slot = scan_slot
        self.on_message = on_message
        self.initial_pose = tuple(float(v) for v in initial_pose)
        self.correction = correction  # the newest map -> odom, handed to a restarted worker
        self.ctx = mp.get_context("forkserver")
        self.ctx.set_forkserver_preload(FORK_SERVER_PRELOAD)
        self.shared_map = SharedMap(settings.map_capacity_cells, settings.tile_size, create=True)
        self.health = WorkerHealth()
        self._lock = threading.Lock()
        self._process: mp.Process | None = None
        self._commands = None
        self._states = None
        self._stopping = threading.Event()  # no more restarts
        self._relay_done = threading.Event()  # the relay may stop reading (the worker has exited)
        self._relay: threading.Thread | None = None
        self._resumed = False  # the current worker loaded its checkpoint and started
        self._blamed = 0  # workers in a row that died after resuming, before they were healthy

    # lifecycle
    def start(self) -> None:
        self._spawn()
        self._relay = threading.Thread(target=self._run, name="worker-relay", daemon=True)
        self._relay.start()

    def _spawn(self) -> None:
        with self._lock:
            self._close_queues()
            self._commands = self.ctx.Queue(COMMANDS_MAX)
            self._states = self.ctx.Queue(STATES_MAX)
            correction = self.correction()
            spec = WorkerSpec(self.settings.model_dump(), self.shared_map.name, self.health.restarts,
                              self.initial_pose, os.getpid(),
                              None if correction is None else tuple(float(v) for v in correction))
            proc = self.ctx.Process(target=worker_main, name="homebot-worker", daemon=True,
                                    args=(spec, self._commands, self._states, self.scan_slot,
                                          self.odometry_ring))
            proc.start()
            self._process = proc
            self.health.alive, self.health.pid, self.health.started_at = True, proc.pid, time.time()
            self.health.healthy = False
            self._resumed = False

    def _close_queues(self) -> None:
        """Release the last generation's queues (their feeder thread and semaphores) at once."""
        for q in (self._commands, self._states):
            if q is not None:
                q.close()
                q.cancel_join_thread()  # a dead worker reads nothing: do not wait for the pipe
        self._commands = self._states = None

    def stop(self) -> None:
        """Ask the worker to save and exit (SIGTERM), wait, then release the shared map."""
        self._stopping.set()
        proc = self._process
        if proc is not None and proc.is_alive():
            os.kill(proc.pid, signal.SIGTERM)
            proc.join(STOP_TIMEOUT_S)  # the relay reads on meanwhile, so the worker's last messages flow
            if proc.is_alive():
                proc.kill()
                proc.join()
        self._relay_done.set()
        if self._relay is not None:
            self._relay.join(2.0)
        self._drain()
        self._close_queues()
        self._process = None  # its arguments hold the last queues
        self.health.alive = False
        self.shared_map.close()
        with contextlib.suppress(FileNotFoundError):
            self.shared_map.unlink()

    # commands
    def send(self, command: Command) -> bool:
        """Queue a command for the worker; False when it cannot take it now."""
        try:
            self._commands.put_nowait(command)
            return True
        except (queue.Full, ValueError, OSError, AttributeError):
            return False

    # relay
    def _drain(self) -> None:
        while True:
            try:
                message = self._states.get_nowait()
            except (queue.Empty, OSError, ValueError, EOFError):
                return
            except Exception:  # unreadable (unpickling failed): dropped
                log.warning("supervisor: dropped an unreadable worker message", exc_info=True)
                continue
            self._deliver(message)

    def _receive(self) -> WorkerMessage | None:
        """The next message from the worker, or ``None`` after a short wait or an unreadable one."""
        try:
            return self._states.get(timeout=POLL_S)
        except queue.Empty:
            return None
        except (OSError, EOFError, ValueError, AttributeError):  # queues closed or being replaced
            time.sleep(POLL_S)
            return None
        except Exception:  # unreadable (unpickling failed): dropped
            log.warning("supervisor: dropped an unreadable worker message", exc_info=True)
            return None

    def _deliver(self, message: WorkerMessage) -> None:
        if not accepted(message, WorkerMessage, "supervisor"):
            return
        event = message.name if isinstance(message, WorkerEvent) else None
        if event is not None:
            message = WorkerEvent(message.name, message.t, {
                k: without_data_dir(v, self.settings.data_dir) if isinstance(v, str) else v
                for k, v in message.fields.items()})
        if event in ("crashed", "error"):
            self.health.last_error = message.fields.get("detail")
        elif event == "started":
            self._resumed = True  # the checkpoint loaded: a death from now on may be its fault
        elif event == "healthy":
            self.health.healthy, self.health.failures, self._blamed = True, 0, 0
        try:
            self.on_message(message)
        except Exception:  # a bug in a consumer must not stop the relay
            log.exception("worker message consumer failed")

    def _run(self) -> None:
        while not self._relay_done.is_set():
            message = self._receive()
            if message is not None:
                self._deliver(message)
            proc = self._process
            if proc is not None and not proc.is_alive() and not self._stopping.is_set():
                self._restart(proc)

    def _blame_checkpoint(self) -> None:
        """The second worker in a row to die soon after resuming sets the newest snapshot aside."""
        self._blamed += 1
        if self._blamed < CRASH_LOOP_FAILURES:
            return
        self._blamed = 0
        path = quarantine_newest(self.settings.checkpoint_dir)
        if path is not None:
            log.warning("the worker died twice in a row after resuming; set %s aside", path)
            self._deliver(WorkerEvent("checkpoint_quarantined", time.time(), {
                "path": str(path), "detail": "the worker died twice in a row after resuming it"}))

    def _restart(self, proc: mp.Process) -> None:
        self._drain()
        code = proc.exitcode
        self.health.alive = False
        self.health.last_exit_code = code
        if self.health.last_error is None or (code is not None and code < 0):
            self.health.last_error = f"worker exited with code {code}"
        self.health.restarts += 1
        if not self.health.healthy:
            self.health.failures += 1
        self.health.history.append({"time": time.time(), "exit_code": code, "healthy": self.health.healthy})
        if self._resumed and not self.health.healthy:
            self._blame_checkpoint()
        # A worker that was healthy is replaced at once; failures in a row back off. One that was
        # asked to stop (exit code 0) and not by us is given time for the server's own stop to come
        # (a service manager signals every process of the service at once).
        delay = 0.0 if self.health.healthy else restart_delay(self.settings.worker_restart_delay_s,
                                                              self.health.failures)
        if code == 0:
            if self._stopping.wait(CLEAN_EXIT_GRACE_S):
                return  # the server's stop came: nothing to restart, nothing to say
            delay = max(0.0, delay - CLEAN_EXIT_GRACE_S)
        log.warning("worker exited (code %s); restarting from the last checkpoint in %.1f s", code, delay)
        self._stopping.wait(delay)
        if not self._stopping.is_set():
            self._spawn()
            self.on_message(WorkerEvent("restarted", time.time(),
                                        {"restarts": self.health.restarts, "exit_code": code}))
