"""How the worker pairs a scan with odometry before a step: :class:`StampedPairing`.

Every new scan is stepped once, with the odometry at the scan's own timestamp, interpolated
in a short :class:`~app.grabbers.odometry_history.OdometryHistory`, not with "the newest of
each". Scan and odometry stamps are on one clock: the host's ``time.time()`` for a robot
(the simulator stamps its scans so, the odometry grabber its readings on arrival), the log's
for a replay.

Scans are stepped in order from a short :class:`~app.grabbers.shared.Backlog`: a burst (a
laser driver's, or a log's: a third of intel's records come within 10 ms of the one before)
or a slow filter update delays the scans after it but loses none; a worker more than
``max_lag_s`` behind the newest scan skips to the scans within that lag.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

from app.grabbers.odometry_history import OdometryHistory
from app.grabbers.shared import Backlog
from slam_core.scan import Scan

#: How long a scan newer than the newest odometry waits for the reading after it (s).
ODOMETRY_WAIT_S = 0.05
POLL_S = 0.002
#: Scans held for a worker behind the sensor; and how far behind the newest a scan is still stepped (s).
SCAN_BACKLOG = 32
MAX_LAG_S = 0.5


@dataclass(frozen=True)
class Pair:
    """An odometry reading (``.pose``, ``.ticks``) and the scan to step with it;
    ``scan_seq`` is the scan's sequence number in its :class:`~app.grabbers.shared.Backlog`."""

    odometry: Any
    scan: Scan
    scan_seq: int


class StampedPairing:
    def __init__(self, odometry: OdometryHistory, scans: Backlog, wait_s: float = ODOMETRY_WAIT_S,
                 max_lag_s: float = MAX_LAG_S):
        self.odometry = odometry
        self.scans = scans
        self.wait_s = wait_s
        self.max_lag_s = max_lag_s
        self._last_scan = 0
        self._pending: tuple[int, float] | None = None  # a scan waiting for its odometry, since when

    @property
    def last_scan(self) -> int:
        """The sequence number of the last scan taken (stepped or dropped for want of odometry)."""
        return self._last_scan

    def next(self, timeout: float) -> Pair | None:
        """The oldest scan not yet taken (within ``max_lag_s`` of the newest) with the odometry at
        its stamp; ``None`` after waiting up to ``timeout`` for a scan, or when no odometry came
        yet (that scan is dropped). A scan newer than the newest odometry waits up to ``wait_s``
        for the reading after it."""
        held = self.scans.wait_after(self._last_scan, timeout)
        if not held:
            return None
        newest = held[-1][1].timestamp
        scan_seq, scan = next((seq, s) for seq, s in held if s.timestamp >= newest - self.max_lag_s)
        if not self.odometry.covers(scan.timestamp):
            if self._pending is None or self._pending[0] != scan_seq:
                self._pending = (scan_seq, time.monotonic())
            if time.monotonic() - self._pending[1] < self.wait_s:
                time.sleep(POLL_S)
                return None
        self._last_scan = scan_seq
        reading = self.odometry.at(scan.timestamp)
        return None if reading is None else Pair(reading, scan, scan_seq)
