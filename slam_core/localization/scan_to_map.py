"""Scan-to-map matching in a known map: Gauss-Newton on the distance field.

As Cartographer's pure localization refines a pose with its Ceres scan matcher,
this refines a pose ``(x, y, theta)`` of the laser so that the scan's endpoints
fall on the map's walls. With ``D(p)`` the distance from world point ``p`` to the
nearest occupied cell (bilinearly interpolated between cell centres, so it has
a gradient), the matcher minimises::

    sum_b  D(e_b(pose))^2  +  sum_k w_k (pose_k - start_k)^2

over the beams b with ``D(e_b) < cutoff`` (trimmed least squares: an endpoint
farther than ``cutoff`` from any wall is a person, a door that moved or a wrong
guess, and does not pull). The prior on the start pose (weights ``w`` from the
caller, see :func:`prior_weights`) decides the directions the scan leaves open
(along a featureless corridor); the beams of one scan share the map's errors, so
they count as ``EFFECTIVE_BEAMS`` independent ones against it. Steps:

1. project the endpoints with the current pose;
2. Gauss-Newton: ``H = sum J^T J + diag(w)``, ``g = sum J^T D + w (pose - start)``,
   with ``J = grad D(e) [1, 0, -(e_y - y); 0, 1, e_x - x]``, the step clamped;
3. the cutoff shrinks from ``CUTOFF_START`` to ``CUTOFF_END`` over the iterations.

It returns the pose and its *fit*: the fraction of the beams whose endpoint lies
within ``FIT_DISTANCE + FIT_PER_METRE * range`` of a wall (far beams are allowed
the error a small heading error gives them), the number the localizer uses to
decide whether the map explains the scan; and its *spread*, the mean squared distance of the
beams within ``CUTOFF_END`` of a wall, which tells apart two poses that explain as many beams.

:func:`search` is the fallback when the start is too far off for Gauss-Newton
(odometry that stalled, then caught up): an exhaustive correlative search
(Olson 2009) over a window of poses, scoring the beams within ``FIT_DISTANCE`` of a wall.

:meth:`ScanToMapMatcher.seen_through` counts the beams that contradict the map at a pose:
their ray passes an occupied cell well before the endpoint (the map's wall is not there). A beam
that ends short of the map's wall is no contradiction: a person or a moved chair is in front of
it (the beam model's ``z_short``), which is how a crowd around the robot differs from a wrong pose.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam_core.jit import njit
from slam_core.localization.beam_model import cast_ray
from slam_core.localization.known_map import KnownMap

#: Trimming distance (m) of the first and the last iteration.
CUTOFF_START = 0.25
CUTOFF_END = 0.1
#: Distances beyond this (m) are all the same to the matcher (and a map without walls stays finite).
FIELD_CAP = 2.0
#: Gauss-Newton iterations.
ITERATIONS = 12
#: An endpoint this close (m) to a wall, plus this much per metre of range, is explained by the map.
FIT_DISTANCE = 0.1
FIT_PER_METRE = 0.01
#: The standard deviation of one beam's distance to the wall (m), the unit of the prior's weights.
BEAM_SIGMA = 0.05
#: Beams of one scan share the map's errors: together they count as this many independent ones.
EFFECTIVE_BEAMS = 20
#: Default prior when the caller gives none: 0.1 m and 0.05 rad standard deviation.
DEFAULT_PRIOR = ((BEAM_SIGMA / 0.1) ** 2, (BEAM_SIGMA / 0.05) ** 2)
#: The correlative search scores a beam ``max(0, 1 - D / SEARCH_REACH)``.
SEARCH_REACH = 0.3
#: A ray that meets a wall this far (m), plus this much per metre of range, before its endpoint
#: sees through the map.
THROUGH_DISTANCE = 0.2
THROUGH_PER_METRE = 0.03
#: Largest step of one iteration (m, rad).
MAX_STEP_XY = 0.25
MAX_STEP_THETA = 0.2


@dataclass(frozen=True)
class MatchResult:
    """The refined pose, the fraction of beams the map explains there, how many beams were used, and
    the mean squared distance (m^2) to the map's walls of the beams within ``CUTOFF_END`` of them
    (how closely they fit: of two matches that explain as many beams, the smaller fits better;
    infinite when no beam is that near)."""

    pose: np.ndarray
    fit: float
    beams: int
    spread: float = np.inf


@njit
def field_at(distance, origin_x, origin_y, res, px, py):
    """Bilinear distance at ``(px, py)`` and its gradient; ``(-1, 0, 0)`` outside the map."""
    ny, nx = distance.shape
    gx = (px - origin_x) / res - 0.5
    gy = (py - origin_y) / res - 0.5
    if gx < 0.0 or gy < 0.0 or gx >= nx - 1 or gy >= ny - 1:
        return -1.0, 0.0, 0.0
    ix = int(gx)
    iy = int(gy)
    fx = gx - ix
    fy = gy - iy
    d00 = distance[iy, ix]
    d10 = distance[iy, ix + 1]
    d01 = distance[iy + 1, ix]
    d11 = distance[iy + 1, ix + 1]
    d = (d00 * (1 - fx) + d10 * fx) * (1 - fy) + (d01 * (1 - fx) + d11 * fx) * fy
    ddx = ((d10 - d00) * (1 - fy) + (d11 - d01) * fy) / res
    ddy = ((d01 - d00) * (1 - fx) + (d11 - d10) * fx) / res
    return d, ddx, ddy


@njit
def _normal_equations(distance, origin_x, origin_y, res, x, y, th, bx, by, cutoff, h, g):
    """Fill ``h`` (3x3) and ``g`` (3) at the pose; returns (beams used, beams within FIT_DISTANCE,
    the sum of the used beams' squared distances)."""
    h[:, :] = 0.0
    g[:] = 0.0
    c = np.cos(th)
    s = np.sin(th)
    used = 0
    close = 0
    squares = 0.0
    for j in range(bx.shape[0]):
        ex = x + c * bx[j] - s * by[j]
        ey = y + s * bx[j] + c * by[j]
        d, dx, dy = field_at(distance, origin_x, origin_y, res, ex, ey)
        if d >= 0.0 and d <= FIT_DISTANCE + FIT_PER_METRE * np.hypot(bx[j], by[j]):
            close += 1
        if d < 0.0 or d >= cutoff:
            continue
        used += 1
        squares += d * d
        j0 = dx
        j1 = dy
        j2 = -dx * (ey - y) + dy * (ex - x)
        jac = (j0, j1, j2)
        for a in range(3):
            g[a] += jac[a] * d
            for b in range(3):
                h[a, b] += jac[a] * jac[b]
    return used, close, squares


@njit
def _match(distance, origin_x, origin_y, res, x, y, th, bx, by, iterations, cutoff_start, cutoff_end,
           prior_xy, prior_th):
    h = np.zeros((3, 3))
    g = np.zeros(3)
    x0 = x
    y0 = y
    th0 = th
    for it in range(iterations):
        frac = it / max(iterations - 1, 1)
        cutoff = cutoff_start + (cutoff_end - cutoff_start) * frac
        used, _, _ = _normal_equations(distance, origin_x, origin_y, res, x, y, th, bx, by, cutoff, h, g)
        if used < 3:
            break
        scale = used / EFFECTIVE_BEAMS
        h[0, 0] += scale * prior_xy
        h[1, 1] += scale * prior_xy
        h[2, 2] += scale * prior_th
        g[0] += scale * prior_xy * (x - x0)
        g[1] += scale * prior_xy * (y - y0)
        g[2] += scale * prior_th * (th - th0)
        step = np.linalg.solve(h, -g)
        step[0] = min(max(step[0], -MAX_STEP_XY), MAX_STEP_XY)
        step[1] = min(max(step[1], -MAX_STEP_XY), MAX_STEP_XY)
        step[2] = min(max(step[2], -MAX_STEP_THETA), MAX_STEP_THETA)
        x += step[0]
        y += step[1]
        th += step[2]
    used, close, squares = _normal_equations(distance, origin_x, origin_y, res, x, y, th, bx, by,
                                             cutoff_end, h, g)
    return x, y, th, close, squares / used if used else np.inf


@njit
def _search(score, origin_x, origin_y, res, x, y, th, bx, by, half_cells, half_th, step_th, cost):
    """Best ``(x, y, theta)`` on the grid of cell offsets and heading steps around the start: the
    mean beam score less ``cost`` times the squared offset in units of the window's half-widths."""
    ny, nx = score.shape
    n_th = int(half_th / step_th)
    inv_cells = 1.0 / max(half_cells, 1) ** 2
    inv_th = 1.0 / max(n_th, 1) ** 2
    best = -np.inf
    bx_, by_, bth = x, y, th
    cells_x = np.empty(bx.shape[0], np.int64)
    cells_y = np.empty(bx.shape[0], np.int64)
    for k in range(-n_th, n_th + 1):
        t = th + k * step_th
        c = np.cos(t)
        s = np.sin(t)
        for j in range(bx.shape[0]):
            cells_x[j] = int(np.floor((x + c * bx[j] - s * by[j] - origin_x) / res))
            cells_y[j] = int(np.floor((y + s * bx[j] + c * by[j] - origin_y) / res))
        for dy in range(-half_cells, half_cells + 1):
            for dx in range(-half_cells, half_cells + 1):
                total = 0.0
                for j in range(bx.shape[0]):
                    ix = cells_x[j] + dx
                    iy = cells_y[j] + dy
                    if ix >= 0 and iy >= 0 and ix < nx and iy < ny:
                        total += score[iy, ix]
                total = total / bx.shape[0] - cost * ((dx * dx + dy * dy) * inv_cells + k * k * inv_th)
                if total > best:
                    best = total
                    bx_ = x + dx * res
                    by_ = y + dy * res
                    bth = t
    return bx_, by_, bth


@njit
def _seen_through(distance, origin_x, origin_y, res, x, y, th, lx, ly, bx, by):
    """Beams from the laser at ``(lx, ly)`` (robot frame) whose ray meets a wall before its endpoint."""
    c = np.cos(th)
    s = np.sin(th)
    sx = x + c * lx - s * ly
    sy = y + s * lx + c * ly
    count = 0
    for j in range(bx.shape[0]):
        dx = bx[j] - lx
        dy = by[j] - ly
        r = np.hypot(dx, dy)
        reach = r - THROUGH_DISTANCE - THROUGH_PER_METRE * r
        if reach <= 0.0:
            continue
        wx = (c * dx - s * dy) / r
        wy = (s * dx + c * dy) / r
        if cast_ray(sx, sy, wx, wy, distance, origin_x, origin_y, res, reach) < reach:
            count += 1
    return count


def prior_weights(sigma_xy: float, sigma_theta: float) -> tuple[float, float]:
    """Prior weights for a start pose known to ``sigma_xy`` (m) and ``sigma_theta`` (rad)."""
    return (BEAM_SIGMA / sigma_xy) ** 2, (BEAM_SIGMA / sigma_theta) ** 2


class ScanToMapMatcher:
    """Refines laser poses in a :class:`KnownMap` against scan endpoints given in the laser frame."""

    def __init__(self, known_map: KnownMap):
        self.map = known_map
        self._distance = np.ascontiguousarray(np.minimum(known_map.distance, FIELD_CAP), dtype=np.float64)
        self._score = np.maximum(0.0, 1.0 - self._distance / SEARCH_REACH)

    def match(self, pose, points: np.ndarray, prior=DEFAULT_PRIOR,
              iterations: int = ITERATIONS) -> MatchResult:
        """Best pose near ``pose`` for endpoints ``(n, 2)`` in the robot frame, and its fit.

        ``prior`` is the weight ``(w_xy, w_theta)`` pulling towards ``pose``.
        """
        pose = np.asarray(pose, dtype=np.float64).reshape(-1)
        if pose.shape != (3,) or not np.all(np.isfinite(pose)):
            raise ValueError(f"pose must be three finite numbers (x, y, theta), got {pose}")
        points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        if len(points) == 0:
            return MatchResult(pose.copy(), 0.0, 0)
        m = self.map
        x, y, th, close, spread = _match(self._distance, m.origin[0], m.origin[1], m.resolution,
                                         pose[0], pose[1], pose[2], np.ascontiguousarray(points[:, 0]),
                                         np.ascontiguousarray(points[:, 1]), iterations, CUTOFF_START,
                                         CUTOFF_END, float(prior[0]), float(prior[1]))
        refined = np.array([x, y, (th + np.pi) % (2 * np.pi) - np.pi])
        return MatchResult(refined, close / len(points), len(points), spread)

    def search(self, pose, points: np.ndarray, half_xy: float, half_theta: float,
               step_theta: float, prior=DEFAULT_PRIOR, cost: float = 0.0) -> MatchResult:
        """Best pose within ``+-half_xy`` (m), ``+-half_theta`` (rad) of ``pose``, then :meth:`match`.

        Candidates pay ``cost`` (a fraction of the beams' mean score) times their squared offset
        from ``pose`` in units of the half-widths: of two poses that fit alike, the nearer wins."""
        pose = np.asarray(pose, dtype=np.float64).reshape(-1)
        points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        if len(points) == 0:
            return MatchResult(pose.copy(), 0.0, 0)
        m = self.map
        half_cells = max(round(half_xy / m.resolution), 0)
        x, y, th = _search(self._score, m.origin[0], m.origin[1], m.resolution, pose[0], pose[1], pose[2],
                           np.ascontiguousarray(points[:, 0]), np.ascontiguousarray(points[:, 1]),
                           half_cells, half_theta, step_theta, cost)
        return self.match((x, y, th), points, prior)

    def seen_through(self, pose, points: np.ndarray, laser_xy=(0.0, 0.0)) -> float:
        """Fraction of the endpoints ``(n, 2)`` (robot frame, laser at ``laser_xy``) whose ray passes
        through a wall of the map at ``pose``."""
        pose = np.asarray(pose, dtype=np.float64).reshape(-1)
        points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        if len(points) == 0:
            return 0.0
        m = self.map
        count = _seen_through(self._distance, m.origin[0], m.origin[1], m.resolution, pose[0], pose[1],
                              pose[2], float(laser_xy[0]), float(laser_xy[1]),
                              np.ascontiguousarray(points[:, 0]), np.ascontiguousarray(points[:, 1]))
        return count / len(points)
