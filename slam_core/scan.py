"""The one 2D range-scan type shared by log readers, simulated and real sensors."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Scan:
    """A planar range scan in the sensor frame.

    ``angles`` are beam bearings in radians (counter-clockwise, 0 straight ahead),
    ``ranges`` in metres. A range ``>= range_max`` (or ``inf``) means the beam saw
    nothing; a range ``< range_min`` (or ``nan``) is not a measurement at all.
    """

    angles: np.ndarray
    ranges: np.ndarray
    range_min: float
    range_max: float
    timestamp: float = 0.0

    def __post_init__(self):
        angles = np.ascontiguousarray(self.angles, dtype=np.float64)
        ranges = np.ascontiguousarray(self.ranges, dtype=np.float64)
        if angles.shape != ranges.shape or angles.ndim != 1:
            raise ValueError(f"angles {angles.shape} and ranges {ranges.shape} must be equal 1-D")
        if not 0.0 <= self.range_min < self.range_max:
            raise ValueError(f"need 0 <= range_min < range_max, got {self.range_min}, {self.range_max}")
        object.__setattr__(self, "angles", angles)
        object.__setattr__(self, "ranges", ranges)

    def __len__(self) -> int:
        return len(self.ranges)

    @property
    def valid(self) -> np.ndarray:
        """Mask of beams that returned an echo inside the sensor's limits."""
        r = self.ranges
        return np.isfinite(r) & (r >= self.range_min) & (r < self.range_max) & (r > 0.0)

    def points(self) -> np.ndarray:
        """Endpoints ``(n, 2)`` of the valid beams, in the sensor frame."""
        v = self.valid
        r, a = self.ranges[v], self.angles[v]
        return np.column_stack([r * np.cos(a), r * np.sin(a)])


def uniform_angles(n: int, angle_min: float, increment: float) -> np.ndarray:
    """Bearings ``angle_min + i * increment`` for ``i < n``."""
    return angle_min + increment * np.arange(n, dtype=np.float64)
