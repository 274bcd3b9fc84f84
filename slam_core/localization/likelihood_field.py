"""The likelihood-field range finder model (Thrun, Burgard & Fox, *Probabilistic Robotics*, 6.4).

A beam's endpoint is projected into the map; with ``d`` the distance from it to
the nearest obstacle, the beam's likelihood is::

    p = z_hit * exp(-d^2 / (2 sigma_hit^2)) + z_rand / range_max

``d`` is capped at ``max_dist`` (AMCL's ``laser_likelihood_max_dist``) and taken
as ``max_dist`` outside the map. Max-range readings carry no echo and are skipped,
as in AMCL. A particle's log-likelihood is the sum over the selected beams.
The per-cell ``log p`` is tabulated once, so scoring is a table look-up per beam.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import prange

from slam_core.localization.beams import BeamSelection
from slam_core.localization.known_map import KnownMap
from slam_core.localization.parallel import by_particle_count


@dataclass(frozen=True)
class LikelihoodFieldParams:
    """AMCL's ``laser_z_hit``, ``laser_z_rand``, ``laser_sigma_hit``, ``laser_likelihood_max_dist``."""

    z_hit: float = 0.9
    z_rand: float = 0.1
    sigma_hit: float = 0.1
    max_dist: float = 2.0

    def __post_init__(self):
        if self.z_hit < 0 or self.z_rand <= 0 or self.sigma_hit <= 0 or self.max_dist <= 0:
            raise ValueError(f"likelihood field needs z_hit >= 0, z_rand > 0, sigma_hit > 0, "
                             f"max_dist > 0; got {self}")


def _score_body(particles, laser, bx, by, table, outside, origin_x, origin_y, inv_res, out):
    n = particles.shape[0]
    ny, nx = table.shape
    nb = bx.shape[0]
    for i in prange(n):
        x = particles[i, 0]
        y = particles[i, 1]
        th = particles[i, 2]
        c = np.cos(th)
        s = np.sin(th)
        sx = x + c * laser[0] - s * laser[1]
        sy = y + s * laser[0] + c * laser[1]
        sc = np.cos(th + laser[2])
        ss = np.sin(th + laser[2])
        total = 0.0
        for j in range(nb):
            ex = sx + sc * bx[j] - ss * by[j]
            ey = sy + ss * bx[j] + sc * by[j]
            gx = (ex - origin_x) * inv_res
            gy = (ey - origin_y) * inv_res
            if gx >= 0.0 and gy >= 0.0 and gx < nx and gy < ny:
                total += table[int(gy), int(gx)]
            else:
                total += outside
        out[i] = total


#: Compiled twice: threads pay off only for large particle sets (and hurt on a busy machine).
_score = by_particle_count(_score_body)


class LikelihoodFieldModel:
    """Scores particles ``(n, 3)`` against a scan by the likelihood field of a :class:`KnownMap`."""

    def __init__(self, known_map: KnownMap, params: LikelihoodFieldParams | None = None):
        self.map = known_map
        self.params = params or LikelihoodFieldParams()
        p = self.params
        d = np.minimum(known_map.distance.astype(np.float64), p.max_dist)
        self._hit = p.z_hit * np.exp(-d * d / (2.0 * p.sigma_hit ** 2))
        self._hit_outside = p.z_hit * np.exp(-p.max_dist ** 2 / (2.0 * p.sigma_hit ** 2))
        self._tables: dict[float, tuple[np.ndarray, float]] = {}

    def _table(self, range_max: float) -> tuple[np.ndarray, float]:
        """``log p`` per cell for a sensor of ``range_max`` (z_rand's density depends on it)."""
        if range_max not in self._tables:
            rand = self.params.z_rand / range_max
            self._tables = {range_max: (np.log(self._hit + rand).astype(np.float32),
                                        float(np.log(self._hit_outside + rand)))}
        return self._tables[range_max]

    def log_likelihood(self, particles: np.ndarray, beams: BeamSelection,
                       laser_pose=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, int]:
        """Per-particle log-likelihood and the number of beams it sums over."""
        particles = np.ascontiguousarray(particles, dtype=np.float64)
        if particles.ndim != 2 or particles.shape[1] != 3:
            raise ValueError(f"particles must have shape (n, 3), got {particles.shape}")
        use = ~beams.max_reading
        r, a = beams.ranges[use], beams.angles[use]
        bx = np.ascontiguousarray(r * np.cos(a))
        by = np.ascontiguousarray(r * np.sin(a))
        table, outside = self._table(beams.range_max)
        out = np.empty(len(particles))
        m = self.map
        _score(len(particles))(particles, np.asarray(laser_pose, np.float64), bx, by, table, outside,
               m.origin[0], m.origin[1], 1.0 / m.resolution, out)
        return out, len(bx)
