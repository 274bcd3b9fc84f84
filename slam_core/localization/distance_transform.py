"""Exact Euclidean distance transform (Felzenszwalb & Huttenlocher, *Distance Transforms of
Sampled Functions*, Theory of Computing 8, 2012).

The squared distance to the nearest feature cell is separable: a 1-D transform
along every column, then along every row of that result. Each 1-D pass computes
the lower envelope of the parabolas ``(q - p)^2 + f(p)`` in linear time.
"""

from __future__ import annotations

import numpy as np

from slam_core.jit import njit


@njit
def _edt_1d(f, n, d, v, z):
    """Squared-distance transform of the sampled function ``f[:n]`` into ``d``."""
    k = 0
    v[0] = 0
    z[0] = -np.inf
    z[1] = np.inf
    for q in range(1, n):
        while True:
            p = v[k]
            s = ((f[q] + q * q) - (f[p] + p * p)) / (2.0 * q - 2.0 * p)
            if s <= z[k] and k > 0:
                k -= 1
            else:
                break
        if s <= z[k]:  # k == 0: the new parabola replaces the first one
            v[0] = q
            z[0] = -np.inf
            z[1] = np.inf
            continue
        k += 1
        v[k] = q
        z[k] = s
        z[k + 1] = np.inf
    k = 0
    for q in range(n):
        while z[k + 1] < q:
            k += 1
        p = v[k]
        d[q] = (q - p) * (q - p) + f[p]


@njit
def _edt_2d(features, big):
    ny, nx = features.shape
    out = np.empty((ny, nx), np.float64)
    m = max(nx, ny)
    f = np.empty(m, np.float64)
    d = np.empty(m, np.float64)
    v = np.empty(m, np.int64)
    z = np.empty(m + 1, np.float64)
    for ix in range(nx):
        for iy in range(ny):
            f[iy] = 0.0 if features[iy, ix] else big
        _edt_1d(f, ny, d, v, z)
        for iy in range(ny):
            out[iy, ix] = d[iy]
    for iy in range(ny):
        for ix in range(nx):
            f[ix] = out[iy, ix]
        _edt_1d(f, nx, d, v, z)
        for ix in range(nx):
            out[iy, ix] = d[ix]
    return out


def squared_distance_transform(features) -> np.ndarray:
    """Squared Euclidean distance (in cells) from every cell to the nearest ``True`` cell.

    Cells of a grid without any feature get ``inf``.
    """
    features = np.ascontiguousarray(features, dtype=np.bool_)
    if features.ndim != 2:
        raise ValueError(f"features must be a 2-D mask, got shape {features.shape}")
    if features.size == 0:
        return np.zeros(features.shape)
    if not features.any():
        return np.full(features.shape, np.inf)
    ny, nx = features.shape
    big = float(4 * (nx + ny) ** 2 + 1)  # larger than any real squared distance, still finite
    return _edt_2d(features, big)


def distance_transform(features, resolution: float = 1.0) -> np.ndarray:
    """Euclidean distance (in metres at ``resolution`` m/cell) to the nearest ``True`` cell."""
    return np.sqrt(squared_distance_transform(features)) * float(resolution)
