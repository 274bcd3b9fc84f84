"""The range-scan grabber: scans from the simulator's shared slot or a real sensor source to the worker.

A real robot names its sensor in ``HOMEBOT_SENSOR_SOURCE`` as ``module:callable``; the
callable returns an iterator of :class:`slam_core.scan.Scan` (a lidar driver, or a
depth camera turned into a planar scan).
"""

from __future__ import annotations

import importlib
import logging
import threading
from collections.abc import Callable, Iterator

from app.grabbers.shared import Backlog, Latest
from app.robot.scan_slot import ScanSlot
from slam_core.scan import Scan

log = logging.getLogger(__name__)

POLL_S = 0.002


def load_sensor_source(spec: str) -> Callable[[], Iterator[Scan]]:
    """Resolve ``module:callable``; raises ``ValueError`` saying what is wrong."""
    module_name, _, attr = spec.partition(":")
    if not module_name or not attr:
        raise ValueError(f"sensor source {spec!r} must look like 'module:callable'")
    try:
        return getattr(importlib.import_module(module_name), attr)
    except (ImportError, AttributeError) as exc:
        raise ValueError(f"sensor source {spec!r} cannot be loaded: {exc}") from exc


class ScanGrabber:
    """A thread that publishes every scan from ``slot`` (simulator) or ``source`` (real sensor)."""

    def __init__(self, slot: ScanSlot | None = None, source: Callable[[], Iterator[Scan]] | None = None,
                 output: Latest[Scan] | Backlog[Scan] | None = None):
        if (slot is None) == (source is None):
            raise ValueError("give exactly one of a scan slot or a sensor source")
        self.scans = output if output is not None else Latest()
        self._slot = slot
        self._source = source
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="scan-grabber", daemon=True)

    def start(self) -> ScanGrabber:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(2 * POLL_S + 1.0)

    def _run(self) -> None:
        if self._source is not None:
            for scan in self._source():
                if self._stop.is_set():
                    return
                self.scans.put(scan)
            log.warning("scan grabber: the sensor source ended")
            return
        last = self._slot.count
        while not self._stop.wait(POLL_S):
            if self._slot.count == last:
                continue
            count, scan = self._slot.read()
            if scan is not None and count != last:
                last = count
                self.scans.put(scan)
