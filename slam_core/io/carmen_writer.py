"""Writing CARMEN log lines that :class:`slam_core.io.carmen.CarmenReader` reads back.

``ROBOTLASER1`` carries the scan's start angle, angular step and maximum range,
so any field of view (e.g. a 360-degree lidar) survives the round trip, unlike
``FLASER`` which assumes 180 degrees. Layout (CARMEN logger)::

    ROBOTLASER1 laser_type start_angle field_of_view angular_resolution maximum_range
      accuracy remission_mode num_readings [ranges] num_remissions [remissions]
      laser_x laser_y laser_theta robot_x robot_y robot_theta laser_tv laser_rv
      forward_safety_dist side_safety_dist turn_axis ipc_timestamp hostname logger_timestamp

    ODOM x y theta tv rv accel ipc_timestamp hostname logger_timestamp

Ranges are written with millimetre precision; beams that are not measurements
(``nan``, 0) are written as 0 and no-return beams as the maximum range.
"""

from __future__ import annotations

import numpy as np

from slam_core.scan import Scan

HOSTNAME = "homebot-sim"
#: Relative tolerance on the spacing of angles that ROBOTLASER1 can describe.
UNIFORM_TOLERANCE = 1e-6


def _pose_text(pose) -> str:
    return " ".join(f"{float(v):.6f}" for v in pose)


def robotlaser_line(scan: Scan, laser_pose, robot_pose, timestamp: float, tv: float = 0.0,
                    rv: float = 0.0, hostname: str = HOSTNAME) -> str:
    """One ``ROBOTLASER1`` line (with newline) for a scan with evenly spaced angles."""
    n = len(scan)
    if n < 2:
        raise ValueError("ROBOTLASER1 needs at least two beams")
    steps = np.diff(scan.angles)
    res = float(steps.mean())
    if np.max(np.abs(steps - res)) > UNIFORM_TOLERANCE * max(abs(res), 1e-9) + 1e-12:
        raise ValueError("ROBOTLASER1 needs evenly spaced angles (resample the scan first)")
    r = np.where(np.isfinite(scan.ranges), scan.ranges, 0.0)
    r = np.where(np.isposinf(scan.ranges) | (r >= scan.range_max), scan.range_max, r)
    r = np.where(scan.ranges < scan.range_min, 0.0, r)
    ranges = " ".join(f"{v:.3f}" for v in r)
    fov = res * n
    return (f"ROBOTLASER1 0 {scan.angles[0]:.9f} {fov:.6f} {res:.9f} {scan.range_max:.3f} 0.01 0 "
            f"{n} {ranges} 0 {_pose_text(laser_pose)} {_pose_text(robot_pose)} "
            f"{tv:.4f} {rv:.4f} 0.0 0.0 0.0 {timestamp:.6f} {hostname} {timestamp:.6f}\n")


def odom_line(pose, tv: float, rv: float, timestamp: float, hostname: str = HOSTNAME) -> str:
    """One ``ODOM`` line (with newline)."""
    return f"ODOM {_pose_text(pose)} {tv:.4f} {rv:.4f} 0.0 {timestamp:.6f} {hostname} {timestamp:.6f}\n"
