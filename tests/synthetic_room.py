"""A hand-made world for the SLAM tests: a room of wall segments, cast exactly."""

from __future__ import annotations

import numpy as np

from slam_core.scan import Scan

#: Segments ``(x0, y0, x1, y1)``: a 7 m x 5 m room with a pillar and a shelf.
ROOM = np.array([  # walls off the cell lattice, as real walls are
    [-3.013, -2.021, 4.007, -2.021], [4.007, -2.021, 4.007, 2.983], [4.007, 2.983, -3.013, 2.983],
    [-3.013, 2.983, -3.013, -2.021],
    [2.611, -1.588, 3.017, -1.588], [3.017, -1.588, 3.017, -1.189], [3.017, -1.189, 2.611, -1.189],
    [2.611, -1.189, 2.611, -1.588],
    [-2.0, 1.5, -0.5, 2.2],
])


def cast(pose, angles, segments=ROOM, max_range=30.0) -> np.ndarray:
    """Exact ranges from ``pose`` along ``angles`` (robot frame) to the nearest segment."""
    x, y, th = pose
    a = th + np.asarray(angles)
    dx, dy = np.cos(a)[:, None], np.sin(a)[:, None]
    x0, y0, x1, y1 = (segments[:, i][None, :] for i in range(4))
    ex, ey = x1 - x0, y1 - y0
    denom = dx * ey - dy * ex
    with np.errstate(divide="ignore", invalid="ignore"):
        t = ((x0 - x) * ey - (y0 - y) * ex) / denom
        u = ((x0 - x) * dy - (y0 - y) * dx) / denom
    hit = (np.abs(denom) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1)
    t = np.where(hit, t, np.inf)
    r = t.min(axis=1)
    return np.where(np.isfinite(r), r, max_range)


def room_scan(pose, n=180, noise=0.0, rng=None) -> Scan:
    angles = np.linspace(-np.pi, np.pi, n, endpoint=False)
    r = cast(pose, angles)
    if noise:
        r = r + rng.normal(0.0, noise, r.shape)
    return Scan(angles, r, 0.05, 30.0)
