"""Coarse alignment of a scan to one map by exhaustive (correlative) search.

Olson's real-time correlative scan matching (ICRA 2009), in its simplest form:
the map around the predicted pose is turned into a likelihood field (each cell
holds ``exp(-d^2 / (2 sigma^2))`` for the distance ``d`` to the nearest occupied
cell, truncated), and every pose of a window of rotations x translations is
scored by summing the field at the beam endpoints, times a Gaussian prior on
the distance from the prediction. The filter uses the best particle's map to
find the odometry's error once per update; every particle's own fine match
then starts from its prediction corrected by that error, which widens the
capture range of the fine matcher far beyond its 3 x 3 kernel.

The loop-closing back end searches far wider windows without a prior; there
:func:`bounded_search` finds the same optimum by branch and bound over blocks
of offsets, bounded by a max-pooled field (:func:`max_pool`).
"""

from __future__ import annotations

import numpy as np

from slam_core.jit import njit
from slam_core.rbpf.scan_matcher import logodds_at

#: :func:`bounded_search`'s last five arguments when no region is left out (passed, not defaulted:
#: a call from Python that omits arguments takes numba's slow dispatch path, 0.4 ms, every time).
NO_SKIP = (0.0, 0.0, 0.0, -1, 0)


@njit
def likelihood_window(table, lo, origin_x, origin_y, resolution, cx, cy, half_cells,
                      occupied_lo, sigma, reach_cells):
    """Likelihood field of a square window of ``2 * half_cells`` cells centred at cell ``(cx, cy)``."""
    size = 2 * half_cells
    field = np.zeros((size, size), np.float32)
    x0 = cx - half_cells
    y0 = cy - half_cells
    k = reach_cells
    kernel = np.empty((2 * k + 1, 2 * k + 1), np.float32)
    for dy in range(-k, k + 1):
        for dx in range(-k, k + 1):
            d2 = (dx * dx + dy * dy) * resolution * resolution
            kernel[dy + k, dx + k] = np.exp(-d2 / (2.0 * sigma * sigma))
    for j in range(size):
        for i in range(size):
            if logodds_at(table, lo, x0 + i, y0 + j) <= occupied_lo:
                continue
            for dy in range(-k, k + 1):
                yy = j + dy
                if yy < 0 or yy >= size:
                    continue
                for dx in range(-k, k + 1):
                    xx = i + dx
                    if xx < 0 or xx >= size:
                        continue
                    v = kernel[dy + k, dx + k]
                    if v > field[yy, xx]:
                        field[yy, xx] = v
    return field


@njit
def _score(field, cells_x, cells_y, dx, dy):
    """Sum of the field at the cells shifted by ``(dx, dy)`` (cells off the field count 0)."""
    size_y, size_x = field.shape
    total = 0.0
    for b in range(cells_x.shape[0]):
        xx = cells_x[b] + dx
        yy = cells_y[b] + dy
        if 0 <= xx < size_x and 0 <= yy < size_y:
            total += field[yy, xx]
    return total


@njit
def pooled_bound(pooled, block, cells_x, cells_y, dx, dy):
    """An upper bound of ``_score`` over the offsets ``dx .. dx + block - 1`` (and the same in y):
    the sum of ``pooled = max_pool(field, block)``. A block that starts before the field's
    first row or column is bounded by the pooled cell at the edge, which covers its part
    inside the field."""
    size_y, size_x = pooled.shape
    total = 0.0
    for b in range(cells_x.shape[0]):
        xx = cells_x[b] + dx
        yy = cells_y[b] + dy
        if -block < xx < 0:
            xx = 0
        if -block < yy < 0:
            yy = 0
        if 0 <= xx < size_x and 0 <= yy < size_y:
            total += pooled[yy, xx]
    return total


@njit
def pooled_bounds(pooled, block, cells_x, cells_y, first, out):
    """``out[by, bx] = pooled_bound(pooled, block, cells_x, cells_y, first + bx * block, first +
    by * block)`` for a square of blocks: the same sums, point by point, reading each point's rows
    of ``pooled`` in order."""
    size_y, size_x = pooled.shape
    blocks = out.shape[0]
    span = (blocks - 1) * block
    out[:, :] = 0.0
    for b in range(cells_x.shape[0]):
        x0 = cells_x[b] + first
        y0 = cells_y[b] + first
        if x0 >= 0 and y0 >= 0 and x0 + span < size_x and y0 + span < size_y:
            for by in range(blocks):
                for bx in range(blocks):
                    out[by, bx] += pooled[y0 + by * block, x0 + bx * block]
            continue
        for by in range(blocks):
            yy = y0 + by * block
            if -block < yy < 0:
                yy = 0
            if not 0 <= yy < size_y:
                continue
            for bx in range(blocks):
                xx = x0 + bx * block
                if -block < xx < 0:
                    xx = 0
                if 0 <= xx < size_x:
                    out[by, bx] += pooled[yy, xx]


@njit
def _block_scores(field, cells_x, cells_y, dx0, dy0, out):
    """``out[j, i] = _score(field, cells_x, cells_y, dx0 + i, dy0 + j)`` over ``out``'s shape: the
    same sums, point by point."""
    size_y, size_x = field.shape
    ny, nx = out.shape
    out[:, :] = 0.0
    for b in range(cells_x.shape[0]):
        x0 = cells_x[b] + dx0
        y0 = cells_y[b] + dy0
        if x0 >= 0 and y0 >= 0 and x0 + nx <= size_x and y0 + ny <= size_y:
            for j in range(ny):
                for i in range(nx):
                    out[j, i] += field[y0 + j, x0 + i]
            continue
        for j in range(ny):
            yy = y0 + j
            if 0 <= yy < size_y:
                for i in range(nx):
                    xx = x0 + i
                    if 0 <= xx < size_x:
                        out[j, i] += field[yy, xx]


@njit
def endpoint_cells(px, py, th, points, window_x, window_y, inv, cells_x, cells_y):
    """The field cells of ``points`` (robot frame) seen from ``(px, py, th)``."""
    c = np.cos(th)
    s = np.sin(th)
    for b in range(points.shape[0]):
        ex = px + c * points[b, 0] - s * points[b, 1]
        ey = py + s * points[b, 0] + c * points[b, 1]
        cells_x[b] = int(np.floor((ex - window_x) * inv))
        cells_y[b] = int(np.floor((ey - window_y) * inv))


@njit
def rotated_endpoint_cells(px, py, pth, points, window_x, window_y, resolution, angular_half, angular_step):
    """``(n_rot, cells_x, cells_y)``: the field cells of ``points`` seen from ``(px, py)`` at the
    headings ``pth + r * angular_step`` for ``|r| <= n_rot``, row ``r + n_rot`` each."""
    n_rot = int(np.floor(angular_half / angular_step + 0.5))
    rotations = 2 * n_rot + 1
    cells_x = np.empty((rotations, points.shape[0]), np.int64)
    cells_y = np.empty((rotations, points.shape[0]), np.int64)
    inv = 1.0 / resolution
    for r in range(rotations):
        endpoint_cells(px, py, pth + (r - n_rot) * angular_step, points, window_x, window_y, inv, cells_x[r],
                       cells_y[r])
    return n_rot, cells_x, cells_y


@njit
def search(field, resolution, window_x, window_y, px, py, pth, points, angular_half, angular_step,
           linear_cells, sigma_xy, sigma_th):
    """Best pose ``(x, y, th, score)`` in the window around ``(px, py, pth)``.

    ``field`` covers world cells starting at ``(window_x, window_y)`` (its lower-left
    corner in metres); ``points`` are beam endpoints ``(n, 2)`` in the robot frame.
    """
    n_rot = int(np.floor(angular_half / angular_step + 0.5))
    best = -1.0
    bx, by, bth = px, py, pth
    cells_x = np.empty(points.shape[0], np.int64)
    cells_y = np.empty(points.shape[0], np.int64)
    inv = 1.0 / resolution
    for r in range(-n_rot, n_rot + 1):
        th = pth + r * angular_step
        endpoint_cells(px, py, th, points, window_x, window_y, inv, cells_x, cells_y)
        prior_th = (r * angular_step) ** 2 / (sigma_th * sigma_th)
        for dy in range(-linear_cells, linear_cells + 1):
            for dx in range(-linear_cells, linear_cells + 1):
                total = _score(field, cells_x, cells_y, dx, dy)
                d2 = (dx * dx + dy * dy) * resolution * resolution
                total *= np.exp(-0.5 * (d2 / (sigma_xy * sigma_xy) + prior_th))
                if total > best:
                    best = total
                    bx = px + dx * resolution
                    by = py + dy * resolution
                    bth = th
    return bx, by, bth, best


@njit
def max_pool(field, block):
    """``pooled[y, x] = max(field[y:y + block, x:x + block])`` (cells past the edge count as 0)."""
    size_y, size_x = field.shape
    rows = np.zeros((size_y, size_x), np.float32)
    for y in range(size_y):
        for x in range(size_x):
            v = field[y, x]
            for k in range(1, block):
                if x + k < size_x and field[y, x + k] > v:
                    v = field[y, x + k]
            rows[y, x] = v
    pooled = np.zeros((size_y, size_x), np.float32)
    for y in range(size_y):
        for x in range(size_x):
            v = rows[y, x]
            for k in range(1, block):
                if y + k < size_y and rows[y + k, x] > v:
                    v = rows[y + k, x]
            pooled[y, x] = v
    return pooled


@njit
def bounded_search(field, pooled, coarse, block, resolution, window_x, window_y, px, py, pth, points,
                   angular_half, angular_step, linear_cells, skip_x, skip_y, skip_th, skip_cells, skip_steps):
    """The best pose ``(x, y, th, score)`` of an exhaustive search without prior, found by
    branch and bound (Hess et al., ICRA 2016, with two levels).

    ``pooled`` is ``max_pool(field, block)``: its sum at a block's first offset bounds the
    score of every offset in the block; ``coarse`` is ``pool_pairs(pooled, block)``, which
    bounds blocks twice as wide the same way. Blocks come out of a heap, the largest bound
    first (ties: the lower rotation, row, column, wide blocks before narrow ones): a wide one
    puts its four narrow ones in, a narrow one has its offsets scored, until no bound beats
    the best score found.

    With ``skip_cells >= 0`` (:data:`NO_SKIP` leaves nothing out) the poses within ``skip_cells``
    cells (each axis) and ``skip_steps`` heading steps of ``(skip_x, skip_y, skip_th)`` are left
    out: the best pose elsewhere, the runner-up to that one. Headings are compared around the
    full turn.
    """
    n_rot, cells_x, cells_y = rotated_endpoint_cells(px, py, pth, points, window_x, window_y, resolution,
                                                     angular_half, angular_step)
    rotations = 2 * n_rot + 1
    width = 2 * linear_cells + 1
    blocks = (width + block - 1) // block
    wide = (width + 2 * block - 1) // (2 * block)
    per_level = rotations * blocks * blocks  # codes: level * per_level + (r * blocks + by) * blocks + bx
    keys = np.empty(rotations * wide * wide + 64)  # grown when opened blocks fill it
    codes = np.empty(keys.shape[0], np.int64)
    size = 0
    wide_bounds = np.empty((wide, wide))
    for r in range(rotations):
        pooled_bounds(coarse, 2 * block, cells_x[r], cells_y[r], -linear_cells, wide_bounds)
        for by in range(wide):
            for bx in range(wide):
                size = _push(keys, codes, size, wide_bounds[by, bx], (r * blocks + by) * blocks + bx)
    best = -1.0
    bx_best, by_best, r_best = 0, 0, n_rot
    skip_dx = round((skip_x - px) / resolution)
    skip_dy = round((skip_y - py) / resolution)
    turn = round(2.0 * np.pi / angular_step)
    scores = np.empty((block, block))
    while size > 0:
        bound, code = keys[0], codes[0]
        size = _pop(keys, codes, size)
        if bound <= best:
            break
        level = code // per_level
        r = (code % per_level) // (blocks * blocks)
        by = (code // blocks) % blocks
        bx = code % blocks
        if level == 0:  # a wide block: its narrow blocks go in
            if size + 4 > keys.shape[0]:
                keys, codes = _grown(keys, codes)
            for k in range(4):
                fy, fx = 2 * by + k // 2, 2 * bx + k % 2
                if fy < blocks and fx < blocks:
                    narrow = pooled_bound(pooled, block, cells_x[r], cells_y[r], fx * block - linear_cells,
                                          fy * block - linear_cells)
                    if narrow > best:
                        size = _push(keys, codes, size, narrow, per_level + (r * blocks + fy) * blocks + fx)
            continue
        dx0 = bx * block - linear_cells
        dy0 = by * block - linear_cells
        in_block = scores[:min(block, width - by * block), :min(block, width - bx * block)]
        _block_scores(field, cells_x[r], cells_y[r], dx0, dy0, in_block)
        for j in range(in_block.shape[0]):
            for i in range(in_block.shape[1]):
                dx = dx0 + i
                dy = dy0 + j
                if skip_cells >= 0 and abs(dx - skip_dx) <= skip_cells and abs(dy - skip_dy) <= skip_cells:
                    steps = abs(round((pth + (r - n_rot) * angular_step - skip_th) / angular_step)) % turn
                    if min(steps, turn - steps) <= skip_steps:
                        continue
                if in_block[j, i] > best:
                    best = in_block[j, i]
                    bx_best, by_best, r_best = dx, dy, r
    return (px + bx_best * resolution, py + by_best * resolution, pth + (r_best - n_rot) * angular_step,
            best)


@njit
def _first(keys, codes, a, b):
    """Whether heap entry ``a`` comes out before ``b``: the larger key, then the smaller code."""
    return keys[a] > keys[b] or (keys[a] == keys[b] and codes[a] < codes[b])


@njit
def _grown(keys, codes):
    """The heap's arrays with twice the room."""
    more_keys = np.empty(2 * keys.shape[0])
    more_codes = np.empty(2 * keys.shape[0], np.int64)
    more_keys[:keys.shape[0]] = keys
    more_codes[:keys.shape[0]] = codes
    return more_keys, more_codes


@njit
def _push(keys, codes, size, key, code):
    """Put ``(key, code)`` into the heap of the first ``size`` entries; the new size."""
    i = size
    keys[i], codes[i] = key, code
    while i > 0:
        parent = (i - 1) // 2
        if not _first(keys, codes, i, parent):
            break
        keys[i], keys[parent] = keys[parent], keys[i]
        codes[i], codes[parent] = codes[parent], codes[i]
        i = parent
    return size + 1


@njit
def _pop(keys, codes, size):
    """Take the first entry out of the heap of ``size`` entries (read it at 0 before); the new size."""
    size -= 1
    keys[0], codes[0] = keys[size], codes[size]
    i = 0
    while True:
        first = i
        for child in (2 * i + 1, 2 * i + 2):
            if child < size and _first(keys, codes, child, first):
                first = child
        if first == i:
            return size
        keys[i], keys[first] = keys[first], keys[i]
        codes[i], codes[first] = codes[first], codes[i]
        i = first


@njit
def pool_pairs(pooled, block):
    """``max_pool(field, 2 * block)`` from ``pooled = max_pool(field, block)``."""
    out = np.zeros(pooled.shape, np.float32)
    pool_pairs_into(pooled, block, out)
    return out


@njit
def pool_pairs_into(pooled, block, out):
    """``out[y, x]``: the largest of ``pooled`` at ``(y, x)`` and ``block`` cells right, up, and both
    (cells past the edges count 0; the values are not negative)."""
    size_y, size_x = pooled.shape
    for y in range(size_y):
        for x in range(size_x):
            v = pooled[y, x]
            if x + block < size_x:
                v = max(v, pooled[y, x + block])
            if y + block < size_y:
                v = max(v, pooled[y + block, x])
                if x + block < size_x:
                    v = max(v, pooled[y + block, x + block])
            out[y, x] = v


def bound_levels(field: np.ndarray, block: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`bounded_search`'s ``pooled`` and ``coarse`` for ``field`` and ``block``."""
    pooled = max_pool(field, block)
    return pooled, pool_pairs(pooled, block)
