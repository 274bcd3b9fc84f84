"""Ray traversal and the inverse sensor model, compiled with numba.

Cells are indexed ``(ix, iy)`` with ``ix = floor(gx)``, ``iy = floor(gy)`` where
``(gx, gy)`` are coordinates in cell units from the grid's lower-left corner; a
point exactly on a cell border therefore belongs to the cell above/right of it.

:func:`trace_ray` visits every cell the segment passes through, in order, from
the start cell to the end cell (Amanatides & Woo, 1987). When the segment goes
exactly through a cell corner it steps in y before x, so a diagonal visits one
of the two corner-sharing cells (4-connected path).

The cell update is Bayes' rule in odds form. With ``l = log(p / (1 - p))``, the
binary Bayes filter for a static cell and an inverse sensor model ``p(m | z, x)``
multiplies the prior odds by the measurement odds, which in log-odds is a sum::

    l_t = l_{t-1} + log(p(m | z_t, x_t) / (1 - p(m | z_t, x_t))) - l_0

With the prior ``p = 0.5`` (``l_0 = 0``) a beam adds ``l_free`` (negative) to
every cell it crosses before its echo and ``l_occ`` (positive) to the cell of
its echo; the sum is clamped so that the map stays able to change.

A beam does not clear the cells whose centre lies within ``echo_margin`` of its
echo (:func:`cleared_cells`): a ray that grazes a wall, or whose echo came back
a few centimetres long, crosses the wall's own cells just before its echo, and
clearing them wears the wall away on the side the robot sees it from. A map
worn that way puts every wall a fraction of a cell too far, and a scan matched
against it a centimetre or more ahead of where it was taken.
"""

from __future__ import annotations

import numpy as np

from slam_core.jit import njit

#: How far (m) before a far echo its beam clears the cells (see :func:`far_gap`).
FAR_TAIL = 0.5


@njit
def trace_ray(gx0, gy0, gx1, gy1, out):
    """Write the cells crossed from ``(gx0, gy0)`` to ``(gx1, gy1)`` into ``out``.

    Coordinates are in cell units. ``out`` is an int array of shape ``(m, 2)``
    with room for ``|ex - ix| + |ey - iy| + 1`` cells (start cell ``(ix, iy)``, end
    cell ``(ex, ey)``; at most ``|dx| + |dy| + 3``): a shorter buffer silently cuts
    the ray. Returns the number of cells.
    """
    ix = int(np.floor(gx0))
    iy = int(np.floor(gy0))
    ex = int(np.floor(gx1))
    ey = int(np.floor(gy1))
    dx = gx1 - gx0
    dy = gy1 - gy0
    step_x = 1 if dx > 0 else -1
    step_y = 1 if dy > 0 else -1
    inf = np.inf
    if dx > 0:
        t_max_x = (ix + 1 - gx0) / dx
        t_delta_x = 1.0 / dx
    elif dx < 0:
        t_max_x = (gx0 - ix) / -dx
        t_delta_x = -1.0 / dx
    else:
        t_max_x = inf
        t_delta_x = inf
    if dy > 0:
        t_max_y = (iy + 1 - gy0) / dy
        t_delta_y = 1.0 / dy
    elif dy < 0:
        t_max_y = (gy0 - iy) / -dy
        t_delta_y = -1.0 / dy
    else:
        t_max_y = inf
        t_delta_y = inf
    n = 0
    limit = out.shape[0]
    while n < limit:
        out[n, 0] = ix
        out[n, 1] = iy
        n += 1
        if ix == ex and iy == ey:
            break
        # Never step past the end cell's row or column, whatever rounding says.
        if iy == ey or (ix != ex and t_max_x < t_max_y):
            ix += step_x
            t_max_x += t_delta_x
        else:
            iy += step_y
            t_max_y += t_delta_y
    return n


@njit
def ray_buffer_size(max_range, resolution):
    """Cells a ray of ``max_range`` metres can cross, with margin."""
    return int(2.0 * max_range / resolution) + 4


@njit
def beam_endpoint(px, py, pth, angle, rng, range_min, range_max, usable_range, no_return_range):
    """Classify one beam and clip it: returns ``(use, hit, ex, ey)`` in metres.

    ``use`` is False for beams that are no measurement (nan, zero, below
    ``range_min``). ``hit`` is False for echoes beyond ``usable_range``, which
    clear space up to that range, and for no-return beams (``>= range_max``),
    which clear space up to ``no_return_range``.
    """
    if not (rng >= range_min) or rng <= 0.0:
        return False, False, 0.0, 0.0
    if rng >= range_max:
        hit = False
        r = min(no_return_range, usable_range)
    elif rng > usable_range:
        hit = False
        r = usable_range
    else:
        hit = True
        r = rng
    a = pth + angle
    return True, hit, px + r * np.cos(a), py + r * np.sin(a)


@njit
def far_gap(buf, n, hit, gx0, gy0, gx1, gy1, usable_range, near_range, tail, inv):
    """``(lo, hi)``: the cells ``lo <= k < hi`` of a ray traced from ``(gx0, gy0)`` to ``(gx1, gy1)``
    (cell units, ``n`` cells in ``buf``) that it leaves as they were, in a scan whose echoes are
    trusted beyond ``near_range`` (its ``usable_range`` is larger, see
    :meth:`~slam_core.occupancy_grid.SensorModel.reach`): past ``near_range`` such a beam clears
    only the last ``tail`` metres before its echo (none without an echo). Its far echo marks a
    wall, but the free space it crossed out there costs cells in every particle's map and says
    little. ``(0, 0)`` for every other scan."""
    if usable_range <= near_range:
        return 0, 0
    near2 = (near_range * inv) ** 2
    lo = 0
    while lo < n and (buf[lo, 0] + 0.5 - gx0) ** 2 + (buf[lo, 1] + 0.5 - gy0) ** 2 <= near2:
        lo += 1
    if not hit:
        return lo, n
    tail2 = (tail * inv) ** 2
    hi = n - 1
    while hi > lo and (buf[hi - 1, 0] + 0.5 - gx1) ** 2 + (buf[hi - 1, 1] + 0.5 - gy1) ** 2 < tail2:
        hi -= 1
    return lo, hi


@njit
def cleared_cells(buf, n, hit, gx1, gy1, margin):
    """How many of the ``n`` cells traced to ``(gx1, gy1)`` (cell units) in ``buf`` the beam clears:
    all of them without an echo; with one, those before the cells whose centre lies within
    ``margin`` cells of it (the echo's own cell, the last, is never cleared)."""
    if not hit:
        return n
    m = n - 1
    r2 = margin * margin
    while m > 0:
        dx = buf[m - 1, 0] + 0.5 - gx1
        dy = buf[m - 1, 1] + 0.5 - gy1
        if dx * dx + dy * dy >= r2:
            break
        m -= 1
    return m


@njit
def integrate_scan_dense(logodds, origin_x, origin_y, resolution, pose, angles, ranges,
                         range_min, range_max, usable_range, near_range, no_return_range, echo_margin,
                         l_free, l_occ, l_min, l_max):
    """Apply the inverse sensor model of one scan to a dense log-odds grid in place.

    ``logodds[iy, ix]``; the grid must already contain every traced cell.
    """
    inv = 1.0 / resolution
    buf = np.empty((ray_buffer_size(usable_range, resolution), 2), dtype=np.int64)
    gx0 = (pose[0] - origin_x) * inv
    gy0 = (pose[1] - origin_y) * inv
    ny, nx = logodds.shape
    for b in range(angles.shape[0]):
        use, hit, ex, ey = beam_endpoint(pose[0], pose[1], pose[2], angles[b], ranges[b],
                                         range_min, range_max, usable_range, no_return_range)
        if not use:
            continue
        gx1, gy1 = (ex - origin_x) * inv, (ey - origin_y) * inv
        n = trace_ray(gx0, gy0, gx1, gy1, buf)
        cleared = cleared_cells(buf, n, hit, gx1, gy1, echo_margin * inv)
        gap_lo, gap_hi = far_gap(buf, n, hit, gx0, gy0, gx1, gy1, usable_range, near_range, FAR_TAIL, inv)
        for k in range(n):
            cx = buf[k, 0]
            cy = buf[k, 1]
            if (cx < 0 or cy < 0 or cx >= nx or cy >= ny or cleared <= k < n - 1
                    or (gap_lo < gap_hi and gap_lo <= k < gap_hi)):
                continue
            delta = l_occ if (hit and k == n - 1) else l_free
            v = logodds[cy, cx] + delta
            logodds[cy, cx] = min(max(v, l_min), l_max)
