"""Slow, obvious references for the foundation's fast kernels.

Nothing here is clever: every cell of a bounding box is tested on its own, and
the scan update is written beam by beam, cell by cell, in plain Python.
"""

from __future__ import annotations

import math

import numpy as np

from slam_core.raycast import FAR_TAIL


def ray_cells(gx0, gy0, gx1, gy1):
    """Cells ``[(ix, iy), ...]`` crossed by the segment, ordered by entry parameter.

    Cells are the half-open squares ``[ix, ix + 1) x [iy, iy + 1)`` (so a point on a
    border belongs to the cell above/right of it). A cell is kept when the part of
    the segment inside it has positive length; the cells holding the start and end
    points are always kept. For every cell of the bounding box the segment
    ``P(t) = P0 + t (P1 - P0)``, ``0 <= t <= 1`` is clipped against the square.
    """
    dx, dy = gx1 - gx0, gy1 - gy0
    start = (math.floor(gx0), math.floor(gy0))
    end = (math.floor(gx1), math.floor(gy1))
    found = {start: -1.0, end: 2.0}
    for ix in range(min(start[0], end[0]), max(start[0], end[0]) + 1):
        tx = _slab(gx0, dx, ix)
        if tx is None:
            continue
        for iy in range(min(start[1], end[1]), max(start[1], end[1]) + 1):
            ty = _slab(gy0, dy, iy)
            if ty is None:
                continue
            lo = max(tx[0], ty[0], 0.0)
            hi = min(tx[1], ty[1], 1.0)
            if hi > lo and (ix, iy) not in (start, end):
                found[(ix, iy)] = lo
    return sorted(found, key=found.get)


def _slab(p0, d, k):
    """Parameter interval where ``p0 + t d`` lies in ``[k, k + 1)``; None if never."""
    if d == 0.0:
        return (-math.inf, math.inf) if k <= p0 < k + 1 else None
    a, b = (k - p0) / d, (k + 1 - p0) / d
    return (min(a, b), max(a, b))


def integrate_scan(logodds, origin, resolution, pose, scan, model):
    """The inverse sensor model applied beam by beam with :func:`ray_cells`.

    Updates ``logodds`` (float32, ``[iy, ix]``) in place exactly as the kernel
    documents: ``l_free`` on every traced cell of a beam, ``l_occ`` instead on its
    echo cell, nothing on the other cells whose centre lies within ``echo_margin`` of
    the echo, each sum clamped to ``[l_min, l_max]``. Raises if a cell lies outside.
    Echoes count up to the scan's reach (``SensorModel.reach``); where that is beyond
    ``usable_range``, a beam leaves the cells from the first whose centre lies beyond
    ``usable_range`` from the sensor as they were, up to the cells before its echo whose
    centres lie within ``FAR_TAIL`` of it (all of them without an echo).
    """
    px, py, pth = (float(v) for v in pose)
    ox, oy = float(origin[0]), float(origin[1])
    reach = model.reach(scan)
    for angle, rng in zip(scan.angles, scan.ranges, strict=True):
        rng = float(rng)
        if math.isnan(rng) or rng < scan.range_min or rng <= 0.0:
            continue
        if rng >= scan.range_max:
            hit, r = False, min(model.no_return_range, reach)
        elif rng > reach:
            hit, r = False, reach
        else:
            hit, r = True, rng
        a = pth + float(angle)
        ex, ey = px + r * math.cos(a), py + r * math.sin(a)
        inv = 1.0 / resolution
        cells = ray_cells((px - ox) * inv, (py - oy) * inv, (ex - ox) * inv, (ey - oy) * inv)
        gap = _far_gap(cells, ox, oy, resolution, (px, py), (ex, ey), hit, reach, model.usable_range)
        for k, (ix, iy) in enumerate(cells):
            if k in gap:
                continue
            if not (0 <= iy < logodds.shape[0] and 0 <= ix < logodds.shape[1]):
                raise IndexError(f"cell {(ix, iy)} outside grid {logodds.shape}")
            echo = hit and k == len(cells) - 1
            centre = ox + (ix + 0.5) * resolution, oy + (iy + 0.5) * resolution
            if hit and not echo and math.dist(centre, (ex, ey)) < model.echo_margin:
                continue
            delta = model.l_occ if echo else model.l_free
            v = float(logodds[iy, ix]) + delta
            logodds[iy, ix] = min(max(v, model.l_min), model.l_max)


def check_integrate(grid, scan, pose) -> None:
    """Integrate ``scan`` at ``pose`` into ``grid`` and assert that the result is exactly what
    :func:`integrate_scan` makes of the grid's old cells (moved as the grid grew)."""
    before, old_origin = grid.data.copy(), grid.origin.copy()
    grid.integrate(scan, pose)
    expected = np.zeros_like(grid.data)
    ox, oy = np.round((old_origin - grid.origin) / grid.resolution).astype(int)
    expected[oy:oy + before.shape[0], ox:ox + before.shape[1]] = before
    integrate_scan(expected, grid.origin, grid.resolution, pose, scan, grid.model)
    assert np.array_equal(expected, grid.data)


def _far_gap(cells, ox, oy, resolution, sensor, echo, hit, reach, near):
    """The indices of the cells a beam of a scan trusted to ``reach`` leaves alone beyond ``near``."""
    if reach <= near:
        return range(0)
    centres = [(ox + (ix + 0.5) * resolution, oy + (iy + 0.5) * resolution) for ix, iy in cells]
    lo = next((k for k, c in enumerate(centres) if math.dist(c, sensor) > near), len(cells))
    if not hit:
        return range(lo, len(cells))
    hi = len(cells) - 1
    while hi > lo and math.dist(centres[hi - 1], echo) < FAR_TAIL:
        hi -= 1
    return range(lo, hi)


def nearest_indices(times, queries, max_dt):
    """Brute force: for each query the index of the closest time (-1 if none within max_dt)."""
    out = []
    for q in queries:
        d = [abs(t - q) for t in times]
        best = min(range(len(times)), key=lambda i: (d[i], i))
        out.append(best if d[best] <= max_dt else -1)
    return np.array(out, dtype=np.int64)


def compose(a, b):
    """``a ⊕ b`` with 3x3 homogeneous matrices."""
    m = _matrix(a) @ _matrix(b)
    return np.array([m[0, 2], m[1, 2], math.atan2(m[1, 0], m[0, 0])])


def _matrix(p):
    c, s = math.cos(p[2]), math.sin(p[2])
    return np.array([[c, -s, p[0]], [s, c, p[1]], [0.0, 0.0, 1.0]])
