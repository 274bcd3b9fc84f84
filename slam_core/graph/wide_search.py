"""Correlative search over windows metres wide: multi-level branch and bound.

Hess et al., "Real-time loop closure in 2D LIDAR SLAM" (ICRA 2016): the likelihood
field is max-pooled over blocks of ``2^k`` cells for every level ``k``
(:func:`field_pyramid`); the pooled sum at a block's first offset bounds the score of
every offset in the block, so the search starts from the coarsest blocks and splits
only those whose bound beats the best score found (depth first, likeliest first).
A minimum score prunes from the start: a window with nothing that good is rejected
at its top level. Used by the loop-closing back end when the drift since the last
closure is larger than the narrow window of :func:`slam_core.rbpf.correlative.bounded_search`.
"""

from __future__ import annotations

import numpy as np

from slam_core.jit import njit
from slam_core.rbpf.correlative import pool_pairs_into, pooled_bound, pooled_bounds, rotated_endpoint_cells

#: Levels of the pyramid above the field (blocks of up to ``2 ** LEVELS`` cells).
LEVELS = 6


@njit
def field_pyramid(field, levels):
    """``out[k, y, x] = max(field[y:y + 2^k, x:x + 2^k])`` for ``k <= levels`` (0 past the edges)."""
    size_y, size_x = field.shape
    out = np.zeros((levels + 1, size_y, size_x), np.float32)
    out[0] = field
    for k in range(1, levels + 1):
        pool_pairs_into(out[k - 1], 1 << (k - 1), out[k])
    return out


@njit
def _within_disc(ox, oy, size, cx, cy, radius):
    """Whether the block of ``size`` offsets from ``(ox, oy)`` lies wholly within ``radius`` of
    ``(cx, cy)`` (its farthest corner does)."""
    dx = max(abs(ox - cx), abs(ox + size - 1 - cx))
    dy = max(abs(oy - cy), abs(oy + size - 1 - cy))
    return dx * dx + dy * dy <= radius * radius


@njit
def wide_search(pyramid, resolution, window_x, window_y, px, py, pth, points, angular_half,
                angular_step, linear_cells, min_score, exclude_x, exclude_y, exclude_cells):
    """The best pose ``(x, y, th, score)`` within ``+-linear_cells`` and ``+-angular_half`` of
    ``(px, py, pth)`` whose score (the field summed at the ``points``) exceeds ``min_score``;
    ``score`` is ``-1`` when no pose does. ``pyramid`` is ``field_pyramid(field, ...)``, the
    field's lower-left corner at ``(window_x, window_y)``. Offsets within ``exclude_cells`` (if
    positive) of the offset ``(exclude_x, exclude_y)`` (cells) are left out, at every heading."""
    levels = pyramid.shape[0] - 1
    n_rot, cells_x, cells_y = rotated_endpoint_cells(px, py, pth, points, window_x, window_y, resolution,
                                                     angular_half, angular_step)
    rotations = 2 * n_rot + 1
    width = 2 * linear_cells + 1
    top = 1 << levels
    blocks = (width + top - 1) // top
    count = rotations * blocks * blocks
    capacity = count + 4 * levels + 4
    st_r = np.empty(capacity, np.int64)
    st_x = np.empty(capacity, np.int64)
    st_y = np.empty(capacity, np.int64)
    st_level = np.empty(capacity, np.int64)
    st_bound = np.empty(capacity)
    bounds = np.empty(count)
    by_rotation = bounds.reshape((rotations, blocks, blocks))
    for r in range(rotations):
        pooled_bounds(pyramid[levels], top, cells_x[r], cells_y[r], -linear_cells, by_rotation[r])
    sp = 0
    for idx in np.argsort(bounds):  # the likeliest ends on top of the stack
        if bounds[idx] > min_score:
            st_r[sp] = idx // (blocks * blocks)
            st_y[sp] = ((idx // blocks) % blocks) * top - linear_cells
            st_x[sp] = (idx % blocks) * top - linear_cells
            st_level[sp] = levels
            st_bound[sp] = bounds[idx]
            sp += 1
    best = min_score
    found = False
    bx_best, by_best, r_best = 0, 0, n_rot
    child_x = np.empty(4, np.int64)
    child_y = np.empty(4, np.int64)
    child_bound = np.empty(4)
    while sp > 0:
        sp -= 1
        if st_bound[sp] <= best:
            continue
        r, ox, oy, level = st_r[sp], st_x[sp], st_y[sp], st_level[sp]
        if exclude_cells > 0 and _within_disc(ox, oy, 1 << level, exclude_x, exclude_y, exclude_cells):
            continue  # every offset of the block is left out
        if level == 0:
            best = st_bound[sp]
            found = True
            bx_best, by_best, r_best = ox, oy, r
            continue
        half = 1 << (level - 1)
        n = 0
        for cy in range(2):
            for cx in range(2):
                x = ox + cx * half
                y = oy + cy * half
                if x - (-linear_cells) < width and y - (-linear_cells) < width:
                    child_x[n] = x
                    child_y[n] = y
                    child_bound[n] = pooled_bound(pyramid[level - 1], half, cells_x[r], cells_y[r], x, y)
                    n += 1
        for k in np.argsort(child_bound[:n]):
            if child_bound[k] > best:
                st_r[sp] = r
                st_x[sp] = child_x[k]
                st_y[sp] = child_y[k]
                st_level[sp] = level - 1
                st_bound[sp] = child_bound[k]
                sp += 1
    if not found:
        return px, py, pth, -1.0
    return (px + bx_best * resolution, py + by_best * resolution, pth + (r_best - n_rot) * angular_step,
            best)
