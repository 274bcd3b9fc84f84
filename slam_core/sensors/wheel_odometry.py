"""Wheel encoders to SE(2) odometry for a differential-drive robot."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam_core.geometry import compose


@dataclass(frozen=True)
class DiffDriveGeometry:
    """Wheel radius and separation (m) and encoder ticks per wheel revolution."""

    wheel_radius: float = 0.035
    wheel_base: float = 0.23
    ticks_per_rev: int = 1440

    @property
    def metres_per_tick(self) -> float:
        return 2.0 * np.pi * self.wheel_radius / self.ticks_per_rev


def ticks_to_increment(d_left: int, d_right: int, geometry: DiffDriveGeometry) -> np.ndarray:
    """Motion ``(dx, dy, dtheta)`` in the robot frame for tick increments of both wheels.

    The wheels are assumed to turn at constant speed over the interval, so the
    robot moves along an arc (exact for constant velocities).
    """
    sl = d_left * geometry.metres_per_tick
    sr = d_right * geometry.metres_per_tick
    ds = 0.5 * (sl + sr)
    dth = (sr - sl) / geometry.wheel_base
    if abs(dth) < 1e-9:
        return np.array([ds, 0.0, 0.0])
    radius = ds / dth
    return np.array([radius * np.sin(dth), radius * (1.0 - np.cos(dth)), dth])


def integrate_ticks(pose, d_left: int, d_right: int, geometry: DiffDriveGeometry) -> np.ndarray:
    """The odometry pose after one pair of tick increments."""
    return compose(pose, ticks_to_increment(d_left, d_right, geometry))
