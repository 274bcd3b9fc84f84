"""Importance weights and resampling shared by the particle filters (RBPF SLAM, MCL).

``effective_sample_size`` is Kong, Liu & Wong's estimate ``N_eff = 1 / sum(w_i^2)``
of normalized weights; filters resample only when it drops below a threshold
(Doucet et al. 2000; Grisetti et al. 2007). ``low_variance_resample`` is
systematic resampling (Thrun, Burgard & Fox, *Probabilistic Robotics*, table 4.4):
one random offset ``u ~ U[0, 1/n)`` and the ``n`` equally spaced pointers
``u + j / n`` walked along the cumulative weights. Particle ``i`` is copied
``floor(n w_i)`` or ``ceil(n w_i)`` times, so the expected count is exactly
``n w_i`` with the smallest possible spread.
"""

from __future__ import annotations

import numpy as np

from slam_core.jit import njit


def normalized_weights(weights) -> np.ndarray:
    """Weights as a float array summing to one; refuses negative, NaN or all-zero weights."""
    w = np.asarray(weights, dtype=np.float64)
    if w.ndim != 1 or w.size == 0:
        raise ValueError(f"weights must be a non-empty 1-D array, got shape {w.shape}")
    if not np.all(np.isfinite(w)) or np.any(w < 0):
        bad = int(np.flatnonzero(~np.isfinite(w) | (w < 0))[0])
        raise ValueError(f"weights must be finite and >= 0; weight {bad} is {w[bad]}")
    total = w.sum()
    if total <= 0:
        raise ValueError("weights sum to zero: no particle explains the data")
    return w / total


def effective_sample_size(weights) -> float:
    """``1 / sum(w_i^2)`` of the normalized weights: ``n`` when uniform, 1 when degenerate."""
    w = normalized_weights(weights)
    return float(1.0 / np.dot(w, w))


def normalized(log_weights) -> np.ndarray:
    """Normalized weights from log-weights, computed stably (max subtracted first)."""
    lw = np.asarray(log_weights, dtype=np.float64)
    if lw.ndim != 1 or lw.size == 0:
        raise ValueError(f"log-weights must be a non-empty 1-D array, got shape {lw.shape}")
    top = np.max(lw)
    if not np.isfinite(top):
        raise ValueError(f"log-weights must contain a finite maximum, got {top}")
    w = np.exp(lw - top)
    return w / w.sum()


@njit
def _systematic(cumulative, u0, n, out):
    m = cumulative.shape[0]
    i = 0
    for j in range(n):
        u = (u0 + j) / n
        while i < m - 1 and cumulative[i] <= u:
            i += 1
        out[j] = i


def low_variance_resample(weights, rng: np.random.Generator, count: int | None = None) -> np.ndarray:
    """Indices of ``count`` (default: as many as weights) particles drawn by systematic resampling.

    Indices come out sorted ascending; shuffle them if their order matters.
    """
    w = normalized_weights(weights)
    n = len(w) if count is None else int(count)
    if n < 1:
        raise ValueError(f"need at least one particle to draw, got count={n}")
    cumulative = np.cumsum(w)
    cumulative[-1] = 1.0  # guard against round-off leaving the last pointer unmatched
    out = np.empty(n, np.int64)
    _systematic(cumulative, float(rng.random()), n, out)
    return out
