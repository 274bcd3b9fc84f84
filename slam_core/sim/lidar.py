"""A simulated 360-degree 2D lidar (RPLidar-like) returning :class:`slam_core.scan.Scan`.

The lidar is the robot's laser (:class:`slam_core.robot_config.LaserSpec`): it sits at
the laser's mount on the robot and scans from there, in its own frame. Beams start at
``-pi`` and step ``2 pi / beams`` counter-clockwise. The true
range comes from exact ray casting against every obstacle taller than the
lidar's mounting height; Gaussian noise of ``range_noise_std`` is added; a beam
drops out (range 0, "no measurement", as RPLidars report) with probability
``dropout``; beams that hit nothing within ``range_max`` read exactly
``range_max`` (no return).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from slam_core.robot_config import LaserSpec, robot_from
from slam_core.scan import Scan, uniform_angles
from slam_core.sim.raycast import cast_rays
from slam_core.sim.world import World


@dataclass(frozen=True)
class LidarConfig:
    """The robot's ``laser`` and the simulated sensor's imperfections."""

    laser: LaserSpec
    range_noise_std: float = 0.01
    dropout: float = 0.01

    def __post_init__(self):
        if self.laser.beams < 1:
            raise ValueError("lidar needs at least one beam")
        if not 0 <= self.laser.range_min < self.laser.range_max:
            raise ValueError("need 0 <= range_min < range_max")
        if self.range_noise_std < 0 or not 0 <= self.dropout <= 1:
            raise ValueError("need range_noise_std >= 0 and 0 <= dropout <= 1")

    @property
    def angle_min(self) -> float:
        return -math.pi

    @property
    def increment(self) -> float:
        return 2 * math.pi / self.laser.beams


class Lidar:
    """``Lidar(world, config).scan(robot_pose, rng, timestamp)`` -> :class:`Scan` (default: the
    simulated robot's laser)."""

    def __init__(self, world: World, config: LidarConfig | None = None):
        self.config = config or LidarConfig(robot_from(None).laser)
        self.world = world
        laser = self.config.laser
        self.segments, self.circles = world.obstacles(laser.height)
        self.angles = uniform_angles(laser.beams, self.config.angle_min, self.config.increment)

    def true_ranges(self, robot_pose) -> np.ndarray:
        """Noise-free ranges from the laser of a robot at ``robot_pose`` (``range_max`` where
        nothing is hit)."""
        laser = self.config.laser
        pose = laser.mount.laser_poses(robot_pose)
        r = cast_rays(pose, self.angles, self.segments, self.circles, laser.range_max)
        return np.minimum(r, laser.range_max)

    def scan(self, robot_pose, rng: np.random.Generator, timestamp: float = 0.0) -> Scan:
        """One scan in the laser's frame from a robot at ``robot_pose``."""
        c, laser = self.config, self.config.laser
        r = self.true_ranges(robot_pose)
        hit = r < laser.range_max
        noisy = r + rng.normal(0.0, c.range_noise_std, r.shape) if c.range_noise_std > 0 else r.copy()
        noisy = np.where(hit, np.clip(noisy, 0.0, np.nextafter(laser.range_max, 0)), laser.range_max)
        noisy[noisy < laser.range_min] = 0.0
        if c.dropout > 0:
            noisy[rng.random(r.shape) < c.dropout] = 0.0
        return Scan(self.angles, noisy, laser.range_min, laser.range_max, timestamp)
