"""SE(2) geometry: poses as ``(x, y, theta)`` in metres and radians (REP-103).

Every function accepts one pose of shape ``(3,)`` or a stack of poses of shape
``(..., 3)`` and broadcasts like numpy. ``compose(a, b)`` is ``a ⊕ b``: the pose
``b`` (expressed in the frame of ``a``) moved into the frame ``a`` lives in.
"""

from __future__ import annotations

import math

import numpy as np

from slam_core.jit import njit


def wrap_angle(theta):
    """Wrap angles to the half-open interval ``[-pi, pi)``."""
    w = (np.asarray(theta, dtype=float) + np.pi) % (2.0 * np.pi) - np.pi
    # Just below -pi the remainder rounds up to 2 pi and would give +pi.
    return np.where(w >= np.pi, w - 2.0 * np.pi, w)[()]


def _one_pose(a) -> tuple[float, float, float] | None:
    """``a``'s components as floats when it is one finite pose, else ``None`` (the array path).

    The filter and the back end move single poses per scan, where numpy's per-call overhead
    costs ten times the arithmetic; ``math`` gives the same floats as numpy does for them. (The
    compiled :func:`compose_scalar` and :func:`wrap_scalar` give them too, as fast, but calling one
    from Python starts numba's JIT, 0.2-0.3 s, in a process that ran no kernel yet: the server's.)"""
    if isinstance(a, np.ndarray):
        if a.shape != (3,):
            return None
    elif not (isinstance(a, (list, tuple)) and len(a) == 3):
        return None
    try:
        x, y, theta = float(a[0]), float(a[1]), float(a[2])
    except TypeError:
        return None
    return (x, y, theta) if math.isfinite(x + y + theta) else None


def _wrap_float(theta: float) -> float:
    """``wrap_angle`` for one float, with the same rounding."""
    w = (theta + math.pi) % (2.0 * math.pi) - math.pi
    return w - 2.0 * math.pi if w >= math.pi else w


def _compose_floats(a: tuple[float, float, float], b: tuple[float, float, float]) -> np.ndarray:
    c, s = math.cos(a[2]), math.sin(a[2])
    return np.array([a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], _wrap_float(a[2] + b[2])])


def _inverse_floats(a: tuple[float, float, float]) -> tuple[float, float, float]:
    c, s = math.cos(a[2]), math.sin(a[2])
    return -c * a[0] - s * a[1], s * a[0] - c * a[1], _wrap_float(-a[2])


def compose(a, b):
    """Return ``a ⊕ b`` for poses (or stacks of poses) ``a`` and ``b``."""
    one_a = _one_pose(a)
    one_b = None if one_a is None else _one_pose(b)  # a stack for a: b is not looked at
    if one_b is not None:
        return _compose_floats(one_a, one_b)
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = a[..., 0] + c * b[..., 0] - s * b[..., 1]
    y = a[..., 1] + s * b[..., 0] + c * b[..., 1]
    return np.stack([x, y, wrap_angle(a[..., 2] + b[..., 2])], axis=-1)


def inverse(a):
    """Return ``a⁻¹`` so that ``compose(a, inverse(a))`` is the identity."""
    one = _one_pose(a)
    if one is not None:
        return np.array(_inverse_floats(one))
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = -c * a[..., 0] - s * a[..., 1]
    y = s * a[..., 0] - c * a[..., 1]
    return np.stack([x, y, wrap_angle(-a[..., 2])], axis=-1)


def relative(a, b):
    """Return ``a⁻¹ ⊕ b``: pose ``b`` expressed in the frame of pose ``a``."""
    one_a = _one_pose(a)
    one_b = None if one_a is None else _one_pose(b)  # a stack for a: b is not looked at
    if one_b is not None:
        return _compose_floats(_inverse_floats(one_a), one_b)
    return compose(inverse(a), b)


def paced_pose(before, last, t_before: float, t_last: float, t_now: float) -> np.ndarray | None:
    """Where a pose would be at ``t_now`` had it kept the pace from ``before`` (at ``t_before``) to
    ``last`` (at ``t_last``): that step, scaled by the time since over its time, after ``last``; or
    ``None`` unless the two are a positive time apart."""
    if not t_last > t_before:
        return None
    return compose(last, relative(before, last) * ((t_now - t_last) / (t_last - t_before)))


def transform_points(pose, points):
    """Move points of shape ``(n, 2)`` from the frame of ``pose`` to its parent frame."""
    pose = np.asarray(pose, dtype=float)
    points = np.asarray(points, dtype=float)
    c, s = np.cos(pose[2]), np.sin(pose[2])
    out = np.empty_like(points)
    out[:, 0] = pose[0] + c * points[:, 0] - s * points[:, 1]
    out[:, 1] = pose[1] + s * points[:, 0] + c * points[:, 1]
    return out


def circular_mean(angles, weights=None):
    """Weighted mean of angles on the circle."""
    angles = np.asarray(angles, dtype=float)
    w = np.ones_like(angles) if weights is None else np.asarray(weights, dtype=float)
    return float(np.arctan2(np.sum(w * np.sin(angles)), np.sum(w * np.cos(angles))))


def mean_pose(poses, weights=None):
    """Weighted mean of poses: arithmetic for x and y, circular for the heading."""
    poses = np.asarray(poses, dtype=float)
    w = np.full(len(poses), 1.0 / len(poses)) if weights is None else np.asarray(weights, float)
    w = w / w.sum()
    return np.array([w @ poses[:, 0], w @ poses[:, 1], circular_mean(poses[:, 2], w)])


@njit
def wrap_scalar(theta):
    """Compiled ``wrap_angle`` for one float."""
    w = (theta + np.pi) % (2.0 * np.pi) - np.pi
    return w - 2.0 * np.pi if w >= np.pi else w


@njit
def compose_scalar(ax, ay, ath, bx, by, bth):
    """Compiled ``compose`` for one pair of poses given by their components."""
    c, s = np.cos(ath), np.sin(ath)
    return ax + c * bx - s * by, ay + s * bx + c * by, wrap_scalar(ath + bth)
