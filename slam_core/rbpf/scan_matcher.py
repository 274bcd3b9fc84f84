"""Scan matching against one particle's tiled map: Gauss-Newton on point-to-line residuals.

The map's *surface points* are the mean beam endpoints of its occupied cells
(:mod:`slam_core.rbpf.tiled_map` keeps the sums). For one beam endpoint ``e``:

- its **correspondence** is the surface point nearest ``e`` among the occupied
  cells within ``radius`` cells of ``e``'s cell whose counterpart ``FREE_STEP``
  cells back along the beam is free (the beam must arrive from free space, so a
  wall is never matched from behind; 1.5 rather than 1 so that an endpoint on a
  cell border never finds its own cell again);
- the **local surface** is the principal axis of the surface points of the 3 x 3
  cells around that correspondence. Where they lie on a line (minor / major
  spread below ``LINE_RATIO``) the residual ``r`` is the distance from ``e`` to
  that line (point-to-line, so a scan slides freely along a wall instead of
  sticking to the cell lattice); elsewhere it is the distance to the point.

The matcher minimises ``sum_b huber(r_b)`` over the pose by Gauss-Newton, with
a weak prior on the start pose that only decides directions the scan leaves
open (a featureless corridor). Its first iterations search correspondences two
cells wide, the rest one cell. It returns the pose and the information matrix
``H = sum_b J_b^T J_b / lsigma^2`` of the observation likelihood there.

The observation log-likelihood of a pose is ``sum_b -min(r_b, d_max)^2 / (2 lsigma^2)``
(a beam with no correspondence counts as ``d_max`` off), the truncated Gaussian
beam model of GMapping (Grisetti et al. 2007).

The per-beam and per-cell functions are inlined into the loops over beams and
never bind an array to a local name: otherwise numba counts references to the
map's arrays (atomic increments and decrements) on every call, which made the
matcher up to 5x slower.
"""

from __future__ import annotations

import numpy as np

from slam_core.jit import njit
from slam_core.rbpf.tiled_map import HIT_N, HIT_X, HIT_Y, PART, TILE, TILE_BITS, part_of

#: How far (in cells) behind a beam's endpoint its free-space check looks.
FREE_STEP = 1.5
#: Surface points whose minor / major spread is below this lie on a line.
LINE_RATIO = 0.1
#: Fewer surface points than this around a correspondence give no line.
LINE_MIN_POINTS = 3
#: Correspondence search radius (cells) of the matcher's first, wide iterations.
MAX_RADIUS = 2

# Indices into the parameter array built by MatcherParams.packed().
P_LSIGMA2, P_DMAX2, P_OCCUPIED, P_FREE, P_HUBER, P_PRIOR_XY, P_PRIOR_TH = range(7)


@njit
def _tile_of(table, ix, iy):
    if ix < 0 or iy < 0:
        return -1
    ty = iy >> TILE_BITS
    tx = ix >> TILE_BITS
    if ty >= table.shape[0] or tx >= table.shape[1]:
        return -1
    return table[ty, tx]


@njit
def logodds_at(table, lo, ix, iy):
    """Log-odds of cell ``(ix, iy)``; 0 (unknown) outside the map's tiles."""
    t = _tile_of(table, ix, iy)
    if t < 0:
        return 0.0
    return lo[t, iy & (TILE - 1), ix & (TILE - 1)]


@njit
def surface_point(table, lo, hits, origin_x, origin_y, resolution, ix, iy, occupied_lo):
    """``(found, x, y)``: the mean endpoint of cell ``(ix, iy)`` if the cell is occupied."""
    t = _tile_of(table, ix, iy)
    if t < 0:
        return False, 0.0, 0.0
    ly = iy & (TILE - 1)
    lx = ix & (TILE - 1)
    h = hits[0][t, part_of(ly, lx)]  # not unpacked into locals (see the module's docstring)
    if h < 0:
        return False, 0.0, 0.0
    hy, hx = ly & (PART - 1), lx & (PART - 1)
    n = hits[1][h, hy, hx, HIT_N]
    if lo[t, ly, lx] <= occupied_lo or n <= 0.0:
        return False, 0.0, 0.0
    return (True, origin_x + ix * resolution + hits[1][h, hy, hx, HIT_X] / n,
            origin_y + iy * resolution + hits[1][h, hy, hx, HIT_Y] / n)


@njit(inline="always")
def local_line(table, lo, hits, origin_x, origin_y, resolution, ix, iy, occupied_lo):
    """``(is_line, nx, ny, cx, cy)``: unit normal and centroid of the surface around cell ``(ix, iy)``."""
    n = 0
    sx = 0.0
    sy = 0.0
    sxx = 0.0
    sxy = 0.0
    syy = 0.0
    for dy in range(-1, 2):
        for dx in range(-1, 2):
            found, px, py = surface_point(table, lo, hits, origin_x, origin_y, resolution,
                                          ix + dx, iy + dy, occupied_lo)
            if found:
                n += 1
                sx += px
                sy += py
                sxx += px * px
                sxy += px * py
                syy += py * py
    if n < LINE_MIN_POINTS:
        return False, 0.0, 0.0, 0.0, 0.0
    cx = sx / n
    cy = sy / n
    a = sxx / n - cx * cx
    b = sxy / n - cx * cy
    c = syy / n - cy * cy
    half_trace = 0.5 * (a + c)
    disc = np.sqrt(max(half_trace * half_trace - (a * c - b * b), 0.0))
    major = half_trace + disc
    minor = half_trace - disc
    if major <= 0.0 or minor > LINE_RATIO * major:
        return False, 0.0, 0.0, 0.0, 0.0
    angle = 0.5 * np.arctan2(2.0 * b, a - c)  # direction of the major axis
    return True, -np.sin(angle), np.cos(angle), cx, cy


@njit(inline="always")
def _rows(is_line, nx, ny, cx, cy, ex, ey, rx, ry, sx, sy, d2, jac):
    """:func:`_remembered_residual`'s result for a beam ending at ``(ex, ey)`` (``(rx, ry)`` from the pose)
    matched to surface point ``(sx, sy)`` (squared distance ``d2``) on the local line found there."""
    if is_line:
        r = nx * (ex - cx) + ny * (ey - cy)
        jac[0, 0] = nx
        jac[0, 1] = ny
        jac[0, 2] = -nx * ry + ny * rx
        return 1, r, 0.0, r * r
    jac[0, 0] = 1.0
    jac[0, 1] = 0.0
    jac[0, 2] = -ry
    jac[1, 0] = 0.0
    jac[1, 1] = 1.0
    jac[1, 2] = rx
    return 2, ex - sx, ey - sy, d2


@njit(inline="always")
def _remembered_residual(table, lo, hits, origin_x, origin_y, resolution, c, s, x, y, beams, b, params,
                         radius, jac, keys, cells, points, lines):
    """Residual(s) of beam ``b`` at pose ``(x, y, atan2(s, c))``: ``(rows, r0, r1, d2)``, 0 rows
    when unmatched, 1 (point-to-line, ``r0``, Jacobian in ``jac[0]``) or 2 (point-to-point, ``r0,
    r1``, ``jac[0], jac[1]``); ``d2`` is the squared residual length (``inf`` with no correspondence).

    It remembers across calls what depends only on cells: the admissible surface points around the
    endpoint's cell (kept while the endpoint and its free point stay in the same cells and ``radius``
    is the same), and the local line of the last correspondence's cell, so a converging match reads
    the map less.

    ``keys[b]``: ``(ix, iy, fix, fiy, radius, count, line_ix, line_iy)``; ``cells[b, :count]``
    and ``points[b, :count]`` the admissible cells and their surface points in search order;
    ``lines[b]`` the local line (``is_line, nx, ny, cx, cy``). ``keys`` start at -1.
    """
    rx = c * beams[b, 0] - s * beams[b, 1]
    ry = s * beams[b, 0] + c * beams[b, 1]
    ex = x + rx
    ey = y + ry
    back = FREE_STEP * resolution
    fx = ex - back * (c * beams[b, 2] - s * beams[b, 3])
    fy = ey - back * (s * beams[b, 2] + c * beams[b, 3])
    inv = 1.0 / resolution
    ix = int(np.floor((ex - origin_x) * inv))
    iy = int(np.floor((ey - origin_y) * inv))
    fix = int(np.floor((fx - origin_x) * inv))
    fiy = int(np.floor((fy - origin_y) * inv))
    if (keys[b, 0] != ix or keys[b, 1] != iy or keys[b, 2] != fix or keys[b, 3] != fiy
            or keys[b, 4] != radius):
        count = 0
        for dy in range(-radius, radius + 1):
            for dx in range(-radius, radius + 1):
                found, sx, sy = surface_point(table, lo, hits, origin_x, origin_y, resolution,
                                              ix + dx, iy + dy, params[P_OCCUPIED])
                if not found or logodds_at(table, lo, fix + dx, fiy + dy) >= params[P_FREE]:
                    continue
                cells[b, count, 0] = ix + dx
                cells[b, count, 1] = iy + dy
                points[b, count, 0] = sx
                points[b, count, 1] = sy
                count += 1
        keys[b, 0] = ix
        keys[b, 1] = iy
        keys[b, 2] = fix
        keys[b, 3] = fiy
        keys[b, 4] = radius
        keys[b, 5] = count
    best = np.inf
    k = -1
    for j in range(keys[b, 5]):
        d2 = (ex - points[b, j, 0]) * (ex - points[b, j, 0]) + (ey - points[b, j, 1]) * (ey - points[b, j, 1])
        if d2 < best:
            best = d2
            k = j
    if k < 0:
        return 0, 0.0, 0.0, best
    if keys[b, 6] != cells[b, k, 0] or keys[b, 7] != cells[b, k, 1]:
        is_line, nx, ny, cx, cy = local_line(table, lo, hits, origin_x, origin_y, resolution, cells[b, k, 0],
                                             cells[b, k, 1], params[P_OCCUPIED])
        keys[b, 6] = cells[b, k, 0]
        keys[b, 7] = cells[b, k, 1]
        lines[b, 0] = 1.0 if is_line else 0.0
        lines[b, 1] = nx
        lines[b, 2] = ny
        lines[b, 3] = cx
        lines[b, 4] = cy
    return _rows(lines[b, 0] != 0.0, lines[b, 1], lines[b, 2], lines[b, 3], lines[b, 4], ex, ey, rx, ry,
                 points[b, k, 0], points[b, k, 1], best, jac)


def beam_rows(scan, max_range: float, max_beams: int) -> np.ndarray:
    """Rows ``(px, py, ux, uy)`` (endpoint and unit direction, sensor frame) of up to
    ``max_beams`` evenly spread echoes no longer than ``max_range`` (those nearest
    ``np.linspace(0, echoes - 1, max_beams)``, halves to even)."""
    return _beam_rows(scan.ranges, scan.valid, np.cos(scan.angles), np.sin(scan.angles), float(max_range),
                      int(max_beams))


@njit
def _beam_rows(ranges, valid, cos, sin, max_range, max_beams):
    n = ranges.shape[0]
    echoes = np.empty(n, np.int64)
    m = 0
    for i in range(n):
        if valid[i] and ranges[i] <= max_range:
            echoes[m] = i
            m += 1
    count = min(m, max(max_beams, 0))
    rows = np.empty((count, 4))
    step = (m - 1) / (count - 1) if count > 1 else 0.0
    for k in range(count):
        j = k
        if count < m:  # as np.linspace(0, m - 1, count): k * step, the last m - 1, rounded half to even
            j = m - 1 if 0 < k == count - 1 else int(np.rint(k * step))
        i = echoes[j]
        rows[k, 0] = ranges[i] * cos[i]
        rows[k, 1] = ranges[i] * sin[i]
        rows[k, 2] = cos[i]
        rows[k, 3] = sin[i]
    return rows


@njit
def _solve3(a, b):
    """``a^-1 b`` for a symmetric positive definite 3 x 3 ``a`` (Cholesky)."""
    lower = cholesky3(a)
    z = np.empty(3)
    for i in range(3):
        v = b[i]
        for k in range(i):
            v -= lower[i, k] * z[k]
        z[i] = v / lower[i, i]
    out = np.empty(3)
    for i in range(2, -1, -1):
        v = z[i]
        for k in range(i + 1, 3):
            v -= lower[k, i] * out[k]
        out[i] = v / lower[i, i]
    return out


@njit
def cholesky3(a):
    """Lower Cholesky factor of a symmetric positive (semi-)definite 3 x 3 matrix."""
    lower = np.zeros((3, 3))
    for i in range(3):
        for j in range(i + 1):
            v = a[i, j]
            for k in range(j):
                v -= lower[i, k] * lower[j, k]
            if i == j:
                lower[i, i] = np.sqrt(max(v, 1e-18))
            else:
                lower[i, j] = v / lower[j, j]
    return lower


@njit
def match(table, lo, hits, origin_x, origin_y, resolution, x, y, th, beams, params, iterations,
          wide_iterations):
    """Gauss-Newton from ``(x, y, th)``; returns ``(x, y, th, info (3, 3), matched, ll, fitting)``.

    ``info`` is the observation likelihood's information matrix at the result (without
    the start prior); ``matched`` counts beams with a correspondence in the last pass;
    ``(ll, fitting)`` is :func:`pose_likelihood` at the result, computed from what the last
    pass remembered of the map (the same figures, with fewer map reads).
    """
    sx0 = x
    sy0 = y
    sth0 = th
    huber = params[P_HUBER]
    prior_xy = 1.0 / params[P_PRIOR_XY]
    prior_th = 1.0 / params[P_PRIOR_TH]
    inv_l2 = 1.0 / params[P_LSIGMA2]
    jac = np.empty((2, 3))
    info = np.zeros((3, 3))
    matched = 0
    n_beams = beams.shape[0]
    keys = np.full((n_beams, 8), -1, np.int64)
    cells = np.empty((n_beams, (2 * MAX_RADIUS + 1) ** 2, 2), np.int64)
    points = np.empty((n_beams, (2 * MAX_RADIUS + 1) ** 2, 2))
    lines = np.empty((n_beams, 5))
    grad = np.zeros(3)
    loglik = 0.0
    fitting = 0
    it = 0
    final = iterations <= 0
    while True:  # the Gauss-Newton passes, then one more at the result for its likelihood
        radius = MAX_RADIUS if it < wide_iterations and not final else 1
        c = np.cos(th)
        s = np.sin(th)
        if not final:
            info[:, :] = 0.0
            grad[:] = 0.0
            matched = 0
        for b in range(n_beams):  # one call site: the residual is inlined once
            rows, r0, r1, d2 = _remembered_residual(table, lo, hits, origin_x, origin_y, resolution, c, s,
                                                    x, y, beams, b, params, radius, jac, keys, cells, points,
                                                    lines)
            if final:
                if rows > 0:
                    fitting += 1
                loglik -= min(d2, params[P_DMAX2])
                continue
            if rows == 0:
                continue
            matched += 1
            length = np.sqrt(d2)
            w = inv_l2 if length <= huber else inv_l2 * huber / length
            for k in range(rows):
                r = r0 if k == 0 else r1
                for i in range(3):
                    grad[i] += w * jac[k, i] * r
                    for j in range(3):
                        info[i, j] += w * jac[k, i] * jac[k, j]
        if final:
            break
        system = info.copy()
        system[0, 0] += prior_xy
        system[1, 1] += prior_xy
        system[2, 2] += prior_th
        grad[0] += prior_xy * (x - sx0)
        grad[1] += prior_xy * (y - sy0)
        grad[2] += prior_th * (th - sth0)
        step = _solve3(system, grad)
        x -= step[0]
        y -= step[1]
        th -= step[2]
        converged = it >= wide_iterations and abs(step[0]) + abs(step[1]) < 1e-4 and abs(step[2]) < 1e-4
        it += 1
        final = converged or it >= iterations
    return x, y, th, info, matched, loglik / (2.0 * params[P_LSIGMA2]), fitting


@njit
def pose_likelihood(table, lo, hits, origin_x, origin_y, resolution, x, y, th, beams, params):
    """``(log_likelihood, matched)`` of a pose: the truncated Gaussian beam model, by :func:`match`'s
    last pass with no Gauss-Newton step before it (one compiled copy of the per-beam code)."""
    none = np.int64(0)  # typed as every other caller's counts: a literal 0 compiles match once more
    _, _, _, _, _, loglik, matched = match(table, lo, hits, origin_x, origin_y, resolution, x, y, th, beams,
                                           params, none, none)
    return loglik, matched
