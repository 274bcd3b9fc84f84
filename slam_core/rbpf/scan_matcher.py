"""Scan matching against one particle's tiled map, compiled with numba.

A beam's endpoint is scored against the *surface points* of the map: the mean
endpoint of each occupied cell. Around the endpoint's cell the 3 x 3 kernel is
searched for an occupied cell whose counterpart one cell back along the beam is
free (the beam must arrive from free space); ``d`` is the distance from the
endpoint to that cell's surface point. As in GMapping (Grisetti et al. 2007):

- the matching score is ``sum_b exp(-d_b^2 / (2 sigma^2))`` over matched beams;
- the observation log-likelihood is ``sum_b -min(d_b, d_max)^2 / (2 lsigma^2)``.

The pose maximising the score is found by hill climbing: try a step in +-x,
+-y, +-theta, take the best improving move, halve the steps when none improves.
"""

from __future__ import annotations

import numpy as np

from slam_core.jit import njit
from slam_core.rbpf.tiled_map import HIT_N, HIT_X, HIT_Y, TILE, TILE_BITS


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
def _logodds_at(table, lo, ix, iy):
    t = _tile_of(table, ix, iy)
    if t < 0:
        return 0.0
    return lo[t, iy & (TILE - 1), ix & (TILE - 1)]


@njit
def beam_distance2(table, lo, hits, origin_x, origin_y, resolution, ex, ey, fx, fy,
                   occupied_lo, free_lo):
    """Squared distance from endpoint ``(ex, ey)`` to the nearest surface point; inf if none.

    ``(fx, fy)`` is the point one cell back along the beam; a candidate cell
    counts only if the cell at the same offset from the free point is free.
    """
    inv = 1.0 / resolution
    ix = int(np.floor((ex - origin_x) * inv))
    iy = int(np.floor((ey - origin_y) * inv))
    fix = int(np.floor((fx - origin_x) * inv))
    fiy = int(np.floor((fy - origin_y) * inv))
    best = np.inf
    for dy in range(-1, 2):
        for dx in range(-1, 2):
            cx = ix + dx
            cy = iy + dy
            t = _tile_of(table, cx, cy)
            if t < 0:
                continue
            ly = cy & (TILE - 1)
            lx = cx & (TILE - 1)
            if lo[t, ly, lx] <= occupied_lo:
                continue
            if _logodds_at(table, lo, fix + dx, fiy + dy) >= free_lo:
                continue
            n = hits[t, ly, lx, HIT_N]
            if n <= 0.0:
                continue
            mx = origin_x + cx * resolution + hits[t, ly, lx, HIT_X] / n
            my = origin_y + cy * resolution + hits[t, ly, lx, HIT_Y] / n
            d2 = (ex - mx) * (ex - mx) + (ey - my) * (ey - my)
            if d2 < best:
                best = d2
    return best


@njit
def evaluate_pose(table, lo, hits, origin_x, origin_y, resolution, x, y, th, beams, params):
    """``(score, log_likelihood, matched)`` of a pose.

    ``beams`` rows are ``(px, py, ux, uy)``: endpoint and unit direction in the
    robot frame. ``params`` is the array built by :class:`MatcherParams`.
    """
    sigma2, lsigma2, dmax2, occupied_lo, free_lo = params[0], params[1], params[2], params[3], params[4]
    c = np.cos(th)
    s = np.sin(th)
    score = 0.0
    loglik = 0.0
    matched = 0
    for b in range(beams.shape[0]):
        px = beams[b, 0]
        py = beams[b, 1]
        ex = x + c * px - s * py
        ey = y + s * px + c * py
        fx = ex - resolution * (c * beams[b, 2] - s * beams[b, 3])
        fy = ey - resolution * (s * beams[b, 2] + c * beams[b, 3])
        d2 = beam_distance2(table, lo, hits, origin_x, origin_y, resolution, ex, ey, fx, fy,
                            occupied_lo, free_lo)
        if d2 < np.inf:
            score += np.exp(-d2 / (2.0 * sigma2))
            matched += 1
            loglik -= min(d2, dmax2) / (2.0 * lsigma2)
        else:
            loglik -= dmax2 / (2.0 * lsigma2)
    return score, loglik, matched


@njit
def hill_climb(table, lo, hits, origin_x, origin_y, resolution, x, y, th, beams, params,
               linear_step, angular_step, refinements):
    """Local search for the pose of highest score; returns ``(x, y, th, score)``."""
    best, _, _ = evaluate_pose(table, lo, hits, origin_x, origin_y, resolution, x, y, th, beams, params)
    done = 0
    while done < refinements:
        move_x = 0.0
        move_y = 0.0
        move_th = 0.0
        improved = False
        for m in range(6):
            cx = x
            cy = y
            cth = th
            if m == 0:
                cx += linear_step
            elif m == 1:
                cx -= linear_step
            elif m == 2:
                cy += linear_step
            elif m == 3:
                cy -= linear_step
            elif m == 4:
                cth += angular_step
            else:
                cth -= angular_step
            sc, _, _ = evaluate_pose(table, lo, hits, origin_x, origin_y, resolution, cx, cy, cth,
                                     beams, params)
            if sc > best:
                best = sc
                move_x = cx
                move_y = cy
                move_th = cth
                improved = True
        if improved:
            x = move_x
            y = move_y
            th = move_th
        else:
            linear_step *= 0.5
            angular_step *= 0.5
            done += 1
    return x, y, th, best
