"""A simulated differential-drive robot: limits, collisions, wheel slip and encoders.

The motors turn the wheels at the commanded speeds (after velocity and
acceleration limits). The encoders count whole ticks of the wheel *rotation*
(quantisation: ``floor(angle / 2pi * ticks_per_rev)``). The ground moves by the
rotation times the wheel radius times ``1 + slip``: each wheel's slip is a
constant scale error drawn once (tyre wear, radius mismatch) plus an
Ornstein-Uhlenbeck process (carpet, thresholds) with standard deviation
``slip_std`` and correlation time ``slip_tau``. Odometry integrated from the
ticks with the nominal geometry therefore drifts the way a real robot's does,
while :attr:`SimRobot.true_pose` is the exact ground truth.

The robot's body, wheels and limits are its :class:`~slam_core.robot_config.RobotConfig`
(default: the simulated robot's shipped file). It is a disc of ``footprint_radius``.
Motion is integrated in sub-steps no longer than a quarter of the radius (so it
cannot tunnel through a wall, which would need a step of twice the radius); a
sub-step that would bring the disc closer than its radius to any wall, furniture
edge or leg is cut short by bisection, the robot stops there (wheels stopped,
``bumped`` set) and waits for a new command.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from slam_core.robot_config import RobotConfig, robot_from
from slam_core.sensors.wheel_odometry import ticks_to_increment
from slam_core.sim.raycast import _clearance
from slam_core.sim.world import World

#: Bisection steps used to move the robot up to the contact point.
CONTACT_BISECTIONS = 12
#: Normal variates drawn at a time for the wheel slip.
NOISE_BLOCK = 1024


@dataclass(frozen=True)
class WheelNoise:
    """Per-wheel slip: a fixed scale error (std, drawn once) plus a correlated random slip.

    All values are fractions of the wheel's rotation (0.02 = 2 %). The defaults are a
    calibrated robot on hard floors: a 0.05 % wheel-size mismatch turns the heading by
    about 0.2 degrees per metre driven (Borenstein & Feng's UMBmark reports 0.1-0.5 %
    before calibration); raise them for carpets or a worn robot.
    """

    scale_std: float = 0.0005
    slip_std: float = 0.005
    slip_tau: float = 0.3

    @classmethod
    def none(cls) -> WheelNoise:
        return cls(0.0, 0.0, 0.5)


class SimRobot:
    """A disc-shaped differential-drive robot in a :class:`World`.

    Interface used by grabbers and the serial virtual microcontroller:
    ``set_velocity(v, w)``, ``step(dt)``, ``ticks()``; ground truth in
    ``true_pose``, dead reckoning from the ticks in ``odometry_pose``.
    """

    def __init__(self, world: World, pose=None, robot: RobotConfig | None = None,
                 noise: WheelNoise | None = None, rng: np.random.Generator | None = None,
                 obstacle_min_height: float = 0.0):
        self.world = world
        self.robot = robot or robot_from(None)
        self.geometry = self.robot.wheels
        self.limits = self.robot.limits
        self.noise = noise or WheelNoise()
        self.radius = float(self.robot.footprint_radius)
        self.rng = rng if rng is not None else np.random.default_rng(0)
        # Anything at least ``obstacle_min_height`` tall blocks the robot's body.
        self._segments, self._circles = world.obstacles(obstacle_min_height)
        start = world.start if pose is None else np.asarray(pose, dtype=float)
        self._pose = np.array(start, dtype=float)
        if self._pose.shape != (3,) or not np.all(np.isfinite(self._pose)):
            raise ValueError(f"start pose must be a finite (x, y, theta), got {start!r}")
        if self.clearance() < self.radius:
            raise ValueError(f"start pose {tuple(self._pose)} puts the robot (radius {self.radius} m) "
                             f"inside an obstacle in world {world.name!r}")
        self._odom = self._pose.copy()
        self._scale = [float(v) for v in 1.0 + self.rng.normal(0.0, self.noise.scale_std, 2)]
        self._slip = [0.0, 0.0]
        self._wheel_angle = [0.0, 0.0]  # cumulative rotation (rad) of the left and right wheel
        self._normals: list[float] = []
        self._ticks = (0, 0)
        self._cmd = (0.0, 0.0)
        self._v = 0.0
        self._w = 0.0
        self.time = 0.0  # simulated seconds since creation
        self.bumped = False  # the last step ended against an obstacle

    # --- the hardware interface -------------------------------------------------------------
    def set_velocity(self, v: float, w: float) -> None:
        """Command linear ``v`` (m/s) and angular ``w`` (rad/s); clipped to the limits."""
        if not (math.isfinite(v) and math.isfinite(w)):
            raise ValueError(f"velocity command must be finite, got ({v}, {w})")
        lim = self.limits
        self._cmd = (min(max(v, -lim.v_max), lim.v_max), min(max(w, -lim.w_max), lim.w_max))
        self.bumped = False

    def ticks(self) -> tuple[int, int]:
        """Cumulative left and right encoder counts."""
        return self._ticks

    def step(self, dt: float) -> None:
        """Advance the simulation by ``dt`` seconds."""
        if not dt > 0:
            raise ValueError(f"dt must be positive, got {dt}")
        lim = self.limits
        self._v = _approach(self._v, 0.0 if self.bumped else self._cmd[0], lim.a_max * dt)
        self._w = _approach(self._w, 0.0 if self.bumped else self._cmd[1], lim.alpha_max * dt)
        self._update_slip(dt)
        half = 0.5 * self.geometry.wheel_base
        r = self.geometry.wheel_radius
        # wheel rotations (rad) commanded over dt, and how far each wheel moves over the floor
        rot_l = (self._v - half * self._w) * dt / r
        rot_r = (self._v + half * self._w) * dt / r
        fraction = self._move(rot_l * r * (self._scale[0] + self._slip[0]),
                              rot_r * r * (self._scale[1] + self._slip[1]))
        self._wheel_angle[0] += rot_l * fraction
        self._wheel_angle[1] += rot_r * fraction
        old = self._ticks
        tpr = self.geometry.ticks_per_rev
        self._ticks = (math.floor(self._wheel_angle[0] / (2 * math.pi) * tpr),
                       math.floor(self._wheel_angle[1] / (2 * math.pi) * tpr))
        dl, dr = self._ticks[0] - old[0], self._ticks[1] - old[1]
        if dl or dr:  # integrate_ticks, with the scalar compose of the physics loop
            self._odom = _compose(self._odom, ticks_to_increment(dl, dr, self.geometry))
        self.time += dt

    # --- state ------------------------------------------------------------------------------
    @property
    def true_pose(self) -> np.ndarray:
        """Ground-truth pose ``(x, y, theta)``."""
        return self._pose.copy()

    @property
    def odometry_pose(self) -> np.ndarray:
        """Pose integrated from the encoder ticks (starts at the true start pose).

        Equal to folding :func:`slam_core.sensors.wheel_odometry.integrate_ticks` over
        the tick increments of every :meth:`step`.
        """
        return self._odom.copy()

    @property
    def velocity(self) -> tuple[float, float]:
        """The wheels' current commanded-and-limited ``(v, w)``."""
        return self._v, self._w

    def clearance(self, pose=None) -> float:
        """Distance from the robot's centre to the nearest obstacle."""
        p = self._pose if pose is None else pose
        return float(_clearance(float(p[0]), float(p[1]), self._segments, self._circles))

    # --- internals --------------------------------------------------------------------------
    def _update_slip(self, dt: float) -> None:
        n = self.noise
        if n.slip_std <= 0:
            return
        if len(self._normals) < 2:
            self._normals = self.rng.normal(size=NOISE_BLOCK).tolist()
        decay = math.exp(-dt / n.slip_tau)
        gain = n.slip_std * math.sqrt(1.0 - decay * decay)
        self._slip = [decay * self._slip[0] + gain * self._normals.pop(),
                      decay * self._slip[1] + gain * self._normals.pop()]

    def _move(self, sl: float, sr: float) -> float:
        """Move by wheel ground distances ``sl``, ``sr``; returns the fraction achieved (0..1)."""
        max_step = 0.25 * self.radius
        n_sub = max(1, math.ceil(abs(0.5 * (sl + sr)) / max_step))
        base = self.geometry.wheel_base
        sl, sr = sl / n_sub, sr / n_sub
        for i in range(n_sub):
            nxt = _compose(self._pose, _arc(sl, sr, base))
            if self.clearance(nxt) >= self.radius:
                self._pose = nxt
                continue
            lo, hi = 0.0, 1.0  # bisect the sub-step for the contact point
            for _ in range(CONTACT_BISECTIONS):
                mid = 0.5 * (lo + hi)
                if self.clearance(_compose(self._pose, _arc(mid * sl, mid * sr, base))) >= self.radius:
                    lo = mid
                else:
                    hi = mid
            self._pose = _compose(self._pose, _arc(lo * sl, lo * sr, base))
            self.bumped = True
            self._v = self._w = 0.0
            return (i + lo) / n_sub
        return 1.0


def _arc(sl: float, sr: float, base: float) -> tuple[float, float, float]:
    """Robot-frame motion of a differential drive whose wheels roll ``sl`` and ``sr`` metres."""
    ds = 0.5 * (sl + sr)
    dth = (sr - sl) / base
    if abs(dth) < 1e-12:
        return ds, 0.0, 0.0
    rad = ds / dth
    return rad * math.sin(dth), rad * (1.0 - math.cos(dth)), dth


def _compose(a, b) -> np.ndarray:
    """``a ⊕ b`` for one pose (scalar math: this runs every physics sub-step)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    th = (a[2] + b[2] + math.pi) % (2.0 * math.pi) - math.pi
    return np.array([a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], th])


def _approach(value: float, target: float, max_change: float) -> float:
    return value + min(max(target - value, -max_change), max_change)
