"""How the worker pairs a scan with odometry before a step: :class:`StampedPairing`.

Every new scan is stepped once, with the odometry at the scan's own timestamp, interpolated
in a short :class:`~app.grabbers.odometry_history.OdometryHistory`, not with "the newest of
each". Scan and odometry stamps are on one clock: the host's ``time.time()`` for a robot
(the simulator stamps its scans so, the odometry grabber its readings on arrival), the log's
for a replay.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

from app.grabbers.odometry_history import OdometryHistory
from app.grabbers.shared import Latest
from slam_core.scan import Scan

#: How long a scan newer than the newest odometry waits for the reading after it (s).
ODOMETRY_WAIT_S = 0.05
POLL_S = 0.002


@dataclass(frozen=True)
class Pair:
    """An odometry reading (``.pose``, ``.ticks``) and the scan to step with it;
    ``scan_seq`` is the scan's sequence number in its :class:`Latest`."""

    odometry: Any
    scan: Scan
    scan_seq: int


class StampedPairing:
    def __init__(self, odometry: OdometryHistory, scans: Latest, wait_s: float = ODOMETRY_WAIT_S):
        self.odometry = odometry
        self.scans = scans
        self.wait_s = wait_s
        self._last_scan = 0
        self._pending: tuple[int, float] | None = None  # a scan waiting for its odometry, since when

    @property
    def last_scan(self) -> int:
        """The sequence number of the last scan taken (stepped or dropped for want of odometry)."""
        return self._last_scan

    def next(self, timeout: float) -> Pair | None:
        """The newest scan not yet taken with the odometry at its stamp; ``None`` after waiting up
        to ``timeout`` for a scan, or when no odometry came yet (that scan is dropped). A scan
        newer than the newest odometry waits up to ``wait_s`` for the reading after it."""
        got = self.scans.get()
        if got[0] <= self._last_scan:
            got = self.scans.wait_newer(self._last_scan, timeout)
            if got is None:
                return None
        scan_seq, scan = got
        if not self.odometry.covers(scan.timestamp):
            if self._pending is None or self._pending[0] != scan_seq:
                self._pending = (scan_seq, time.monotonic())
            if time.monotonic() - self._pending[1] < self.wait_s:
                time.sleep(POLL_S)
                return None
        self._last_scan = scan_seq
        reading = self.odometry.at(scan.timestamp)
        return None if reading is None else Pair(reading, scan, scan_seq)
