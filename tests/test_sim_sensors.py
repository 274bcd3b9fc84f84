import dataclasses
import math

import numpy as np
import pytest

from slam_core.robot_config import robot_from
from slam_core.sensors.depth_to_scan import depth_to_scan
from slam_core.sim.depth_camera import DepthCamera, DepthCameraConfig, kinect_depth_sigma
from slam_core.sim.lidar import Lidar, LidarConfig
from slam_core.sim.raycast import cast_rays
from slam_core.sim.world import parse_world

# a long room: 2 m to the east wall from the robot at (1, 2), a low box and a tall post
ROOM = parse_world("start 1 2 0\nroom r 0 0 12 4\n", source="room")
LASER = robot_from(None).laser


def _laser(**changes):
    return dataclasses.replace(LASER, **changes)


def test_lidar_geometry_and_no_returns():
    w = parse_world("start 1 2 0\nwall 3 -10 3 10\n", source="wall")
    lidar = Lidar(w, LidarConfig(_laser(beams=8, range_max=5.0), range_noise_std=0.0, dropout=0.0))
    s = lidar.scan([1, 2, 0], np.random.default_rng(0))
    assert np.allclose(s.angles, -np.pi + np.arange(8) * np.pi / 4)
    # beam 4 is straight ahead (2 m), beams 3 and 5 at +-45 deg (2 sqrt 2); the rest see nothing
    assert s.ranges[4] == pytest.approx(2.0)
    assert s.ranges[3] == pytest.approx(2 * math.sqrt(2)) and s.ranges[5] == pytest.approx(2 * math.sqrt(2))
    assert np.all(s.ranges[[0, 1, 2, 6, 7]] == 5.0) and s.valid.sum() == 3


def test_lidar_noise_and_dropout_statistics():
    cfg = LidarConfig(_laser(beams=720, range_max=20.0), range_noise_std=0.02, dropout=0.1)
    lidar = Lidar(ROOM, cfg)
    rng = np.random.default_rng(5)
    truth = lidar.true_ranges([1.0, 2.0, 0.3])
    scans = np.array([lidar.scan([1.0, 2.0, 0.3], rng).ranges for _ in range(40)])
    dropped = scans == 0.0
    assert dropped.mean() == pytest.approx(0.1, abs=0.01)
    err = (scans - truth)[~dropped]
    assert abs(err.mean()) < 0.002
    assert err.std() == pytest.approx(0.02, rel=0.05)


def test_lidar_sees_only_what_reaches_its_height():
    w = parse_world("start 1 2 0\nroom r 0 0 6 4\nfurniture low 0.1 3 1.5 3.5 1.5 3.5 2.5 3 2.5\n"
                    "leg 2 2 0.05 0.5\n", source="w")
    cfg = LidarConfig(_laser(beams=4, height=0.2), range_noise_std=0.0, dropout=0.0)
    s = Lidar(w, cfg).scan([1, 2, np.pi], np.random.default_rng(0))
    # facing west (pi), beam index 2 (bearing 0) sees the west wall 1 m away; beam 0 (bearing -pi)
    # looks east: the 0.5 m leg at x = 2 (radius 0.05) is hit, the 0.1 m box behind it would not be
    assert s.ranges[2] == pytest.approx(1.0) and s.ranges[0] == pytest.approx(0.95)
    s2 = Lidar(w, cfg).scan([2.6, 2, 0], np.random.default_rng(0))
    assert s2.ranges[2] == pytest.approx(6.0 - 2.6)  # looks over the low box to the east wall


def test_depth_camera_sees_a_wall_at_the_right_depth_and_floor_below():
    cam = DepthCamera(ROOM, DepthCameraConfig(noise=False, dropout=0.0))
    k = cam.intrinsics
    z = cam.true_depth([10.0, 2.0, 0.0])  # east wall 2 m ahead
    centre_rows = np.abs(np.arange(k.height) - k.cy) < 5
    assert np.allclose(z[centre_rows], 2.0)  # z-depth of a perpendicular wall is constant
    # bottom row: the ray falls mount_height over cam_h / slope of z, so it sees the floor
    slope = (k.height - 1 - k.cy) / k.fy
    assert z[-1, 0] == pytest.approx(0.3 / slope)
    img = cam.render([10.0, 2.0, 0.0])
    assert img.dtype == np.uint16 and img[int(k.cy), 0] == 2000


def test_depth_camera_range_limits_and_noise_grow_with_distance():
    cam = DepthCamera(ROOM, DepthCameraConfig(dropout=0.0))
    far = cam.render([1.0, 2.0, 0.0], np.random.default_rng(0))  # east wall 11 m away
    k = cam.intrinsics
    # central columns look 11 m down the room: beyond 4.5 m reads 0; the side walls
    # (2 m away sideways) come into view within range at the image edges
    centre = slice(int(k.cx) - 20, int(k.cx) + 21)
    assert np.all(far[int(k.cy) - 3:int(k.cy) + 4, centre] == 0)
    assert np.all(far[int(k.cy), :5] > 0)
    near, farther = [], []
    rng = np.random.default_rng(1)
    for _ in range(20):
        near.append(cam.render([10.5, 2.0, 0.0], rng)[int(k.cy), :].astype(float) / 1000)
        farther.append(cam.render([8.0, 2.0, 0.0], rng)[int(k.cy), :].astype(float) / 1000)
    s_near = np.std(np.array(near), axis=0).mean()
    s_far = np.std(np.array(farther), axis=0).mean()
    assert s_far > 3 * s_near
    assert s_far == pytest.approx(kinect_depth_sigma(4.0), rel=0.3)


@pytest.mark.parametrize("pose, min_valid", [([9.0, 1.5, 0.2], 0.9), ([1.0, 2.0, 0.0], 0.1)])
def test_depth_grabber_on_simulated_image_matches_ray_casting(pose, min_valid):
    """The band around the optical centre sees walls, never the floor or ceiling (even down a long room)."""
    cam = DepthCamera(ROOM, DepthCameraConfig(noise=False, dropout=0.0))
    scan = depth_to_scan(cam.render(pose), cam.intrinsics)
    truth = cast_rays(pose, scan.angles, *ROOM.obstacles())
    ok = scan.valid
    assert min_valid * len(scan) < ok.sum()
    assert np.allclose(scan.ranges[ok], truth[ok], atol=0.002)  # mm quantisation
    # nothing valid where the wall is beyond 4.5 m of z-depth
    assert not np.any(ok & (truth * np.cos(scan.angles) > 4.5 + 1e-3))
