"""The odometry motion model (Thrun, Burgard & Fox, *Probabilistic Robotics*, ch. 5.4).

An odometry increment from pose ``o0`` to ``o1`` is read as a rotation ``rot1``
towards the direction of travel, a translation ``trans`` and a final rotation
``rot2``. Each is perturbed by zero-mean Gaussian noise with variance::

    rot1, rot2:  alpha1 * rot^2   + alpha2 * trans^2
    trans:       alpha3 * trans^2 + alpha4 * (rot1^2 + rot2^2)

Driving backwards is read as a negative translation, not a half turn. The same
model serves the particle filter SLAM and Monte Carlo localization.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam_core.geometry import wrap_scalar
from slam_core.jit import njit

#: Below this translation (m) the direction of travel is undefined: rot1 = 0.
MIN_TRANSLATION = 1e-4
#: Floors on the noise standard deviations, so that a standing robot keeps some spread.
MIN_STD_TRANS = 1e-3
MIN_STD_ROT = 1e-3


@njit
def decompose(x0, y0, th0, x1, y1, th1):
    """``(rot1, trans, rot2)`` of the motion from pose 0 to pose 1."""
    dx = x1 - x0
    dy = y1 - y0
    trans = np.sqrt(dx * dx + dy * dy)
    if trans < MIN_TRANSLATION:
        return 0.0, trans, wrap_scalar(th1 - th0)
    rot1 = wrap_scalar(np.arctan2(dy, dx) - th0)
    if abs(rot1) > np.pi / 2:  # driving backwards
        rot1 = wrap_scalar(rot1 + np.pi)
        trans = -trans
    return rot1, trans, wrap_scalar(th1 - th0 - rot1)


@njit
def noise_stds(rot1, trans, rot2, a1, a2, a3, a4):
    """Standard deviations of the noise on ``rot1``, ``trans`` and ``rot2``."""
    s_rot1 = max(np.sqrt(a1 * rot1 * rot1 + a2 * trans * trans), MIN_STD_ROT)
    s_trans = max(np.sqrt(a3 * trans * trans + a4 * (rot1 * rot1 + rot2 * rot2)), MIN_STD_TRANS)
    s_rot2 = max(np.sqrt(a1 * rot2 * rot2 + a2 * trans * trans), MIN_STD_ROT)
    return s_rot1, s_trans, s_rot2


@njit
def apply_motion(x, y, th, rot1, trans, rot2):
    """Move a pose by a ``(rot1, trans, rot2)`` motion."""
    h = th + rot1
    return x + trans * np.cos(h), y + trans * np.sin(h), wrap_scalar(h + rot2)


@njit
def _sample(poses, odom0, odom1, noise, alphas, out):
    rot1, trans, rot2 = decompose(odom0[0], odom0[1], odom0[2], odom1[0], odom1[1], odom1[2])
    s1, st, s2 = noise_stds(rot1, trans, rot2, alphas[0], alphas[1], alphas[2], alphas[3])
    for i in range(poses.shape[0]):
        x, y, th = apply_motion(poses[i, 0], poses[i, 1], poses[i, 2],
                                rot1 + s1 * noise[i, 0], trans + st * noise[i, 1],
                                rot2 + s2 * noise[i, 2])
        out[i, 0] = x
        out[i, 1] = y
        out[i, 2] = th


@njit
def log_likelihood_one(px, py, pth, qx, qy, qth, rot1, trans, rot2, a1, a2, a3, a4):
    """log p(pose q | pose p, odometry motion ``(rot1, trans, rot2)``)."""
    h_rot1, h_trans, h_rot2 = decompose(px, py, pth, qx, qy, qth)
    s1, st, s2 = noise_stds(rot1, trans, rot2, a1, a2, a3, a4)
    e1 = wrap_scalar(rot1 - h_rot1) / s1
    et = (trans - h_trans) / st
    e2 = wrap_scalar(rot2 - h_rot2) / s2
    log_norm = -1.5 * np.log(2 * np.pi) - np.log(s1) - np.log(st) - np.log(s2)
    return log_norm - 0.5 * (e1 * e1 + et * et + e2 * e2)


@njit
def _log_likelihood(prev, new, odom0, odom1, alphas, out):
    rot1, trans, rot2 = decompose(odom0[0], odom0[1], odom0[2], odom1[0], odom1[1], odom1[2])
    for i in range(prev.shape[0]):
        out[i] = log_likelihood_one(prev[i, 0], prev[i, 1], prev[i, 2],
                                    new[i, 0], new[i, 1], new[i, 2],
                                    rot1, trans, rot2, alphas[0], alphas[1], alphas[2], alphas[3])


@dataclass(frozen=True)
class OdometryMotionModel:
    """Four noise parameters, as AMCL names them.

    ``alpha1`` rotation noise from rotation, ``alpha2`` rotation noise from
    translation, ``alpha3`` translation noise from translation, ``alpha4``
    translation noise from rotation (variances per squared unit of motion).
    """

    alpha1: float = 0.05
    alpha2: float = 0.01
    alpha3: float = 0.02
    alpha4: float = 0.01

    @property
    def alphas(self) -> np.ndarray:
        return np.array([self.alpha1, self.alpha2, self.alpha3, self.alpha4])

    def sample(self, poses, odom0, odom1, rng: np.random.Generator) -> np.ndarray:
        """Draw one successor for each pose ``(n, 3)`` given odometry poses ``odom0 -> odom1``."""
        poses = np.atleast_2d(np.asarray(poses, dtype=np.float64))
        out = np.empty_like(poses)
        noise = rng.standard_normal(poses.shape)
        _sample(poses, _pose(odom0), _pose(odom1), noise, self.alphas, out)
        return out

    def log_likelihood(self, prev, new, odom0, odom1) -> np.ndarray:
        """``log p(new | prev, odom0 -> odom1)`` for stacks of poses ``(n, 3)``."""
        prev = np.atleast_2d(np.asarray(prev, dtype=np.float64))
        new = np.atleast_2d(np.asarray(new, dtype=np.float64))
        out = np.empty(len(prev))
        _log_likelihood(prev, new, _pose(odom0), _pose(odom1), self.alphas, out)
        return out


def _pose(p) -> np.ndarray:
    return np.ascontiguousarray(p, dtype=np.float64).reshape(3)
