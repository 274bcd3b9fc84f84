"""Exact Euclidean distance transform (Felzenszwalb & Huttenlocher, 2012).

"Distance Transforms of Sampled Functions", Theory of Computing 8(19). The
squared Euclidean distance transform of a 2-D grid is separable: a 1-D
transform along every column, then a 1-D transform along every row of the
result. Each 1-D pass computes ``D(p) = min_q ((p - q)^2 + f(q))`` in linear
time as the lower envelope of the parabolas rooted at every finite ``f(q)``.
"""

from __future__ import annotations

import numpy as np

from slam_core.jit import njit


@njit
def _envelope_1d(f, out, v, z):
    """``out[p] = min_q (p - q)^2 + f[q]`` over finite ``f[q]`` (``inf`` if none)."""
    n = f.shape[0]
    k = -1
    for q in range(n):
        fq = f[q]
        if fq == np.inf:
            continue
        if k < 0:
            k = 0
            v[0] = q
            z[0] = -np.inf
            z[1] = np.inf
            continue
        # Drop the parabolas the new one hides, then append it to the envelope.
        while True:
            r = v[k]
            s = ((fq + q * q) - (f[r] + r * r)) / (2.0 * (q - r))
            if s <= z[k]:
                k -= 1
            else:
                break
        k += 1
        v[k] = q
        z[k] = s
        z[k + 1] = np.inf
    if k < 0:
        for p in range(n):
            out[p] = np.inf
        return
    k = 0
    for p in range(n):
        while z[k + 1] < p:
            k += 1
        r = v[k]
        out[p] = (p - r) * (p - r) + f[r]


@njit
def _squared_edt(features):
    ny, nx = features.shape
    n = max(nx, ny)
    v = np.empty(n, np.int64)
    z = np.empty(n + 1, np.float64)
    f = np.empty(n, np.float64)
    col = np.empty(n, np.float64)
    out = np.empty((ny, nx), np.float64)
    for ix in range(nx):
        for iy in range(ny):
            f[iy] = 0.0 if features[iy, ix] else np.inf
        _envelope_1d(f[:ny], col[:ny], v, z)
        for iy in range(ny):
            out[iy, ix] = col[iy]
    for iy in range(ny):
        for ix in range(nx):
            f[ix] = out[iy, ix]
        _envelope_1d(f[:nx], col[:nx], v, z)
        for ix in range(nx):
            out[iy, ix] = col[ix]
    return out


def distance_to_features(features: np.ndarray) -> np.ndarray:
    """Euclidean distance, in cells, from every cell to the nearest ``True`` cell.

    ``inf`` everywhere if there is no ``True`` cell. Exact (not chamfer): equal
    to ``scipy.ndimage.distance_transform_edt(~features)``.
    """
    features = np.asarray(features)
    if features.ndim != 2:
        raise ValueError(f"features must be a 2-D array, got shape {features.shape}")
    if features.size == 0:
        return np.zeros(features.shape, np.float64)
    return np.sqrt(_squared_edt(np.ascontiguousarray(features, dtype=np.bool_)))
