"""The depth grabber's core: a depth image to a 2D :class:`~slam_core.scan.Scan`.

Real and simulated depth cameras go through the same function. The image is
``depth[v, u]`` (row ``v`` down, column ``u`` right) of z-depths along the
optical axis: ``uint16`` millimetres (Kinect / OpenNI convention, 0 = invalid)
or floating-point metres (0 or nan = invalid).

For every column the nearest valid z over a band of rows around the optical
centre ``cy`` becomes one beam (like ROS ``depthimage_to_laserscan``). With the
pinhole model, column ``u`` looks along ``x = (u - cx) / fx`` (right-positive in
the image), so its bearing is ``angle = -atan((u - cx) / fx)`` (REP-103: positive
to the left) and a z-depth ``z`` lies ``z * sqrt(1 + x^2)`` away in the scan
plane. Columns are emitted from right to left so that angles increase. A
column with no valid depth in the band gives ``nan`` (no measurement: a Kinect
cannot tell "too near" from "too far").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from slam_core.jit import njit
from slam_core.scan import Scan

#: Kinect v1 working range of z-depth, metres.
KINECT_RANGE_MIN = 0.5
KINECT_RANGE_MAX = 4.5
#: Half-height (rows) of the band around the optical centre used for the scan.
DEFAULT_BAND_ROWS = 4
MILLIMETRES = 0.001


@dataclass(frozen=True)
class CameraIntrinsics:
    """Pinhole intrinsics in pixels (``fx``, ``fy`` focal lengths, ``cx``, ``cy`` principal point)."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    def __post_init__(self):
        if self.width < 1 or self.height < 1 or not (self.fx > 0 and self.fy > 0):
            raise ValueError(f"bad intrinsics {self}: need positive size and focal lengths")

    @classmethod
    def from_fov(cls, width: int, height: int, hfov_deg: float = 57.0) -> CameraIntrinsics:
        """Square pixels, principal point in the image centre, the given horizontal field of view."""
        fx = 0.5 * width / math.tan(math.radians(hfov_deg) / 2)
        return cls(width, height, fx, fx, (width - 1) / 2, (height - 1) / 2)

    def bearings(self) -> np.ndarray:
        """Bearing of every column ``u`` (positive to the left)."""
        return -np.arctan((np.arange(self.width) - self.cx) / self.fx)


@njit
def _depth_to_scan(depth, row0, row1, fx, cx, zmin, zmax, angles, ranges):
    width = depth.shape[1]
    for u in range(width):
        best = np.inf
        for v in range(row0, row1):
            z = depth[v, u]
            if z >= zmin and z <= zmax and z < best:  # nan compares False
                best = z
        x = (u - cx) / fx
        k = width - 1 - u
        angles[k] = -np.arctan(x)
        ranges[k] = best * np.sqrt(1.0 + x * x) if best < np.inf else np.nan


def depth_to_scan(depth, intrinsics: CameraIntrinsics, band_rows: int = DEFAULT_BAND_ROWS,
                  range_min: float = KINECT_RANGE_MIN, range_max: float = KINECT_RANGE_MAX,
                  timestamp: float = 0.0) -> Scan:
    """One beam per column from the nearest valid depth in rows ``cy ± band_rows``.

    ``depth`` is ``uint16`` millimetres or float metres (see the module docstring);
    ``range_min`` / ``range_max`` bound the accepted z-depth in metres. The scan's
    ``range_max`` is the longest in-range beam (the corner columns' slant range).
    """
    depth = np.asarray(depth)
    if depth.ndim != 2:
        raise ValueError(f"depth image must be 2-D (rows, columns), got shape {depth.shape}")
    if depth.shape != (intrinsics.height, intrinsics.width):
        raise ValueError(f"depth image is {depth.shape[1]}x{depth.shape[0]} (w x h) but the intrinsics "
                         f"say {intrinsics.width}x{intrinsics.height}")
    if np.issubdtype(depth.dtype, np.integer):
        metres = depth.astype(np.float64) * MILLIMETRES
    elif np.issubdtype(depth.dtype, np.floating):
        metres = depth.astype(np.float64)
    else:
        raise ValueError(f"depth image must be integer millimetres or float metres, got {depth.dtype}")
    if band_rows < 0:
        raise ValueError("band_rows must be >= 0")
    if not 0 < range_min < range_max:
        raise ValueError(f"need 0 < range_min < range_max, got {range_min}, {range_max}")
    row0 = max(0, math.ceil(intrinsics.cy - band_rows))
    row1 = min(intrinsics.height, math.floor(intrinsics.cy + band_rows) + 1)
    angles = np.empty(intrinsics.width)
    ranges = np.empty(intrinsics.width)
    _depth_to_scan(np.ascontiguousarray(metres), row0, row1, intrinsics.fx, intrinsics.cx,
                   range_min, range_max, angles, ranges)
    widest = max(abs(-intrinsics.cx), abs(intrinsics.width - 1 - intrinsics.cx)) / intrinsics.fx
    scan_max = np.nextafter(range_max * math.sqrt(1.0 + widest * widest), np.inf)
    return Scan(angles, ranges, float(range_min), float(scan_max), timestamp)


def resample_uniform(scan: Scan, beams: int | None = None) -> Scan:
    """The scan on evenly spaced bearings from its first to its last angle (nearest range per bin).

    Depth-camera beams are spaced by ``atan``, not evenly; log formats such as
    CARMEN ``ROBOTLASER1`` need a start angle and a fixed step. Each beam goes to
    the nearest output bearing; a bearing keeps its nearest valid range, or
    ``nan`` if none falls on it.
    """
    n = len(scan) if beams is None else int(beams)
    if n < 2 or len(scan) < 2:
        raise ValueError("need at least two beams to resample")
    a0, a1 = float(scan.angles[0]), float(scan.angles[-1])
    if not a1 > a0:
        raise ValueError("scan angles must increase to resample")
    out_angles = np.linspace(a0, a1, n)
    step = (a1 - a0) / (n - 1)
    out = np.full(n, np.inf)
    valid = scan.valid
    idx = np.clip(np.rint((scan.angles[valid] - a0) / step).astype(np.int64), 0, n - 1)
    np.minimum.at(out, idx, scan.ranges[valid])
    out[np.isinf(out)] = np.nan
    return Scan(out_angles, out, scan.range_min, scan.range_max, scan.timestamp)
