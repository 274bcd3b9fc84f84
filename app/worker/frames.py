"""The robot's frames as in ROS REP-105 (and slam_toolbox): ``map -> odom -> base_link``.

The odometry (``odom -> base_link``) is continuous but drifts; the estimator's pose
(``map -> base_link``) is right but comes once per SLAM step. The worker publishes the
correction between the two, ``map_T_odom = pose ∘ odometry⁻¹``, against the odometry its step
used; whoever needs the pose composes that correction with the newest odometry, at its own rate,
so the pose moves at odometry rate between steps and follows a loop closure at once.
All poses are ``(x, y, theta)`` in metres and radians.
"""

from __future__ import annotations

import numpy as np

from slam_core.geometry import compose, inverse


def map_to_odom(pose, odometry) -> np.ndarray:
    """The correction ``map_T_odom`` that takes ``odometry`` (odom frame) to ``pose`` (map frame)."""
    return compose(np.asarray(pose, float), inverse(np.asarray(odometry, float)))


def pose_in_map(correction, odometry) -> np.ndarray:
    """The robot's pose in the map frame: ``map_T_odom ∘ odometry``."""
    return compose(np.asarray(correction, float), np.asarray(odometry, float))
