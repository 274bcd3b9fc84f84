"""Effective sample size and low-variance resampling, shared by the particle filters."""

from __future__ import annotations

import numpy as np


def normalized(log_weights) -> np.ndarray:
    """Weights summing to one from unnormalised log-weights."""
    lw = np.asarray(log_weights, dtype=float)
    w = np.exp(lw - lw.max())
    return w / w.sum()


def effective_sample_size(weights) -> float:
    """``N_eff = 1 / sum(w_i^2)`` for normalised weights (Liu 1996)."""
    w = np.asarray(weights, dtype=float)
    return float(1.0 / np.sum(w * w))


def low_variance_resample(weights, rng: np.random.Generator, count: int | None = None) -> np.ndarray:
    """Indices drawn by systematic (low-variance) resampling (Probabilistic Robotics, Table 4.4).

    One uniform offset ``r`` in ``[0, 1/M)`` and the ``M`` pointers ``r + m/M``
    walk the cumulative weights once: a particle of weight ``w`` is copied
    ``floor(M w)`` or ``ceil(M w)`` times.
    """
    w = np.asarray(weights, dtype=float)
    m = len(w) if count is None else int(count)
    cumulative = np.cumsum(w / w.sum())
    cumulative[-1] = 1.0
    pointers = (rng.random() + np.arange(m)) / m
    return np.searchsorted(cumulative, pointers, side="right").astype(np.int64)
