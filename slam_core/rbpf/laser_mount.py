"""Where the laser sits on the robot: a fixed pose in the robot frame (base_link).

The estimators match and draw scans at the laser's pose, and report the robot's;
this type moves poses between the two frames. A mount of ``(0, 0, 0)`` (the laser at
the robot's centre, facing forward) leaves poses untouched, bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam_core.geometry import compose, inverse

#: The farthest a laser may sit from the robot's centre (m); a mount beyond it is a mistake.
MAX_OFFSET_M = 10.0


@dataclass(frozen=True)
class LaserMount:
    """The laser's pose ``(x, y, theta)`` in the robot frame (metres, radians)."""

    x: float = 0.0
    y: float = 0.0
    theta: float = 0.0

    def __post_init__(self):
        if not np.isfinite([self.x, self.y, self.theta]).all():
            raise ValueError(f"laser mount must be finite, got {self.as_tuple()}")
        if max(abs(self.x), abs(self.y)) > MAX_OFFSET_M:
            raise ValueError(f"laser mount ({self.x:g}, {self.y:g}) is more than {MAX_OFFSET_M:g} m "
                             "from the robot's centre")

    @classmethod
    def of(cls, value) -> LaserMount:
        """A mount from a ``LaserMount`` or any ``(x, y, theta)`` sequence (``None``: centred)."""
        if value is None:
            return cls()
        if isinstance(value, LaserMount):
            return value
        numbers = np.asarray(value, dtype=float).reshape(-1)
        if numbers.shape != (3,):
            raise ValueError(f"laser mount must be (x, y, theta), got {value!r}")
        return cls(*(float(v) for v in numbers))

    def as_tuple(self) -> tuple[float, float, float]:
        return (self.x, self.y, self.theta)

    @property
    def centred(self) -> bool:
        return self.x == 0.0 and self.y == 0.0 and self.theta == 0.0

    def laser_poses(self, robot_poses) -> np.ndarray:
        """The laser's pose(s) for robot pose(s) ``(..., 3)``."""
        robot_poses = np.asarray(robot_poses, dtype=float)
        return robot_poses if self.centred else compose(robot_poses, np.array(self.as_tuple()))

    def robot_poses(self, laser_poses) -> np.ndarray:
        """The robot's pose(s) for laser pose(s) ``(..., 3)``."""
        laser_poses = np.asarray(laser_poses, dtype=float)
        return laser_poses if self.centred else compose(laser_poses, inverse(np.array(self.as_tuple())))
