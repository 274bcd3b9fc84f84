"""The beam range finder model (Thrun, Burgard & Fox, *Probabilistic Robotics*, 6.3).

For each beam the expected range ``z*`` is ray-cast in the map, and the reading
``z`` is scored by the mixture::

    p = z_hit N(z; z*, sigma_hit^2) + z_short eta lambda e^(-lambda z) [z < z*]
        + z_max [z >= range_max] + z_rand / range_max,   eta = 1 / (1 - e^(-lambda z*))

The ray cast marches along the beam in steps bounded by the distance transform
(sphere tracing): a step never jumps over an obstacle, and in open space it is long.
Slower than the likelihood field (one ray per beam and particle), but it sees
free space that the field ignores.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import prange

from slam_core.jit import njit
from slam_core.localization.beams import BeamSelection
from slam_core.localization.known_map import KnownMap
from slam_core.localization.parallel import by_particle_count

#: Smallest ray-march step, in cells; the half-cell step can graze past a cell corner.
MIN_STEP_CELLS = 0.5
#: Margin (cells) between a cell-centre distance and a safe step: two half-diagonals.
STEP_MARGIN_CELLS = 1.5


@dataclass(frozen=True)
class BeamModelParams:
    """AMCL's ``laser_z_hit``, ``laser_z_short``, ``laser_z_max``, ``laser_z_rand``,
    ``laser_sigma_hit`` and ``laser_lambda_short``."""

    z_hit: float = 0.8
    z_short: float = 0.05
    z_max: float = 0.05
    z_rand: float = 0.1
    sigma_hit: float = 0.1
    lambda_short: float = 0.1

    def __post_init__(self):
        if min(self.z_hit, self.z_short, self.z_max) < 0 or self.z_rand <= 0 or self.sigma_hit <= 0 \
                or self.lambda_short <= 0:
            raise ValueError(f"beam model needs non-negative mixture weights, z_rand > 0, "
                             f"sigma_hit > 0, lambda_short > 0; got {self}")


@njit
def cast_ray(sx, sy, c, s, distance, origin_x, origin_y, res, range_max):
    """Range from ``(sx, sy)`` along ``(c, s)`` to the first occupied cell (``range_max`` if none)."""
    ny, nx = distance.shape
    inv = 1.0 / res
    t = 0.0
    while t < range_max:
        gx = (sx + t * c - origin_x) * inv
        gy = (sy + t * s - origin_y) * inv
        if gx < 0.0 or gy < 0.0 or gx >= nx or gy >= ny:
            return range_max
        d = distance[int(gy), int(gx)]
        if d == 0.0:
            return t
        t += max(d - STEP_MARGIN_CELLS * res, MIN_STEP_CELLS * res)
    return range_max


def _score_body(particles, laser, angles, ranges, max_reading, distance, origin_x, origin_y, res,
           range_max, z_hit, z_short, z_max, z_rand, sigma, lam, out):
    n = particles.shape[0]
    nb = angles.shape[0]
    norm = 1.0 / (np.sqrt(2.0 * np.pi) * sigma)
    rand = z_rand / range_max
    for i in prange(n):
        x = particles[i, 0]
        y = particles[i, 1]
        th = particles[i, 2]
        c = np.cos(th)
        s = np.sin(th)
        sx = x + c * laser[0] - s * laser[1]
        sy = y + s * laser[0] + c * laser[1]
        total = 0.0
        for j in range(nb):
            a = th + laser[2] + angles[j]
            expected = cast_ray(sx, sy, np.cos(a), np.sin(a), distance, origin_x, origin_y, res,
                                range_max)
            z = ranges[j]
            p = rand
            if max_reading[j]:
                p += z_max
            else:
                e = (z - expected) / sigma
                p += z_hit * norm * np.exp(-0.5 * e * e)
                if z < expected:
                    p += z_short * lam * np.exp(-lam * z) / (1.0 - np.exp(-lam * expected))
            total += np.log(p)
        out[i] = total


#: Compiled twice: threads pay off only for large particle sets (and hurt on a busy machine).
_score = by_particle_count(_score_body)


class BeamModel:
    """Scores particles ``(n, 3)`` against a scan by ray casting in a :class:`KnownMap`."""

    def __init__(self, known_map: KnownMap, params: BeamModelParams | None = None):
        self.map = known_map
        self.params = params or BeamModelParams()

    def log_likelihood(self, particles: np.ndarray, beams: BeamSelection,
                       laser_pose=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, int]:
        """Per-particle log-likelihood and the number of beams it sums over."""
        particles = np.ascontiguousarray(particles, dtype=np.float64)
        if particles.ndim != 2 or particles.shape[1] != 3:
            raise ValueError(f"particles must have shape (n, 3), got {particles.shape}")
        p = self.params
        m = self.map
        out = np.empty(len(particles))
        _score(len(particles))(particles, np.asarray(laser_pose, np.float64), beams.angles, beams.ranges,
               beams.max_reading, m.distance, m.origin[0], m.origin[1], m.resolution,
               beams.range_max, p.z_hit, p.z_short, p.z_max, p.z_rand, p.sigma_hit, p.lambda_short, out)
        return out, len(beams)
