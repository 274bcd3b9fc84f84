"""Slow, obvious references for the localization kernels."""

from __future__ import annotations

import math

import numpy as np


def likelihood_field_log_lik(particles, laser, angles, ranges, max_reading, distance, origin, res,
                             range_max, z_hit, z_rand, sigma, max_dist):
    out = []
    ny, nx = distance.shape
    for x, y, th in particles:
        sx = x + math.cos(th) * laser[0] - math.sin(th) * laser[1]
        sy = y + math.sin(th) * laser[0] + math.cos(th) * laser[1]
        total = 0.0
        for a, r, skip in zip(angles, ranges, max_reading, strict=True):
            if skip:
                continue
            ex = sx + r * math.cos(th + laser[2] + a)
            ey = sy + r * math.sin(th + laser[2] + a)
            ix = math.floor((ex - origin[0]) / res)
            iy = math.floor((ey - origin[1]) / res)
            d = min(distance[iy, ix], max_dist) if 0 <= ix < nx and 0 <= iy < ny else max_dist
            total += math.log(z_hit * math.exp(-d * d / (2 * sigma * sigma)) + z_rand / range_max)
        out.append(total)
    return np.array(out)


def march_range(occupied, origin, res, sx, sy, heading, range_max, step=0.002):
    """Range to the first occupied cell by tiny fixed steps (range_max if none / leaving the map)."""
    ny, nx = occupied.shape
    t = 0.0
    while t < range_max:
        ix = math.floor((sx + t * math.cos(heading) - origin[0]) / res)
        iy = math.floor((sy + t * math.sin(heading) - origin[1]) / res)
        if not (0 <= ix < nx and 0 <= iy < ny):
            return range_max
        if occupied[iy, ix]:
            return t
        t += step
    return range_max


def beam_log_lik(z, expected, is_max, range_max, z_hit, z_short, z_max, z_rand, sigma, lam):
    p = z_rand / range_max
    if is_max:
        return math.log(p + z_max)
    p += z_hit * math.exp(-0.5 * ((z - expected) / sigma) ** 2) / (math.sqrt(2 * math.pi) * sigma)
    if z < expected:
        p += z_short * lam * math.exp(-lam * z) / (1 - math.exp(-lam * expected))
    return math.log(p)
