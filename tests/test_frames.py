"""map -> odom (REP-105): the correction and its composition, against homogeneous matrices as the oracle."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from app.worker.frames import map_to_odom, pose_in_map

coordinate = st.floats(-50.0, 50.0, allow_nan=False)
angle = st.floats(-3 * math.pi, 3 * math.pi, allow_nan=False)
poses = st.tuples(coordinate, coordinate, angle)


def matrix(pose) -> np.ndarray:
    x, y, theta = pose
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s, x], [s, c, y], [0.0, 0.0, 1.0]])


def same_pose(pose, m: np.ndarray) -> bool:
    """Whether ``pose`` is the rigid transform ``m`` (angles compared on the circle)."""
    heading = math.atan2(m[1, 0], m[0, 0])
    turn = math.remainder(float(pose[2]) - heading, 2 * math.pi)
    return np.allclose(pose[:2], m[:2, 2], atol=1e-9) and abs(turn) < 1e-9 and -math.pi <= pose[2] < math.pi


@settings(max_examples=300, deadline=None)
@given(pose=poses, odometry=poses, motion=poses)
def test_the_correction_composed_with_newer_odometry_is_the_pose_moved_by_that_motion(pose, odometry, motion):
    correction = map_to_odom(pose, odometry)
    assert same_pose(correction, matrix(pose) @ np.linalg.inv(matrix(odometry)))
    assert same_pose(pose_in_map(correction, odometry), matrix(pose))
    newer = matrix(odometry) @ matrix(motion)  # the robot moved on by ``motion`` in its own frame
    newer_odometry = (newer[0, 2], newer[1, 2], math.atan2(newer[1, 0], newer[0, 0]))
    assert same_pose(pose_in_map(correction, newer_odometry), matrix(pose) @ matrix(motion))


def test_a_known_case_by_hand():
    # odometry says (1, 0) facing +x; the map says (0, 2) facing +y: the odom frame is turned by 90°
    correction = map_to_odom((0.0, 2.0, math.pi / 2), (1.0, 0.0, 0.0))
    assert np.allclose(correction, (0.0, 1.0, math.pi / 2))
    # one more metre straight ahead in odometry is one metre up in the map
    assert np.allclose(pose_in_map(correction, (2.0, 0.0, 0.0)), (0.0, 3.0, math.pi / 2))
