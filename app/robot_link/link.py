"""The robot link: the server's one owner of the robot's serial port (odometry in, velocity out).

An :class:`~app.grabbers.odometry_grabber.OdometryGrabber` thread reads the encoder frames and
writes every odometry reading into an :class:`~app.robot.odometry_ring.OdometryRing`, which the
SLAM worker reads (:mod:`app.grabbers.ring_odometry_grabber`) and the server composes with the
worker's ``map -> odom`` correction (:mod:`app.worker.frames`). Velocity commands from the
navigator and teleop go straight to the port, never through the worker, so a worker crash or
restart leaves the link, the odometry and the robot's motion alone.
"""

from __future__ import annotations

import contextlib

from app.grabbers.odometry_grabber import DEFAULT_BAUDRATE, OdometryGrabber, OdometryGrabberStats
from app.robot.odometry_ring import OdometryRing
from slam_core.sensors.wheel_odometry import DiffDriveGeometry


class RobotLink:
    """Serial port ``port`` <-> ``ring`` (odometry) and :meth:`send_velocity`."""

    def __init__(self, port: str, ring: OdometryRing, baudrate: int = DEFAULT_BAUDRATE,
                 geometry: DiffDriveGeometry | None = None):
        self.ring = ring
        self.grabber = OdometryGrabber(port, baudrate, geometry=geometry, output=ring)

    def start(self) -> RobotLink:
        self.grabber.start()
        return self

    def stop(self) -> None:
        """Stop the wheels, then close the port."""
        with contextlib.suppress(Exception):
            self.grabber.send_velocity(0.0, 0.0)
        self.grabber.stop()

    def send_velocity(self, v: float, w: float) -> bool:
        """Body velocity ``v`` (m/s), ``w`` (rad/s) to the MCU; False if it could not be sent."""
        return self.grabber.send_velocity(v, w)

    def stats(self) -> OdometryGrabberStats:
        return self.grabber.stats()
