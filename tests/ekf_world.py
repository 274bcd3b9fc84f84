"""A tiny analytic world for the EKF unit tests: a square room with round posts, ray-cast exactly.

Independent of the EKF and simulator code: beams meet circles and walls in closed form.
"""

from __future__ import annotations

import numpy as np

from slam_core.scan import Scan

ROOM = 10.0  # the room spans [-ROOM, ROOM]^2
POST_RADIUS = 0.05
RANGE_MAX = 12.0


def posts(rng: np.random.Generator, n: int = 30, min_gap: float = 1.5) -> np.ndarray:
    out: list[np.ndarray] = []
    while len(out) < n:
        p = rng.uniform(-ROOM + 1.0, ROOM - 1.0, 2)
        if np.hypot(*p) > 2.5 and all(np.hypot(*(p - q)) > min_gap for q in out):
            out.append(p)
    return np.array(out)


def cast(pose, centres, n_beams=720, sigma=0.0, rng=None, radius=POST_RADIUS) -> Scan:
    """Exact ranges from ``pose`` to the room walls and posts (+ optional Gaussian noise)."""
    angles = -np.pi + 2 * np.pi * np.arange(n_beams) / n_beams
    a = pose[2] + angles
    d = np.column_stack([np.cos(a), np.sin(a)])
    o = np.asarray(pose[:2], float)
    with np.errstate(divide="ignore", invalid="ignore"):
        tx = np.where(d[:, 0] > 0, (ROOM - o[0]) / d[:, 0], (-ROOM - o[0]) / d[:, 0])
        ty = np.where(d[:, 1] > 0, (ROOM - o[1]) / d[:, 1], (-ROOM - o[1]) / d[:, 1])
    ranges = np.minimum(np.abs(tx), np.abs(ty))
    for c in centres:
        oc = o - c
        b = d @ oc
        disc = b * b - (oc @ oc - radius ** 2)
        t = -b - np.sqrt(np.maximum(disc, 0.0))
        hit = (disc >= 0) & (t > 0)
        ranges = np.where(hit, np.minimum(ranges, t), ranges)
    if sigma:
        ranges = ranges + sigma * rng.standard_normal(n_beams)
    ranges = np.where(ranges >= RANGE_MAX, np.inf, ranges)
    return Scan(angles, ranges, 0.05, RANGE_MAX)
