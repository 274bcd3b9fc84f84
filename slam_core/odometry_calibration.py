"""How the odometry errs, learned from the updates whose scans matched.

The motion model's noise is set wide enough for odometry that slips and stalls.
In an update where no particle's scan matches (open ground, a new area, scans far
apart) the particles are drawn from that model alone and weighted by a
likelihood that tells them little apart, so every such update spreads their
headings by the model's whole noise (about 8 deg a metre with the defaults) and
the weights keep whichever heading happened to fit a few beams. Over a few
hundred such updates the trajectory's heading wanders by tens of degrees where
the odometry itself was right to a fraction of a degree a step.

The leading particle's fine match measures the odometry's error in every update
where it fits well. :class:`OdometryCalibration` keeps the last ``window`` of these
errors and gives, for a draw without a match:

- the motion corrected by the odometry's systematic errors: a heading drift per
  metre travelled and per radian turned (unequal wheels, a wrong wheel base) and
  a translation scale, fitted robustly (without the residuals beyond 2.5
  robust standard deviations) under a weak prior that they are small;
- the model's noise scaled by the spread of what remains, in units of the
  model's standard deviations (1.4826 times the median absolute value), rotation
  and translation apart, never wider than the model and never narrower than
  ``min_scale`` of it.

Until ``min_samples`` errors are known, the motion and the model stay as they are. The errors
kept (:class:`MeasuredErrors`) go into the worker's checkpoints, so that a restarted estimator
goes on from them instead of learning the odometry again.

Localization in a finished map (:mod:`slam_core.localization.tracking`) fits the same systematic
errors from its accepted matches and predicts with the corrected motion: a robot whose wheels
over-report travel otherwise runs ahead down a corridor, where a scan cannot pull it back.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam_core.motion_model import noise_stds

#: Robust standard deviation of a zero-mean Gaussian from its median absolute value.
MAD_TO_STD = 1.4826
#: Residuals beyond this many robust standard deviations are left out of the bias fit.
OUTLIER_SIGMAS = 2.5
#: Prior standard deviations of the systematic errors: heading drift (rad per metre),
#: turn scale and translation scale (a few degrees a metre, a few per cent).
SYSTEMATIC_PRIOR = np.array([0.05, 0.05, 0.05])


#: Columns of a measured error: travel, turn (rot1 + rot2), heading error, along-track error, and
#: the motion model's rotation and translation standard deviations for that motion.
ERROR_COLUMNS = 6


@dataclass(frozen=True)
class MeasuredErrors:
    """The errors a calibration kept, oldest first ``(n, ERROR_COLUMNS)``, and the motion model's
    ``alphas`` their standard deviations were computed with."""

    alphas: np.ndarray
    rows: np.ndarray

    def __post_init__(self):
        shape = np.shape(self.rows)
        if np.shape(self.alphas) != (4,) or len(shape) != 2 or shape[1] != ERROR_COLUMNS:
            raise ValueError(f"measured odometry errors need 4 alphas and rows of {ERROR_COLUMNS} values, "
                             f"got {np.shape(self.alphas)} and {np.shape(self.rows)}")
        if not (np.all(np.isfinite(self.alphas)) and np.all(np.isfinite(self.rows))):
            raise ValueError("measured odometry errors hold non-finite values")


class OdometryCalibration:
    """The odometry's systematic error and noise, from the errors the matches measured."""

    def __init__(self, alphas: np.ndarray, window: int, min_samples: int, min_scale: float):
        self.alphas = np.asarray(alphas, dtype=float)
        self.min_samples = max(3, min_samples)
        self.min_scale = min_scale
        self._rows = np.zeros((max(self.min_samples, window), ERROR_COLUMNS))  # a ring, see ERROR_COLUMNS
        self._count = 0
        self._fit: tuple[np.ndarray, np.ndarray] | None = None

    def observe(self, motion: np.ndarray, error: np.ndarray) -> None:
        """Record the odometry's ``error`` (x, y, theta in the predicted pose's frame) over the
        ``motion`` ``(rot1, trans, rot2)`` it reported."""
        rot1, trans, rot2 = motion
        s1, st, s2 = noise_stds(rot1, trans, rot2, *self.alphas)
        row = trans, rot1 + rot2, error[2], error[0], np.hypot(s1, s2), st
        self._rows[self._count % len(self._rows)] = row
        self._count += 1
        self._fit = None

    def calibrated(self) -> bool:
        return self._count >= self.min_samples

    def measured(self) -> MeasuredErrors:
        """The errors kept, oldest first (what :meth:`resume` goes on from)."""
        n = min(self._count, len(self._rows))
        oldest = self._count % len(self._rows) if self._count > len(self._rows) else 0
        return MeasuredErrors(self.alphas.copy(), np.roll(self._rows[:n], -oldest, axis=0))

    def resume(self, errors: MeasuredErrors) -> bool:
        """Go on from ``errors`` measured on the same odometry (the newest that fit the window);
        refused (``False``) when they were measured with another motion model's alphas."""
        if not np.array_equal(errors.alphas, self.alphas):
            return False
        rows = errors.rows[-len(self._rows):]
        self._rows[:len(rows)] = rows
        self._count, self._fit = len(rows), None
        return True

    def bias(self) -> np.ndarray:
        """``(heading per metre, heading per radian turned, translation scale error)``."""
        return self._fitted()[0]

    def scales(self) -> np.ndarray:
        """``(rotation, translation)`` factors on the model's standard deviations."""
        return self._fitted()[1]

    def corrected(self, motion: np.ndarray) -> np.ndarray:
        """``(rot1, trans, rot2)`` with the systematic errors taken out."""
        per_metre, per_radian, scale = self.bias()
        rot1, trans, rot2 = motion
        return np.array([rot1, trans * (1.0 + scale), rot2 + per_metre * trans + per_radian * (rot1 + rot2)])

    def corrected_step(self, step: np.ndarray) -> np.ndarray:
        """An odometry ``step`` ``(x, y, theta)`` in the robot frame with the systematic errors taken
        out (as :meth:`corrected`, without decomposing a step too short to have a direction)."""
        per_metre, per_radian, scale = self.bias()
        travel = np.copysign(np.hypot(step[0], step[1]), step[0])  # negative backwards, as decompose
        return np.array([step[0] * (1.0 + scale), step[1] * (1.0 + scale),
                         step[2] + per_metre * travel + per_radian * step[2]])

    def fallback_alphas(self) -> np.ndarray:
        """The model's alphas with its noise scaled: the rotation pair by the square of the rotation
        scale, the translation pair by the square of the translation scale."""
        rotation, translation = self.scales()
        return self.alphas * np.array([rotation, rotation, translation, translation]) ** 2

    def summary(self) -> dict:
        """The calibration in readable units, for run statistics."""
        (per_metre, per_radian, scale), (rotation, translation) = self._fitted()
        return {"errors_measured": self._count,
                "heading_drift_deg_per_m": round(float(np.degrees(per_metre)), 4),
                "turn_scale_error": round(float(per_radian), 4),
                "translation_scale_error": round(float(scale), 4),
                "rotation_noise_scale": round(float(rotation), 3),
                "translation_noise_scale": round(float(translation), 3)}

    def _fitted(self) -> tuple[np.ndarray, np.ndarray]:
        if not self.calibrated():
            return np.zeros(3), np.ones(2)
        if self._fit is None:
            rows = self._rows[:min(self._count, len(self._rows))]
            trans, turn, heading, along, s_rot, s_trans = rows.T
            drift, heading_left = _robust_fit(np.column_stack([trans, turn]), heading, SYSTEMATIC_PRIOR[:2])
            scale, along_left = _robust_fit(trans[:, None], along, SYSTEMATIC_PRIOR[2:])
            spread = MAD_TO_STD * np.median(np.abs([heading_left / s_rot, along_left / s_trans]), axis=1)
            self._fit = np.append(drift, scale), np.clip(spread, self.min_scale, 1.0)
        return self._fit


def _robust_fit(a: np.ndarray, b: np.ndarray, prior: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients ``x`` of ``a x ~ b`` without the outliers, and the residuals.

    Each step is the posterior mean under a zero-mean Gaussian prior of standard deviations
    ``prior`` on ``x``: where the columns of ``a`` nearly coincide (a robot that drives
    circles turns in proportion to its travel), the data settle only their combination and
    the prior splits it, instead of two large coefficients that cancel."""
    x = np.zeros(a.shape[1])
    keep = np.ones(len(b), bool)
    for _ in range(3):
        left = b - a @ x
        sigma = max(MAD_TO_STD * np.median(np.abs(left[keep])), 1e-9)
        keep = np.abs(left) <= OUTLIER_SIGMAS * sigma
        rows = a[keep]
        x = np.linalg.solve(rows.T @ rows + np.diag((sigma / prior) ** 2), rows.T @ b[keep])
    return x, b - a @ x
