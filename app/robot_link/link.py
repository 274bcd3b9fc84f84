"""The robot link: the server's one owner of the robot's serial port (odometry in, velocity out).

An :class:`~app.grabbers.odometry_grabber.OdometryGrabber` thread reads the encoder frames and
writes every odometry reading into an :class:`~app.robot.odometry_ring.OdometryRing`, which the
SLAM worker reads (:mod:`app.grabbers.ring_odometry_grabber`) and the server composes with the
worker's ``map -> odom`` correction (:mod:`app.worker.frames`). Velocity commands from the
navigator and teleop go straight to the link, never through the worker, so a worker crash or
restart leaves the link, the odometry and the robot's motion alone. A thread of its own writes
them (newest wins), so a stalled port never blocks the server's event loop.
"""

from __future__ import annotations

import contextlib
import math
import threading

from app.grabbers.odometry_grabber import DEFAULT_BAUDRATE, OdometryGrabber, OdometryGrabberStats
from app.grabbers.shared import Latest
from app.robot.odometry_ring import OdometryRing
from slam_core.robot_config import RobotConfig, robot_from

#: How often the command writer looks at its stop flag (s).
POLL_S = 0.1


class RobotLink:
    """Serial port ``port`` <-> ``ring`` (odometry) and :meth:`send_velocity`, for the robot described
    by ``robot`` (its wheels and speed limits; default: the simulated robot)."""

    def __init__(self, port: str, ring: OdometryRing, baudrate: int = DEFAULT_BAUDRATE,
                 robot: RobotConfig | None = None):
        robot = robot or robot_from(None)
        self.ring = ring
        self.grabber = OdometryGrabber(port, baudrate, geometry=robot.wheels,
                                       max_wheel_speed=robot.max_wheel_speed, output=ring)
        self._commands: Latest[tuple[float, float]] = Latest()
        self._stop = threading.Event()
        self._writer = threading.Thread(target=self._write_commands, name="robot-link-commands", daemon=True)

    def start(self) -> RobotLink:
        self.grabber.start()
        self._writer.start()
        return self

    def stop(self) -> None:
        """Stop the wheels, then close the port."""
        self._stop.set()
        self._writer.join(2 * POLL_S + 1.0)
        with contextlib.suppress(Exception):
            self.grabber.send_velocity(0.0, 0.0)
        self.grabber.stop()

    def send_velocity(self, v: float, w: float) -> None:
        """Body velocity ``v`` (m/s), ``w`` (rad/s) for the MCU, written by the link's thread (a newer
        command replaces one not yet written); ``ValueError`` if not finite."""
        if not (math.isfinite(v) and math.isfinite(w)):
            raise ValueError(f"velocity must be finite, got v={v}, w={w}")
        self._commands.put((float(v), float(w)))

    def _write_commands(self) -> None:
        seq = 0
        while not self._stop.is_set():
            got = self._commands.wait_newer(seq, POLL_S)
            if got is not None:
                seq, (v, w) = got
                self.grabber.send_velocity(v, w)  # False (not connected) is counted in its stats

    def stats(self) -> OdometryGrabberStats:
        return self.grabber.stats()
