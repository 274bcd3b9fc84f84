"""The newest odometry readings in shared memory: one writer (the robot link), readers that may be killed.

Like :mod:`app.robot.scan_slot`, a seqlocked shared array rather than a queue (a reader killed
mid-``get`` would leave a queue's lock held). Layout, all ``float64``: a header (write counter,
readings written), then :data:`SLOTS` readings of (host stamp s, x m, y m, theta rad, left ticks,
right ticks); reading ``n`` (1, 2, ...) sits in slot ``(n - 1) % SLOTS``. A log has no encoder
counts: its ticks are stored as NaN and read back as ``None``.
"""

from __future__ import annotations

import multiprocessing as mp
import time
from dataclasses import dataclass

import numpy as np

#: Readings kept: five seconds of a 50 Hz encoder stream.
SLOTS = 256
_HEADER = 2
_WRITES, _COUNT = range(_HEADER)
_FIELDS = 6
READ_RETRIES = 100


@dataclass(frozen=True)
class RingOdometry:
    """One odometry reading as it crosses the process boundary."""

    pose: np.ndarray  # (x, y, theta) in the odometry frame
    stamp: float  # host clock (``time.time()``), or the log's ipc time for a replay
    ticks: tuple[int, int] | None = None  # cumulative (left, right) encoder counts


class OdometryRing:
    """Create with :meth:`create` in the server; pass to the worker. :meth:`put` makes it an
    output of :class:`~app.grabbers.odometry_grabber.OdometryGrabber` or the replay feed."""

    def __init__(self, array):
        self.array = array

    @classmethod
    def create(cls, ctx=None) -> OdometryRing:
        ctx = ctx or mp.get_context("spawn")
        return cls(ctx.RawArray("d", _HEADER + SLOTS * _FIELDS))

    def _view(self) -> np.ndarray:
        return np.frombuffer(self.array, dtype=np.float64)

    def put(self, reading) -> None:
        """Write a reading (anything with ``pose``, ``stamp`` and ``ticks``); one writer at a time."""
        v = self._view()
        slot = int(v[_COUNT]) % SLOTS
        ticks = (np.nan, np.nan) if reading.ticks is None else reading.ticks
        v[_WRITES] += 1
        start = _HEADER + slot * _FIELDS
        v[start:start + _FIELDS] = (reading.stamp, *np.asarray(reading.pose, float)[:3], *ticks)
        v[_COUNT] += 1
        v[_WRITES] += 1

    @property
    def count(self) -> int:
        """Readings written so far."""
        return int(self._view()[_COUNT])

    def read_since(self, count: int) -> tuple[int, list[RingOdometry]]:
        """``(newest count, readings after reading number count)``, oldest first; readings already
        overwritten are skipped (at most :data:`SLOTS` come back). ``(count, [])`` when the ring
        is being written too fast to read (retry later)."""
        v = self._view()
        for _ in range(READ_RETRIES):
            before = v[_WRITES]
            if int(before) % 2:
                time.sleep(0.0002)
                continue
            newest = int(v[_COUNT])
            numbers = range(max(count, newest - SLOTS) + 1, newest + 1)
            rows = [v[_HEADER + (n - 1) % SLOTS * _FIELDS:][:_FIELDS].copy() for n in numbers]
            if v[_WRITES] == before:
                return newest, [_reading(row) for row in rows]
        return count, []

    def newest(self) -> RingOdometry | None:
        """The newest reading; ``None`` before the first."""
        count = self.count
        _, readings = self.read_since(max(0, count - 1))
        return readings[-1] if readings else None


def _reading(row: np.ndarray) -> RingOdometry:
    ticks = None if np.isnan(row[4]) else (int(row[4]), int(row[5]))
    return RingOdometry(row[1:4].copy(), float(row[0]), ticks)
