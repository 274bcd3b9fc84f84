"""Motion and observation models of the landmark EKF, with their Jacobians.

Motion (Thrun, Burgard & Fox, *Probabilistic Robotics*, ch. 10.2, written as a
pose composition): the robot pose ``p = (x, y, θ)`` is moved by the odometry
increment ``u = (dx, dy, dθ)`` measured in the robot frame, ``p' = p ⊕ u``.
The increment's covariance comes from the odometry motion model of
:mod:`slam_core.motion_model` (noise on ``rot1, trans, rot2``) pushed through
``u = (trans cos rot1, trans sin rot1, rot1 + rot2)``.

Observation: a landmark ``l = (lx, ly)`` is seen at range and bearing
``h(p, l) = (|l - (x, y)|, atan2(ly - y, lx - x) - θ)``; its inverse ``g(p, z)``
places a new landmark (ch. 10.2, eq. 10.12 / table 10.1).

Lines (wall segments): a world line ``l = (ρ, α)`` is the set ``{p : p·n(α) = ρ}``
with ``n(α) = (cos α, sin α)``. Seen from the pose it is
``ρ_r = ρ - x cos α - y sin α``, ``α_r = α - θ`` (Arras & Siegwart 1997;
Garulli et al. 2005). Scans give lines with ``ρ_r >= 0`` (the normal points
away from the sensor), so :func:`observe_line` reports that form: when the
robot is on the far side (``ρ_r < 0``) it returns ``(-ρ_r, α_r + π)`` and the
``ρ`` row of the Jacobians changes sign. The world ``ρ`` may be negative.
A line's ``ρ`` is measured from a fixed anchor point ``a`` (the robot's position
when the line was first mapped), ``{p : (p - a)·n(α) = ρ}``: from the world origin
the lever ``|p|`` of a line far away would turn a small angle error into a large
second-order error in ``ρ`` (and ill-condition the covariance).
"""

from __future__ import annotations

import numpy as np

from slam_core.geometry import wrap_angle
from slam_core.motion_model import OdometryMotionModel, decompose, noise_stds


def motion(pose, u) -> np.ndarray:
    """``pose ⊕ u`` for one pose and one robot-frame increment."""
    x, y, th = pose
    c, s = np.cos(th), np.sin(th)
    return np.array([x + c * u[0] - s * u[1], y + s * u[0] + c * u[1], float(wrap_angle(th + u[2]))])


def motion_jacobians(pose, u) -> tuple[np.ndarray, np.ndarray]:
    """``(F, G)``: derivatives of ``pose ⊕ u`` by the pose and by the increment."""
    th = pose[2]
    c, s = np.cos(th), np.sin(th)
    f = np.array([[1.0, 0.0, -s * u[0] - c * u[1]],
                  [0.0, 1.0, c * u[0] - s * u[1]],
                  [0.0, 0.0, 1.0]])
    g = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return f, g


def odometry_increment(odom0, odom1, model: OdometryMotionModel) -> tuple[np.ndarray, np.ndarray]:
    """The robot-frame increment ``u`` from odometry pose ``odom0`` to ``odom1`` and its covariance."""
    o0 = np.asarray(odom0, dtype=float)
    o1 = np.asarray(odom1, dtype=float)
    rot1, trans, rot2 = decompose(o0[0], o0[1], o0[2], o1[0], o1[1], o1[2])
    s1, st, s2 = noise_stds(rot1, trans, rot2, model.alpha1, model.alpha2, model.alpha3, model.alpha4)
    c, s = np.cos(rot1), np.sin(rot1)
    u = np.array([trans * c, trans * s, rot1 + rot2])
    j = np.array([[-trans * s, c, 0.0], [trans * c, s, 0.0], [1.0, 0.0, 1.0]])
    return u, j @ np.diag([s1 * s1, st * st, s2 * s2]) @ j.T


def observe(pose, landmark) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(z, H_pose, H_landmark)``: expected range-bearing of one landmark and its Jacobians."""
    dx = landmark[0] - pose[0]
    dy = landmark[1] - pose[1]
    q = dx * dx + dy * dy
    r = np.sqrt(q)
    z = np.array([r, float(wrap_angle(np.arctan2(dy, dx) - pose[2]))])
    h_pose = np.array([[-dx / r, -dy / r, 0.0], [dy / q, -dx / q, -1.0]])
    h_lm = np.array([[dx / r, dy / r], [-dy / q, dx / q]])
    return z, h_pose, h_lm


def observe_many(pose, landmarks) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`observe` for ``(k, 2)`` landmarks: ``z (k, 2)``, ``H_pose (k, 2, 3)``, ``H_lm (k, 2, 2)``."""
    dx = landmarks[:, 0] - pose[0]
    dy = landmarks[:, 1] - pose[1]
    q = np.maximum(dx * dx + dy * dy, 1e-12)
    r = np.sqrt(q)
    k = len(landmarks)
    z = np.column_stack([r, wrap_angle(np.arctan2(dy, dx) - pose[2])])
    h_pose = np.zeros((k, 2, 3))
    h_pose[:, 0, 0] = -dx / r
    h_pose[:, 0, 1] = -dy / r
    h_pose[:, 1, 0] = dy / q
    h_pose[:, 1, 1] = -dx / q
    h_pose[:, 1, 2] = -1.0
    h_lm = np.empty((k, 2, 2))
    h_lm[:, 0, 0] = dx / r
    h_lm[:, 0, 1] = dy / r
    h_lm[:, 1, 0] = -dy / q
    h_lm[:, 1, 1] = dx / q
    return z, h_pose, h_lm


def inverse_observation(pose, z) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(l, G_pose, G_z)``: the landmark seen at range-bearing ``z`` and the Jacobians of ``g``."""
    r, b = z
    a = pose[2] + b
    c, s = np.cos(a), np.sin(a)
    lm = np.array([pose[0] + r * c, pose[1] + r * s])
    g_pose = np.array([[1.0, 0.0, -r * s], [0.0, 1.0, r * c]])
    g_z = np.array([[c, -r * s], [s, r * c]])
    return lm, g_pose, g_z


def to_range_bearing(points) -> np.ndarray:
    """Range-bearing ``(k, 2)`` of robot-frame points ``(k, 2)``."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    return np.column_stack([np.hypot(points[:, 0], points[:, 1]), np.arctan2(points[:, 1], points[:, 0])])


def observe_line(pose, line, anchor=(0.0, 0.0)) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(z, H_pose, H_line)``: the robot-frame ``(ρ_r >= 0, α_r)`` of a world line and its Jacobians."""
    z, h_pose, h_line = observe_lines_many(pose, np.asarray(line, float).reshape(1, 2),
                                           np.asarray(anchor, float).reshape(1, 2))
    return z[0], h_pose[0], h_line[0]


def observe_lines_many(pose, lines, anchors=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`observe_line` for ``(k, 2)`` lines with anchors ``(k, 2)`` (default the origin):
    ``z (k, 2)``, ``H_pose (k, 2, 3)``, ``H_line (k, 2, 2)``."""
    lines = np.asarray(lines, float).reshape(-1, 2)
    anchors = np.zeros_like(lines) if anchors is None else np.asarray(anchors, float).reshape(-1, 2)
    x, y, th = pose[0] - anchors[:, 0], pose[1] - anchors[:, 1], pose[2]
    rho, alpha = lines[:, 0], lines[:, 1]
    c, s = np.cos(alpha), np.sin(alpha)
    rho_r = rho - x * c - y * s
    sign = np.where(rho_r < 0, -1.0, 1.0)
    k = len(lines)
    z = np.column_stack([sign * rho_r, wrap_angle(alpha - th + np.where(sign < 0, np.pi, 0.0))])
    h_pose = np.zeros((k, 2, 3))
    h_pose[:, 0, 0] = -sign * c
    h_pose[:, 0, 1] = -sign * s
    h_pose[:, 1, 2] = -1.0
    h_line = np.zeros((k, 2, 2))
    h_line[:, 0, 0] = sign
    h_line[:, 0, 1] = sign * (x * s - y * c)
    h_line[:, 1, 1] = 1.0
    return z, h_pose, h_line


def inverse_line_observation(pose, z, anchor=(0.0, 0.0)) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(l, G_pose, G_z)``: the world line seen as robot-frame ``z = (ρ_r, α_r)`` and the Jacobians."""
    x, y, th = pose[0] - anchor[0], pose[1] - anchor[1], pose[2]
    rho_r, alpha_r = z
    alpha = float(wrap_angle(th + alpha_r))
    c, s = np.cos(alpha), np.sin(alpha)
    lever = -x * s + y * c  # dρ/dα at fixed robot-frame ρ_r
    line = np.array([rho_r + x * c + y * s, alpha])
    g_pose = np.array([[c, s, lever], [0.0, 0.0, 1.0]])
    g_z = np.array([[1.0, lever], [0.0, 1.0]])
    return line, g_pose, g_z
