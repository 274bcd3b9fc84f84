"""Which beams of a scan a sensor model scores, as endpoints in the sensor frame."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam_core.scan import Scan


@dataclass(frozen=True)
class BeamSelection:
    """Subsampled beams: bearings, ranges, and whether each is a no-return (max-range) reading."""

    angles: np.ndarray
    ranges: np.ndarray
    max_reading: np.ndarray
    range_max: float

    def __len__(self) -> int:
        return len(self.ranges)


def select_beams(scan: Scan, max_beams: int, usable_range: float | None = None) -> BeamSelection:
    """Up to ``max_beams`` beams evenly spaced over the scan (as AMCL's ``laser_max_beams``).

    Beams that are no measurement (nan, below ``range_min``) are dropped; readings
    at or above ``range_max`` (or beyond ``usable_range``) are flagged as max readings.
    """
    if max_beams < 1:
        raise ValueError(f"max_beams must be >= 1, got {max_beams}")
    n = len(scan)
    if n == 0:
        return BeamSelection(np.zeros(0), np.zeros(0), np.zeros(0, bool), scan.range_max)
    count = min(max_beams, n)
    pick = np.unique(np.round(np.linspace(0, n - 1, count)).astype(np.int64))
    r = scan.ranges[pick]
    a = scan.angles[pick]
    limit = scan.range_max if usable_range is None else min(scan.range_max, usable_range)
    measured = np.isfinite(r) & (r >= scan.range_min) & (r > 0.0) | (r == np.inf)
    r, a = r[measured], a[measured]
    max_reading = r >= limit
    return BeamSelection(np.ascontiguousarray(a), np.ascontiguousarray(np.minimum(r, limit)),
                         max_reading, float(limit))
