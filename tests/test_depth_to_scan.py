import math

import numpy as np
import pytest

from slam_core.scan import Scan
from slam_core.sensors.depth_to_scan import CameraIntrinsics, depth_to_scan, resample_uniform
from tests import naive_sim

K = CameraIntrinsics(width=5, height=7, fx=2.0, fy=2.0, cx=2.0, cy=3.0)


def test_flat_wall_hand_computed():
    """A wall 2 m ahead, perpendicular to the axis: z = 2 everywhere."""
    depth = np.full((7, 5), 2000, np.uint16)
    scan = depth_to_scan(depth, K, band_rows=1)
    # columns u = 4..0 (right to left): x = (u - 2) / 2 = 1, 0.5, 0, -0.5, -1
    x = np.array([1.0, 0.5, 0.0, -0.5, -1.0])
    assert np.allclose(scan.angles, -np.arctan(x))
    assert np.allclose(scan.angles, [-math.pi / 4, -math.atan(0.5), 0, math.atan(0.5), math.pi / 4])
    assert np.allclose(scan.ranges, 2.0 * np.sqrt(1 + x * x))
    # the endpoints lie on the wall x_robot = 2 (camera looks along +x of the robot)
    assert np.allclose(scan.points()[:, 0], 2.0)
    assert np.allclose(scan.points()[:, 1], -2.0 * x)  # image-right is robot-right (negative y)


def test_nearest_valid_depth_in_the_band_only():
    depth = np.full((7, 5), 3.0)
    depth[3, 2] = 1.0        # centre row, centre column: nearest
    depth[2, 1] = 0.0        # invalid inside the band: ignored
    depth[4, 1] = 2.5        # inside band (rows 2..4) wins over 3.0
    depth[0, 0] = 0.6        # outside the band (row 0): ignored
    depth[5, 3] = np.nan     # nan outside the band, harmless
    depth[:, 4] = 0.0        # a column with nothing valid -> nan
    depth[3, 3] = 4.8        # beyond range_max 4.5 -> ignored, the 3.0 rows remain
    scan = depth_to_scan(depth, K, band_rows=1)
    by_column = scan.ranges[::-1]  # back to u = 0..4
    sec = np.sqrt(1 + ((np.arange(5) - 2.0) / 2.0) ** 2)
    assert by_column[0] == pytest.approx(3.0 * sec[0])
    assert by_column[1] == pytest.approx(2.5 * sec[1])
    assert by_column[2] == pytest.approx(1.0)
    assert by_column[3] == pytest.approx(3.0 * sec[3])
    assert math.isnan(by_column[4])
    assert scan.valid.sum() == 4


def test_millimetres_and_metres_agree_and_zero_is_invalid():
    rng = np.random.default_rng(0)
    mm = rng.integers(0, 6000, (7, 5)).astype(np.uint16)
    a = depth_to_scan(mm, K, band_rows=2)
    b = depth_to_scan(mm.astype(float) / 1000.0, K, band_rows=2)
    assert np.allclose(a.ranges, b.ranges, equal_nan=True)


def test_matches_slow_reference_on_random_images():
    rng = np.random.default_rng(1)
    k = CameraIntrinsics.from_fov(32, 24, 57.0)
    for _ in range(5):
        img = rng.uniform(0.0, 6.0, (24, 32))
        img[rng.random(img.shape) < 0.3] = 0.0
        fast = depth_to_scan(img, k, band_rows=3)
        ang, rng_ref = naive_sim.depth_to_scan(img, k.fx, k.cx, k.cy, 3, 0.5, 4.5)
        assert np.allclose(fast.angles, ang)
        assert np.allclose(fast.ranges, rng_ref, equal_nan=True)


def test_kinect_intrinsics():
    k = CameraIntrinsics.from_fov(320, 240, 57.0)
    b = k.bearings()
    assert b[0] - b[-1] == pytest.approx(math.radians(57.0) * (319 / 320), rel=0.02)
    assert b[0] > 0 > b[-1]  # left edge of the image is positive (REP-103)


def test_errors():
    with pytest.raises(ValueError, match="intrinsics"):
        depth_to_scan(np.zeros((6, 5)), K)
    with pytest.raises(ValueError, match="2-D"):
        depth_to_scan(np.zeros(5), K)
    with pytest.raises(ValueError, match="millimetres"):
        depth_to_scan(np.zeros((7, 5), bool), K)


def test_resample_uniform_keeps_the_nearest_per_bin():
    angles = np.array([-0.5, -0.3, -0.05, 0.05, 0.5])
    ranges = np.array([1.0, 2.0, 3.0, 1.5, np.nan])
    s = resample_uniform(Scan(angles, ranges, 0.1, 5.0), beams=3)
    assert np.allclose(s.angles, [-0.5, 0.0, 0.5])
    # -0.3 rounds to bin 0 ((-0.3 + 0.5) / 0.5 = 0.4) -> min(1, 2); -0.05 and 0.05 to bin 1
    assert s.ranges[0] == 1.0 and s.ranges[1] == 1.5 and math.isnan(s.ranges[2])
