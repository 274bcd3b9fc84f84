"""Wheel encoders to SE(2) odometry for a differential-drive robot."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam_core.geometry import compose


@dataclass(frozen=True)
class DiffDriveGeometry:
    """Wheel radius and separation (m) and encoder ticks per wheel revolution (a robot's are in
    its description, :mod:`slam_core.robot_config`)."""

    wheel_radius: float
    wheel_base: float
    ticks_per_rev: int

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


TICK_MODULUS = 1 << 32  # encoder counters are signed 32-bit and wrap
CLOCK_MODULUS = 1 << 32  # MCU timestamps are unsigned 32-bit microseconds and wrap
#: Ticks a wheel may exceed its speed limit by (quantisation, sampling jitter).
TICK_SLACK = 3
#: A gap in MCU time longer than this (s) breaks the odometry chain: re-baseline, don't integrate.
MAX_TIME_GAP = 5.0
#: Host-side slack (s) on the time between two frames' arrivals (serial buffering, scheduling).
HOST_TIME_SLACK = 0.1


def wrapped_delta(new: int, old: int, modulus: int = TICK_MODULUS) -> int:
    """``new - old`` for counters that wrap at ``modulus``, as the signed shortest difference."""
    half = modulus // 2
    return (int(new) - int(old) + half) % modulus - half


class OdometryIntegrator:
    """Successive cumulative tick readings with MCU timestamps to an SE(2) odometry pose.

    Handles 32-bit wrap-around of both tick counters and the microsecond clock. The
    first reading only sets the baseline. A reading is *implausible*, counted in
    ``jumps_rejected`` and not integrated, when a wheel moved more ticks than
    ``max_wheel_speed`` allows for the elapsed time (plus :data:`TICK_SLACK`); the
    MCU clock stepping back or jumping more than :data:`MAX_TIME_GAP` is counted in
    ``time_gaps``. Either way the reading becomes the new baseline, so odometry never
    jumps and resumes at once after an MCU reset (counters and clock back at 0).

    The elapsed time is the MCU's, but when readings carry their host arrival time it is
    at most the host's elapsed time plus :data:`HOST_TIME_SLACK`: a frame whose MCU clock
    leaps ahead (a glitch that passed the CRC) cannot vouch for a long move by itself.
    """

    def __init__(self, geometry: DiffDriveGeometry, max_wheel_speed: float, pose=(0.0, 0.0, 0.0)):
        if not max_wheel_speed > 0:
            raise ValueError(f"max_wheel_speed must be positive (m/s), got {max_wheel_speed!r}")
        if not (geometry.wheel_radius > 0 and geometry.wheel_base > 0 and geometry.ticks_per_rev > 0):
            raise ValueError(f"wheel radius, wheel base and ticks per rev must be positive: {geometry}")
        pose = np.asarray(pose, dtype=float)
        if pose.shape != (3,) or not np.all(np.isfinite(pose)):
            raise ValueError(f"initial pose must be three finite numbers (x, y, theta), got {pose!r}")
        self.geometry = geometry
        self.max_wheel_speed = float(max_wheel_speed)
        self.pose = pose.copy()
        self.time = 0.0  # MCU seconds since the first reading, unwrapped
        self.accepted = 0
        self.jumps_rejected = 0
        self.time_gaps = 0
        self._last: tuple[int, int, int] | None = None

    def max_ticks(self, dt: float) -> int:
        """The most ticks a wheel can turn in ``dt`` seconds."""
        return int(self.max_wheel_speed * dt / self.geometry.metres_per_tick) + TICK_SLACK

    def reset_baseline(self) -> None:
        """Forget the previous reading (keep the pose): the next reading is a new baseline."""
        self._last = None

    def update(self, t_us: int, left: int, right: int, host_time: float | None = None) -> bool:
        """Take one reading (``host_time``: its arrival, monotonic seconds); True when it moved the
        pose (or set the first baseline)."""
        last, self._last = self._last, (t_us, left, right, host_time)
        if last is None:
            self.accepted += 1
            return True
        dt_us = (int(t_us) - last[0]) % CLOCK_MODULUS
        dt = dt_us * 1e-6
        if dt > MAX_TIME_GAP:
            self.time_gaps += 1
            return False
        d_left = wrapped_delta(left, last[1])
        d_right = wrapped_delta(right, last[2])
        vouched = dt
        if host_time is not None and last[3] is not None:
            vouched = min(dt, max(0.0, host_time - last[3]) + HOST_TIME_SLACK)
        limit = self.max_ticks(vouched)
        if abs(d_left) > limit or abs(d_right) > limit:
            self.jumps_rejected += 1
            self.time += dt
            return False
        self.pose = integrate_ticks(self.pose, d_left, d_right, self.geometry)
        self.time += dt
        self.accepted += 1
        return True
