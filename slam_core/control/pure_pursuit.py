"""Pure-pursuit path following along waypoints, with an obstacle stop.

The robot steers toward a *lookahead point* a distance ``L`` ahead of its
projection on the current leg (the straight line from the previous waypoint to
the next one). With the point at ``(lx, ly)`` in the robot frame the arc through
it has curvature ``kappa = 2 ly / (lx^2 + ly^2)`` (Coulter 1992, "Implementation
of the Pure Pursuit Path Tracking Algorithm"); the command is ``w = v kappa``.

Home rooms are tight, so the lookahead point never passes the current waypoint:
the robot follows each straight leg, reaches the waypoint within
``waypoint_tolerance``, turns on the spot when the next leg is more than
``turn_in_place`` radians off its heading, and only then drives on. Speed drops
with curvature (``v = v_max / (1 + curvature_gain |kappa|)``) and before sharp
turns and the goal (``v <= sqrt(2 decel d)``, so it can stop in the distance ``d``
left before the waypoint's tolerance). It stops within ``goal_tolerance`` of the last waypoint.

Obstacle stop: if any valid point of the latest scan (taken by the laser at
``laser_mount``) lies in the rectangle ahead of the robot, ``radius + stop_distance``
long and ``2 (radius + side_margin)`` wide, forward motion stops (turning on the spot stays allowed: the
robot is a disc) and :attr:`PurePursuit.blocked` is set.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from slam_core.geometry import transform_points
from slam_core.rbpf.laser_mount import LaserMount
from slam_core.robot_config import RobotConfig
from slam_core.scan import Scan

#: Smallest forward speed used while a leg is not finished (m/s), so slowing never stalls.
MIN_SPEED = 0.05


@dataclass(frozen=True)
class PursuitConfig:
    """The controller's gains and tolerances; ``robot_radius`` and ``laser_mount`` are the
    robot's (:meth:`for_robot`)."""

    robot_radius: float
    laser_mount: LaserMount
    lookahead: float = 0.35
    v_max: float = 0.4
    w_max: float = 1.2
    decel: float = 0.3
    turn_gain: float = 2.0
    turn_in_place: float = 0.6
    slow_turn_angle: float = 0.5
    curvature_gain: float = 0.5
    waypoint_tolerance: float = 0.12
    goal_tolerance: float = 0.08
    stop_distance: float = 0.25
    side_margin: float = 0.05

    @classmethod
    def for_robot(cls, robot: RobotConfig, **overrides) -> PursuitConfig:
        """The controller of ``robot``: its footprint and laser, speeds within its limits."""
        config = cls(robot.footprint_radius, robot.laser.mount, **overrides)
        return replace(config, v_max=min(config.v_max, robot.limits.v_max),
                       w_max=min(config.w_max, robot.limits.w_max))


class PurePursuit:
    """Follow ``waypoints`` ``(k, 2)``: call :meth:`command` with the pose (and scan) each cycle."""

    def __init__(self, waypoints, config: PursuitConfig):
        pts = np.asarray(waypoints, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) == 0 or not np.all(np.isfinite(pts)):
            raise ValueError(f"waypoints must be a finite (k, 2) array with k >= 1, got shape {pts.shape}")
        self.config = config
        self.waypoints = pts
        self.target = 0
        self._leg_start: np.ndarray | None = None
        self.done = False
        self.blocked = False

    def command(self, pose, scan: Scan | None = None) -> tuple[float, float]:
        """``(v, w)`` for the robot at ``pose``; ``scan`` (the laser's) enables the obstacle stop."""
        c = self.config
        pose = np.asarray(pose, dtype=float)
        if self._leg_start is None:
            self._leg_start = pose[:2].copy()
        if self.done:
            return 0.0, 0.0
        last = len(self.waypoints) - 1
        while True:
            goal = self.waypoints[self.target]
            dist = float(np.hypot(*(goal - pose[:2])))
            if self.target == last:
                if dist <= c.goal_tolerance:
                    self.done = True
                    self.blocked = False
                    return 0.0, 0.0
                break
            if dist > c.waypoint_tolerance:
                break
            self._leg_start = goal.copy()
            self.target += 1
        look = self._lookahead_point(pose[:2], self._leg_start, goal)
        c_th, s_th = math.cos(pose[2]), math.sin(pose[2])
        dx, dy = look[0] - pose[0], look[1] - pose[1]
        lx, ly = c_th * dx + s_th * dy, -s_th * dx + c_th * dy
        alpha = math.atan2(ly, lx)
        if abs(alpha) > c.turn_in_place:
            self.blocked = False
            return 0.0, _clip(c.turn_gain * alpha, c.w_max)
        kappa = 2.0 * ly / max(lx * lx + ly * ly, 1e-9)
        v = c.v_max / (1.0 + c.curvature_gain * abs(kappa))
        if self.target == last or self._turn_at(self.target) > c.slow_turn_angle:
            tol = c.goal_tolerance if self.target == last else c.waypoint_tolerance
            v = min(v, max(math.sqrt(2.0 * c.decel * max(dist - tol, 0.0)), MIN_SPEED))
        w = v * kappa
        if abs(w) > c.w_max:
            v *= c.w_max / abs(w)
            w = math.copysign(c.w_max, w)
        self.blocked = scan is not None and self.obstacle_ahead(scan)
        if self.blocked:
            return 0.0, 0.0
        return v, w

    def obstacle_ahead(self, scan: Scan) -> bool:
        """Whether a valid scan point lies in the stopping box ahead of the robot."""
        c = self.config
        pts = scan.points()
        if len(pts) == 0:
            return False
        if not c.laser_mount.centred:
            pts = transform_points(np.array(c.laser_mount.as_tuple()), pts)
        ahead = (pts[:, 0] > 0.0) & (pts[:, 0] < c.robot_radius + c.stop_distance)
        return bool(np.any(ahead & (np.abs(pts[:, 1]) < c.robot_radius + c.side_margin)))

    def _lookahead_point(self, xy, a, b) -> np.ndarray:
        seg = b - a
        length = float(np.hypot(*seg))
        if length < 1e-9:
            return b
        u = seg / length
        s = float(np.clip(np.dot(xy - a, u), 0.0, length))
        return a + u * min(s + self.config.lookahead, length)

    def _turn_at(self, i: int) -> float:
        """Heading change at waypoint ``i`` between its incoming and outgoing legs."""
        if i + 1 >= len(self.waypoints):
            return math.pi
        prev = self.waypoints[i - 1] if i > 0 else self._leg_start
        d1 = self.waypoints[i] - prev
        d2 = self.waypoints[i + 1] - self.waypoints[i]
        if np.hypot(*d1) < 1e-9 or np.hypot(*d2) < 1e-9:
            return 0.0
        return abs(math.atan2(d1[0] * d2[1] - d1[1] * d2[0], float(np.dot(d1, d2))))


def _clip(value: float, limit: float) -> float:
    return min(max(value, -limit), limit)
