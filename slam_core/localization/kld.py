"""KLD-sampling (Fox, *Adapting the Sample Size in Particle Filters Through KLD-Sampling*, IJRR 2003).

With the belief occupying ``k`` bins of a histogram over ``(x, y, theta)``, the
number of samples needed so that, with probability ``1 - delta``, the K-L
divergence between the sample-based and the true posterior stays below
``epsilon`` is, by the Wilson–Hilferty approximation of the chi-square quantile::

    n = (k - 1) / (2 epsilon) * (1 - 2 / (9 (k - 1)) + sqrt(2 / (9 (k - 1))) z_(1-delta))^3

where ``z_(1-delta)`` is the upper ``1 - delta`` quantile of the standard normal.
Samples are drawn one by one, counting the bins they fall in, until their number
reaches the bound for the bins seen so far.
"""

from __future__ import annotations

from statistics import NormalDist

import numpy as np


def kld_bound(k, epsilon: float, delta: float) -> np.ndarray:
    """Samples needed for ``k`` occupied bins (array-valued; 1 for ``k <= 1``)."""
    if not (epsilon > 0 and 0 < delta < 1):
        raise ValueError(f"need epsilon > 0 and 0 < delta < 1, got {epsilon}, {delta}")
    k = np.asarray(k, dtype=np.float64)
    z = NormalDist().inv_cdf(1.0 - delta)
    km1 = np.maximum(k - 1.0, 1.0)
    a = 2.0 / (9.0 * km1)
    n = km1 / (2.0 * epsilon) * (1.0 - a + np.sqrt(a) * z) ** 3
    return np.where(k <= 1, 1.0, np.ceil(n))


def pose_bins(poses: np.ndarray, xy_size: float, theta_size: float) -> np.ndarray:
    """One integer key per pose for the histogram bin ``(x, y, theta)`` it falls in."""
    poses = np.asarray(poses, dtype=np.float64)
    ix = np.floor(poses[:, 0] / xy_size).astype(np.int64)
    iy = np.floor(poses[:, 1] / xy_size).astype(np.int64)
    it = np.floor(np.mod(poses[:, 2], 2 * np.pi) / theta_size).astype(np.int64)
    # pack into one int64: 24 bits per axis is +-8 million bins
    return ((ix & 0xFFFFFF) << 40) | ((iy & 0xFFFFFF) << 16) | (it & 0xFFFF)


def adaptive_count(keys_in_draw_order: np.ndarray, epsilon: float, delta: float,
                   n_min: int, n_max: int) -> int:
    """How many of the drawn samples to keep: the first ``n`` with ``n >= kld_bound(k_n)``.

    ``k_n`` is the number of distinct bins among the first ``n`` draws. Never below
    ``n_min`` nor above ``n_max`` (nor above the draws available).
    """
    keys = np.asarray(keys_in_draw_order)
    if not 1 <= n_min <= n_max:
        raise ValueError(f"need 1 <= n_min <= n_max, got {n_min}, {n_max}")
    total = min(len(keys), n_max)
    if total == 0:
        raise ValueError("no samples drawn")
    keys = keys[:total]
    _, first = np.unique(keys, return_index=True)
    new_bin = np.zeros(total, np.int64)
    new_bin[first] = 1
    k_n = np.cumsum(new_bin)
    n = np.arange(1, total + 1)
    enough = (n >= kld_bound(k_n, epsilon, delta)) & (n >= n_min)
    hits = np.flatnonzero(enough)
    return int(hits[0] + 1) if len(hits) else total
