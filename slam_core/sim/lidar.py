"""A simulated 360-degree 2D lidar (RPLidar-like) returning :class:`slam_core.scan.Scan`.

Beams start at ``-pi`` and step ``2 pi / beams`` counter-clockwise. The true
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

from slam_core.scan import Scan, uniform_angles
from slam_core.sim.raycast import cast_rays
from slam_core.sim.world import World


@dataclass(frozen=True)
class LidarConfig:
    beams: int = 360
    range_min: float = 0.15
    range_max: float = 8.0
    range_noise_std: float = 0.01
    dropout: float = 0.01
    mount_height: float = 0.2

    def __post_init__(self):
        if self.beams < 1:
            raise ValueError("lidar needs at least one beam")
        if not 0 <= self.range_min < self.range_max:
            raise ValueError("need 0 <= range_min < range_max")
        if self.range_noise_std < 0 or not 0 <= self.dropout <= 1:
            raise ValueError("need range_noise_std >= 0 and 0 <= dropout <= 1")

    @property
    def angle_min(self) -> float:
        return -math.pi

    @property
    def increment(self) -> float:
        return 2 * math.pi / self.beams


class Lidar:
    """``Lidar(world, config).scan(pose, rng, timestamp)`` -> :class:`Scan`."""

    def __init__(self, world: World, config: LidarConfig | None = None):
        self.config = config or LidarConfig()
        self.world = world
        self.segments, self.circles = world.obstacles(self.config.mount_height)
        self.angles = uniform_angles(self.config.beams, self.config.angle_min, self.config.increment)

    def true_ranges(self, pose) -> np.ndarray:
        """Noise-free ranges (``range_max`` where nothing is hit)."""
        c = self.config
        r = cast_rays(pose, self.angles, self.segments, self.circles, c.range_max)
        return np.minimum(r, c.range_max)

    def scan(self, pose, rng: np.random.Generator, timestamp: float = 0.0) -> Scan:
        c = self.config
        r = self.true_ranges(pose)
        hit = r < c.range_max
        noisy = r + rng.normal(0.0, c.range_noise_std, r.shape) if c.range_noise_std > 0 else r.copy()
        noisy = np.where(hit, np.clip(noisy, 0.0, np.nextafter(c.range_max, 0)), c.range_max)
        noisy[noisy < c.range_min] = 0.0
        if c.dropout > 0:
            noisy[rng.random(r.shape) < c.dropout] = 0.0
        return Scan(self.angles, noisy, c.range_min, c.range_max, timestamp)
