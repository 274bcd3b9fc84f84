"""The log as a robot: plays a CARMEN log's laser records into the worker's odometry and scan inputs.

Each laser record becomes one odometry reading (the record's odometry pose, stamped with
its ipc timestamp) put into the worker's :class:`OdometryHistory` (and, through a
:class:`~app.grabbers.shared.Fanout`, the server's odometry ring), then its scan (same
stamp) put into the scan :class:`~app.grabbers.shared.Backlog`, so the worker pairs them exactly as it pairs a
real robot's. Records are played in the log's own timing divided by ``speed``; with
``speed=None`` ("max") each record waits until the worker has stepped the previous one,
so no scan is dropped. The scan backlog's sequence number of a record is its index + 1.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.grabbers.odometry_history import OdometryHistory
from app.grabbers.shared import Backlog, Fanout
from slam_core.io.carmen import LaserRecord, TruncatedLogError, laser_records

#: How often a paused feed looks at its stop flag (s).
POLL_S = 0.05


@dataclass(frozen=True)
class LoggedOdometry:
    """The odometry pose a log gives for one laser record, stamped with the record's ipc time."""

    pose: np.ndarray
    stamp: float
    ticks: tuple[int, int] | None = None  # a log has no encoder counts


def read_laser_records(path: Path) -> tuple[list[LaserRecord], list[str]]:
    """Every laser record of a log and the warnings (a truncated end is one, unless it left no record)."""
    records: list[LaserRecord] = []
    return records, _read(path, records.append)


def check_laser_log(path: Path) -> list[str]:
    """What :func:`read_laser_records` warns of, or its error, without keeping the records."""
    return _read(path, lambda record: None)


def _read(path: Path, keep: Callable[[LaserRecord], None]) -> list[str]:
    """Give every laser record to ``keep``; the warnings, or the error of a log without records."""
    count = 0
    try:
        for record in laser_records(path):
            keep(record)
            count += 1
    except TruncatedLogError as exc:
        if not count:
            raise ValueError(f"{exc}; no laser records before it") from None
        return [str(exc)]
    if not count:
        raise ValueError(f"{path}: no laser records")
    return []


def replay_name(log: str) -> str:
    """The folder name of a replay: a bundled log's name, or the file name without its suffixes."""
    name = Path(log).name
    for suffix in (".gz", ".bz2", ".clf"):
        name = name.removesuffix(suffix)
    return name or "log"


class LogReplay:
    """A thread feeding ``records`` to ``odometry`` and ``scans``; see the module docstring."""

    def __init__(self, records: list[LaserRecord], speed: float | None, odometry: OdometryHistory | Fanout,
                 scans: Backlog):
        if speed is not None and speed <= 0:
            raise ValueError(f"replay speed must be positive, got {speed}")
        self.records = records
        self.speed = speed
        self.odometry = odometry
        self.scans = scans
        self.played = 0
        self.ended = threading.Event()
        self._stepped = -1
        self._cond = threading.Condition()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="log-replay", daemon=True)

    def start(self) -> LogReplay:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(2 * POLL_S + 1.0)

    def mark_stepped(self, index: int) -> None:
        """The worker stepped record ``index`` (a ``--speed max`` feed then plays the next one)."""
        with self._cond:
            self._stepped = max(self._stepped, index)
            self._cond.notify_all()

    def _wait_stepped(self, index: int) -> None:
        with self._cond:
            while self._stepped < index and not self._stop.is_set():
                self._cond.wait(POLL_S)

    def _run(self) -> None:
        start = time.monotonic()
        first = self.records[0].stamp.ipc_time
        for index, record in enumerate(self.records):
            if self.speed is None:
                self._wait_stepped(index - 1)
            else:
                due = start + (record.stamp.ipc_time - first) / self.speed
                self._stop.wait(max(0.0, due - time.monotonic()))
            if self._stop.is_set():
                return
            self.odometry.put(LoggedOdometry(record.odom, record.stamp.ipc_time))
            self.scans.put(record.scan)
            self.played = index + 1
        self.ended.set()
