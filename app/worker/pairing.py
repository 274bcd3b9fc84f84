"""How the worker pairs a scan with odometry before a step.

- :class:`NewestPairing` (the live robot today): a step is taken only when BOTH a new
  odometry reading and a new scan have arrived since the last step, with the newest of each;
  stale data is never stepped twice.
- :class:`StampedPairing` (a replayed log): every new scan with the odometry at the scan's
  own timestamp, from a short :class:`~app.grabbers.odometry_history.OdometryHistory`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from app.grabbers.odometry_history import OdometryHistory
from app.grabbers.shared import Latest
from slam_core.scan import Scan


@dataclass(frozen=True)
class Pair:
    """An odometry reading (``.pose``, ``.ticks``) and the scan to step with it;
    ``scan_seq`` is the scan's sequence number in its :class:`Latest`."""

    odometry: Any
    scan: Scan
    scan_seq: int


class NewestPairing:
    def __init__(self, odometry: Latest, scans: Latest):
        self.odometry = odometry
        self.scans = scans
        self._last_odo = self._last_scan = 0

    def next(self, timeout: float) -> Pair | None:
        """The next pair, or ``None`` after waiting up to ``timeout`` for the missing half."""
        odo_seq, odo = self.odometry.get()
        scan_seq, scan = self.scans.get()
        if odo_seq > self._last_odo and scan_seq > self._last_scan:
            self._last_odo, self._last_scan = odo_seq, scan_seq
            return Pair(odo, scan, scan_seq)
        if odo_seq <= self._last_odo:
            self.odometry.wait_newer(odo_seq, timeout)
        else:
            self.scans.wait_newer(scan_seq, timeout)
        return None


class StampedPairing:
    def __init__(self, odometry: OdometryHistory, scans: Latest):
        self.odometry = odometry
        self.scans = scans
        self._last_scan = 0

    @property
    def last_scan(self) -> int:
        """The sequence number of the last scan taken (stepped or dropped for want of odometry)."""
        return self._last_scan

    def next(self, timeout: float) -> Pair | None:
        """The newest scan not yet taken with the odometry at its stamp; ``None`` after waiting up
        to ``timeout`` for a scan, or when no odometry came yet (that scan is dropped)."""
        got = self.scans.get()
        if got[0] <= self._last_scan:
            got = self.scans.wait_newer(self._last_scan, timeout)
            if got is None:
                return None
        scan_seq, scan = got
        self._last_scan = scan_seq
        reading = self.odometry.at(scan.timestamp)
        return None if reading is None else Pair(reading, scan, scan_seq)
