"""The worker's odometry input: a thread copying the robot link's odometry ring into an OdometryHistory.

The server's :class:`~app.robot_link.link.RobotLink` owns the serial port and writes every
reading into an :class:`~app.robot.odometry_ring.OdometryRing`; the worker only reads it, so a
worker crash or restart never touches the port and the odometry stays continuous. A new worker
starts with the readings the ring still holds (a few seconds).
"""

from __future__ import annotations

import threading

from app.grabbers.odometry_history import OdometryHistory
from app.robot.odometry_ring import OdometryRing

#: How often the ring is looked at (s); well under the 50 ms a scan waits for its odometry.
POLL_S = 0.003


class RingOdometryGrabber:
    """Puts every reading of ``ring`` into ``output``, oldest first."""

    def __init__(self, ring: OdometryRing, output: OdometryHistory):
        self.ring = ring
        self.odometry = output
        self._count = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="ring-odometry-grabber", daemon=True)

    def start(self) -> RingOdometryGrabber:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(2 * POLL_S + 1.0)

    def _run(self) -> None:
        while not self._stop.wait(POLL_S):
            if self.ring.count == self._count:
                continue
            self._count, readings = self.ring.read_since(self._count)
            for reading in readings:
                self.odometry.put(reading)
