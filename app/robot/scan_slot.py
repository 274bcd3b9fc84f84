"""The newest scan in shared memory: one writer (the simulator), readers that may be killed.

A queue's internal locks can be left held by a reader killed mid-``get`` (the
worker is restartable, and tests kill it), so scans cross the process boundary in a
seqlocked slot instead: ``float64`` header (write counter, scan count, timestamp,
beams, range_min, range_max), then the angles and ranges.
"""

from __future__ import annotations

import multiprocessing as mp
import time

import numpy as np

from slam_core.scan import Scan

MAX_BEAMS = 4096
_HEADER = 6
_WRITES, _COUNT, _STAMP, _BEAMS, _RMIN, _RMAX = range(_HEADER)
READ_RETRIES = 100


class ScanSlot:
    """Create with :meth:`create` in the parent; pass to both processes."""

    def __init__(self, array):
        self.array = array

    @classmethod
    def create(cls, ctx=None) -> ScanSlot:
        ctx = ctx or mp.get_context("spawn")
        return cls(ctx.RawArray("d", _HEADER + 2 * MAX_BEAMS))

    def _view(self) -> np.ndarray:
        return np.frombuffer(self.array, dtype=np.float64)

    def write(self, scan: Scan) -> None:
        n = len(scan)
        if n > MAX_BEAMS:
            raise ValueError(f"scan of {n} beams exceeds the slot's {MAX_BEAMS}")
        v = self._view()
        v[_WRITES] += 1
        v[_STAMP], v[_BEAMS], v[_RMIN], v[_RMAX] = scan.timestamp, n, scan.range_min, scan.range_max
        v[_HEADER:_HEADER + n] = scan.angles
        v[_HEADER + MAX_BEAMS:_HEADER + MAX_BEAMS + n] = scan.ranges
        v[_COUNT] += 1
        v[_WRITES] += 1

    @property
    def count(self) -> int:
        return int(self._view()[_COUNT])

    def read(self) -> tuple[int, Scan | None]:
        """``(count, scan)`` of the newest scan; ``(0, None)`` before the first."""
        v = self._view()
        for _ in range(READ_RETRIES):
            before = v[_WRITES]
            if int(before) % 2:
                time.sleep(0.0005)
                continue
            count, n = int(v[_COUNT]), int(v[_BEAMS])
            stamp, rmin, rmax = float(v[_STAMP]), float(v[_RMIN]), float(v[_RMAX])
            angles = v[_HEADER:_HEADER + n].copy()
            ranges = v[_HEADER + MAX_BEAMS:_HEADER + MAX_BEAMS + n].copy()
            if v[_WRITES] == before:
                if count == 0:
                    return 0, None
                return count, Scan(angles, ranges, rmin, rmax, stamp)
        return 0, None
