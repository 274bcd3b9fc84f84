"""A simulated Kinect-like depth camera looking forward from the robot.

Output: ``uint16`` **millimetres** of z-depth, ``depth[v, u]`` (row 0 at the
top), 0 where there is no valid measurement, like OpenNI / libfreenect. The
default is 160 x 120 pixels with a 57 degree horizontal field of view (square
pixels, so about 44 degrees vertically), valid z-depth 0.5-4.5 m.

Rendering is exact against the world's vertical prisms: each column casts one
horizontal ray and gets its nearest hits with their heights
(:func:`slam_core.sim.raycast.cast_hits`); pixel row ``v`` descends with slope
``(v - cy) / fy`` per metre of z-depth from the camera's mounting height, so it
sees the first object it passes *below the top of*, or the floor (z = 0) or the
ceiling if it reaches them first. Low furniture therefore shows in the lower
rows only, and the floor fills the bottom of the image within range.

Noise follows the Kinect's axial model (Nguyen, Izadi & Lovell 2012):
``sigma(z) = 0.0012 + 0.0019 (z - 0.4)^2`` metres, then quantised to millimetres;
a pixel also drops out (0) with probability ``dropout``. Depths outside
``[range_min, range_max]`` read 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam_core.jit import njit
from slam_core.sensors.depth_to_scan import KINECT_RANGE_MAX, KINECT_RANGE_MIN, CameraIntrinsics
from slam_core.sim.raycast import cast_hits
from slam_core.sim.world import World

#: Hits kept per column (enough to look past low furniture and legs).
HITS_PER_COLUMN = 8


def kinect_depth_sigma(z):
    """Axial depth noise (m) of a Kinect v1 at z-depth ``z`` (Nguyen et al. 2012)."""
    z = np.asarray(z, dtype=float)
    return 0.0012 + 0.0019 * (z - 0.4) ** 2


@dataclass(frozen=True)
class DepthCameraConfig:
    width: int = 160
    height: int = 120
    hfov_deg: float = 57.0
    range_min: float = KINECT_RANGE_MIN
    range_max: float = KINECT_RANGE_MAX
    mount_height: float = 0.3
    noise: bool = True
    dropout: float = 0.005

    def intrinsics(self) -> CameraIntrinsics:
        return CameraIntrinsics.from_fov(self.width, self.height, self.hfov_deg)


@njit
def _render(t, h, n, cos_b, slopes, cam_h, ceiling, reach, out):
    """z-depth (m) of every pixel; ``inf`` where nothing is seen within ``reach`` (horizontal m)."""
    rows = slopes.shape[0]
    for u in range(t.shape[0]):
        for v in range(rows):
            s = slopes[v]
            if s > 0.0:
                limit = cam_h / s  # z-depth where the pixel's ray reaches the floor
            elif s < 0.0:
                limit = (ceiling - cam_h) / -s
            else:
                limit = np.inf
            z_seen = limit if limit < reach * cos_b[u] else np.inf
            for i in range(n[u]):
                z = t[u, i] * cos_b[u]
                if z >= limit:
                    break
                if cam_h - s * z <= h[u, i]:
                    z_seen = z
                    break
            out[v, u] = z_seen


class DepthCamera:
    """``DepthCamera(world, config).render(pose, rng)`` -> ``uint16`` millimetre image."""

    def __init__(self, world: World, config: DepthCameraConfig | None = None):
        self.world = world
        self.config = config or DepthCameraConfig()
        self.intrinsics = self.config.intrinsics()
        self.bearings = self.intrinsics.bearings()
        k = self.intrinsics
        self._slopes = (np.arange(k.height) - k.cy) / k.fy
        self._cos = np.cos(self.bearings)

    def true_depth(self, pose) -> np.ndarray:
        """Noise-free z-depth in metres (float), ``inf`` where nothing is seen."""
        w, c = self.world, self.config
        reach = c.range_max / np.min(self._cos) + 1.0
        t, h, n = cast_hits(pose, self.bearings, w.segments, w.segment_heights, w.circles,
                            w.circle_heights, reach, HITS_PER_COLUMN)
        out = np.empty((self.intrinsics.height, self.intrinsics.width))
        _render(t, h, n, self._cos, self._slopes, c.mount_height, w.ceiling, reach, out)
        return out

    def render(self, pose, rng: np.random.Generator | None = None) -> np.ndarray:
        """A ``uint16`` depth image in millimetres (0 = invalid); noise-free if ``rng`` is None."""
        c = self.config
        z = self.true_depth(pose)
        if rng is not None and c.noise:
            finite = np.isfinite(z)
            z[finite] += rng.normal(size=int(finite.sum())) * kinect_depth_sigma(z[finite])
        bad = ~((z >= c.range_min) & (z <= c.range_max))
        if rng is not None and c.dropout > 0:
            bad |= rng.random(z.shape) < c.dropout
        mm = np.where(bad, 0.0, np.rint(np.where(bad, 0.0, z) * 1000.0))
        return mm.astype(np.uint16)
