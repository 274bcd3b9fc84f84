"""Supercover lines between cell centres, in exact integer arithmetic.

The supercover of a segment is every cell whose closed square it touches.
Between the centres of cells ``(x0, y0)`` and ``(x1, y1)`` it is walked like
Bresenham's line with the error term ``e = |dx| * (2 k_y + 1) - |dy| * (2 k_x
+ 1)`` (sign = which cell border the segment crosses next); ``e == 0`` means
the segment passes exactly through a cell corner, and then both cells sharing
that corner are part of the supercover as well as the diagonal one.
"""

from __future__ import annotations

import numpy as np

from slam_core.jit import njit


@njit
def supercover_cells(x0, y0, x1, y1):
    """``(m, 2)`` cells ``(ix, iy)`` of the supercover from cell ``(x0, y0)`` to ``(x1, y1)``."""
    dx = abs(x1 - x0)
    dy = abs(y1 - y0)
    sx = 1 if x1 > x0 else -1
    sy = 1 if y1 > y0 else -1
    out = np.empty((dx + dy + 1 + 2 * min(dx, dy), 2), np.int64)
    x = x0
    y = y0
    out[0, 0] = x
    out[0, 1] = y
    m = 1
    err = dx - dy
    kx = 0
    ky = 0
    while kx < dx or ky < dy:
        if err > 0:
            x += sx
            kx += 1
            err -= 2 * dy
        elif err < 0:
            y += sy
            ky += 1
            err += 2 * dx
        else:
            out[m, 0] = x + sx
            out[m, 1] = y
            out[m + 1, 0] = x
            out[m + 1, 1] = y + sy
            m += 2
            x += sx
            y += sy
            kx += 1
            ky += 1
            err += 2 * dx - 2 * dy
        out[m, 0] = x
        out[m, 1] = y
        m += 1
    return out[:m]


@njit
def segment_clear(weights, x0, y0, x1, y1):
    """True if every supercover cell of the segment has a finite weight."""
    cells = supercover_cells(x0, y0, x1, y1)
    ny, nx = weights.shape
    for i in range(cells.shape[0]):
        ix = cells[i, 0]
        iy = cells[i, 1]
        if ix < 0 or iy < 0 or ix >= nx or iy >= ny or weights[iy, ix] == np.inf:
            return False
    return True
