"""Slow, obvious references for the simulator's compiled kernels (pure Python, float math)."""

from __future__ import annotations

import math

import numpy as np


def ray_segment(ox, oy, a, seg):
    """Distance along the ray at angle ``a`` to the segment, solving the 2x2 system with numpy."""
    d = np.array([math.cos(a), math.sin(a)])
    p, q = np.array(seg[:2]), np.array(seg[2:])
    m = np.column_stack([d, p - q])  # o + t d = p + s (q - p)  ->  t d - s (q - p) = p - o
    if abs(np.linalg.det(m)) < 1e-12:
        return math.inf
    t, s = np.linalg.solve(m, p - np.array([ox, oy]))
    return t if t >= 0 and 0 <= s <= 1 else math.inf


def ray_circle(ox, oy, a, circle):
    """Smallest t >= 0 with |o + t d - c| = r, from the quadratic formula."""
    cx, cy, r = circle
    if (ox - cx) ** 2 + (oy - cy) ** 2 <= r * r:
        return 0.0
    dx, dy = math.cos(a), math.sin(a)
    # t^2 + 2 b t + c = 0
    b = dx * (ox - cx) + dy * (oy - cy)
    c = (ox - cx) ** 2 + (oy - cy) ** 2 - r * r
    disc = b * b - c
    if disc < 0:
        return math.inf
    roots = [t for t in (-b - math.sqrt(disc), -b + math.sqrt(disc)) if t >= 0]
    return min(roots) if roots else math.inf


def cast_rays(pose, angles, segments, circles, max_range=math.inf):
    out = []
    for rel in angles:
        a = pose[2] + rel
        hits = [ray_segment(pose[0], pose[1], a, s) for s in segments]
        hits += [ray_circle(pose[0], pose[1], a, c) for c in circles]
        best = min(hits, default=math.inf)
        out.append(best if best <= max_range else math.inf)
    return np.array(out)


def clearance(x, y, segments, circles):
    best = math.inf
    for x1, y1, x2, y2 in segments:
        # sample-free closed form via projection, clamped
        ex, ey = x2 - x1, y2 - y1
        s = min(max(((x - x1) * ex + (y - y1) * ey) / (ex * ex + ey * ey), 0.0), 1.0)
        best = min(best, math.hypot(x1 + s * ex - x, y1 + s * ey - y))
    for cx, cy, r in circles:
        best = min(best, math.hypot(x - cx, y - cy) - r)
    return best


def depth_to_scan(depth_m, fx, cx, cy, band, zmin, zmax):
    """Per column (right to left): nearest z in [zmin, zmax] over rows |v - cy| <= band."""
    h, w = depth_m.shape
    angles, ranges = [], []
    for u in reversed(range(w)):
        zs = [depth_m[v, u] for v in range(h) if abs(v - cy) <= band
              and zmin <= depth_m[v, u] <= zmax]
        x = (u - cx) / fx
        angles.append(-math.atan(x))
        ranges.append(min(zs) * math.hypot(1.0, x) if zs else math.nan)
    return np.array(angles), np.array(ranges)


def segments_cross(a, b, seg) -> bool:
    """Whether the open segment a-b properly crosses the wall segment."""
    def orient(p, q, r):
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])
    c, d = seg[:2], seg[2:]
    o1, o2 = orient(a, b, c), orient(a, b, d)
    o3, o4 = orient(c, d, a), orient(c, d, b)
    return o1 * o2 < 0 and o3 * o4 < 0
