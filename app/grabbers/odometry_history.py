"""A short odometry history, so that each scan is paired with the odometry at its own timestamp.

The odometry arrives faster than the scans and on another clock path; pairing a scan
with "the newest odometry" pairs it with wherever the robot was when the worker got
round to it. :meth:`OdometryHistory.at` instead interpolates between the two readings
around the scan's stamp (as slam_toolbox looks up ``odom -> base_link`` at the scan's
time).
"""

from __future__ import annotations

import bisect
import threading
from dataclasses import replace
from typing import Protocol

import numpy as np

from slam_core.geometry import wrap_angle

#: Readings kept: a few seconds of a 50 Hz encoder stream.
HISTORY_LENGTH = 256


class Stamped(Protocol):
    """An odometry reading: a frozen dataclass with an ``(x, y, theta)`` pose and a stamp (s)."""

    pose: np.ndarray
    stamp: float


class OdometryHistory:
    """The newest :data:`HISTORY_LENGTH` odometry readings, in stamp order (thread-safe)."""

    def __init__(self, length: int = HISTORY_LENGTH) -> None:
        self._length = length
        self._stamps: list[float] = []
        self._readings: list[Stamped] = []
        self._lock = threading.Lock()

    def put(self, reading: Stamped) -> None:
        """Add a reading in stamp order (a log's stamps sometimes step back), after any of equal stamp;
        the oldest one goes when the history is full."""
        with self._lock:
            i = bisect.bisect_right(self._stamps, reading.stamp)
            self._stamps.insert(i, reading.stamp)
            self._readings.insert(i, reading)
            if len(self._stamps) > self._length:
                del self._stamps[0], self._readings[0]

    def at(self, stamp: float) -> Stamped | None:
        """The reading at ``stamp``: the newest one with exactly that stamp, else the two around
        it interpolated (a copy with ``stamp``); the newest (oldest) reading for a stamp after
        (before) the history; ``None`` while it is empty."""
        with self._lock:
            if not self._stamps:
                return None
            i = bisect.bisect_right(self._stamps, stamp) - 1
            if i < 0:
                return self._readings[0]
            before = self._readings[i]
            if before.stamp == stamp or i == len(self._readings) - 1:
                return before
            after = self._readings[i + 1]
        f = (stamp - before.stamp) / (after.stamp - before.stamp)
        p0, p1 = np.asarray(before.pose, float), np.asarray(after.pose, float)
        pose = p0 + f * (p1 - p0)
        pose[2] = wrap_angle(p0[2] + f * wrap_angle(p1[2] - p0[2]))
        return replace(before, pose=pose, stamp=stamp)
