"""Whether a reference trajectory agrees with its own map, scan by scan.

The localization figures are scored against a reference (the SLAM trajectory of a shipped log,
the corrected poses of a stress log) in a map built from that reference. Where the reference
pose of a scan is not where its own map puts the scan (the map's other passes put it elsewhere,
or the reference slid along a corridor), a localizer that matches the map is "off" by that much
without being wrong. A scan's reference pose is *contradicted* when the best pose within
``window`` of it (correlative search, then refinement, :class:`ScanToMapMatcher`) lies more than
``offset`` away and explains at least ``gain`` more of the beams than the reference pose itself
(a reference a few centimetres off is not contradicted: its best pose is near).

:func:`settled_poses` is the other oracle: the pose the tracker's matcher settles on when it is
started at the reference pose itself. No localizer that matches scans against this map can be
expected to agree with the reference more often than these poses do.
"""

from __future__ import annotations

import numpy as np

from slam_core.localization.known_map import KnownMap
from slam_core.localization.scan_to_map import ScanToMapMatcher
from slam_core.localization.tracking import tracking_points
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.scan import Scan


def contradicted(grid: OccupancyGrid, scans: list[Scan], poses, window: float = 1.0,
                 offset: float = 0.3, gain: float = 0.1, beams: int = 180,
                 max_range: float = 30.0) -> np.ndarray:
    """Flags ``(n,)``: whether the map contradicts each reference pose ``poses[i]`` of ``scans[i]``."""
    matcher = ScanToMapMatcher(KnownMap(grid))
    out = np.zeros(len(scans), bool)
    for i, (scan, pose) in enumerate(zip(scans, np.asarray(poses, dtype=np.float64), strict=True)):
        points = tracking_points(scan, (0.0, 0.0, 0.0), beams, max_range)
        here = matcher.match(pose, points, iterations=0).fit
        best = matcher.search(pose, points, window, np.radians(5.0), np.radians(0.5))
        out[i] = (np.hypot(*(best.pose[:2] - pose[:2])) > offset and best.fit >= here + gain)
    return out


def settled_poses(grid: OccupancyGrid, scans: list[Scan], poses, beams: int = 180,
                  max_range: float = 30.0) -> np.ndarray:
    """``(n, 3)``: each scan matched against the map from its reference pose ``poses[i]``."""
    matcher = ScanToMapMatcher(KnownMap(grid))
    return np.array([matcher.match(pose, tracking_points(scan, (0.0, 0.0, 0.0), beams, max_range)).pose
                     for scan, pose in zip(scans, np.asarray(poses, dtype=np.float64), strict=True)]
                    ).reshape(-1, 3)
