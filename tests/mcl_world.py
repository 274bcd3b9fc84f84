"""A small hand-made flat for localization tests: a rasterised floor plan, a ray-marching
lidar on it (independent of the localizer's distance transform) and a drifting odometry.
"""

from __future__ import annotations

import itertools

import numpy as np

from slam_core.geometry import compose, relative, wrap_angle
from slam_core.jit import njit
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.scan import Scan

RES = 0.05
#: Walls as (x0, y0, x1, y1) boxes in metres: a 10 x 7 m flat, four rooms, furniture.
WALLS = [
    (0.0, 0.0, 10.0, 0.1), (0.0, 6.9, 10.0, 7.0), (0.0, 0.0, 0.1, 7.0), (9.9, 0.0, 10.0, 7.0),
    (4.0, 0.0, 4.1, 2.0), (4.0, 3.0, 4.1, 7.0),  # living | east rooms, door at y 2..3
    (4.1, 3.5, 6.0, 3.6), (7.0, 3.5, 9.9, 3.6),  # kitchen / bedroom split, door x 6..7
    (0.1, 4.5, 1.5, 4.6), (2.5, 4.5, 4.0, 4.6),  # bathroom in the living room's north-west
    (1.0, 1.0, 2.2, 1.6),  # sofa
    (6.5, 5.5, 7.2, 6.9),  # wardrobe
    (8.8, 0.1, 9.9, 0.8),  # kitchen counter
    (5.0, 1.2, 5.4, 1.6),  # table
    (2.9, 5.6, 3.3, 6.0),  # bathroom cabinet
]
SIZE = (10.0, 7.0)


def occupied_mask() -> np.ndarray:
    nx, ny = round(SIZE[0] / RES), round(SIZE[1] / RES)
    mask = np.zeros((ny, nx), bool)
    for x0, y0, x1, y1 in WALLS:
        mask[round(y0 / RES):round(y1 / RES), round(x0 / RES):round(x1 / RES)] = True
    return mask


def flat_grid() -> OccupancyGrid:
    """The flat as a known map: walls occupied, everything else free."""
    grid = OccupancyGrid(RES, (0.0, 0.0), shape=occupied_mask().shape)
    grid.data[:] = grid.model.l_min
    grid.data[occupied_mask()] = grid.model.l_max
    return grid


@njit
def _march(mask, res, x, y, angles, range_max, out):
    ny, nx = mask.shape
    step = res / 10.0
    for j in range(angles.shape[0]):
        c = np.cos(angles[j])
        s = np.sin(angles[j])
        r = range_max
        t = 0.0
        while t < range_max:
            ix = int(np.floor((x + t * c) / res))
            iy = int(np.floor((y + t * s) / res))
            if ix < 0 or iy < 0 or ix >= nx or iy >= ny or mask[iy, ix]:
                r = t
                break
            t += step
        out[j] = r


class Lidar:
    def __init__(self, beams: int = 360, range_max: float = 8.0, noise: float = 0.01):
        self.mask = occupied_mask()
        self.angles = -np.pi + 2 * np.pi / beams * np.arange(beams)
        self.range_max = range_max
        self.noise = noise

    def scan(self, pose, rng: np.random.Generator) -> Scan:
        out = np.empty(len(self.angles))
        _march(self.mask, RES, pose[0], pose[1], pose[2] + self.angles, self.range_max, out)
        hit = out < self.range_max
        out[hit] += rng.normal(0, self.noise, hit.sum())
        return Scan(self.angles, out, 0.1, self.range_max)


#: A tour through every room: waypoints (x, y).
TOUR = [(2.0, 2.5), (3.5, 2.5), (5.0, 2.5), (6.5, 2.5), (6.5, 4.5), (8.5, 4.5), (8.5, 2.0),
        (7.0, 1.5), (5.5, 2.5), (3.0, 3.5), (2.0, 5.2), (1.0, 3.0), (2.5, 0.6), (3.5, 2.5),
        (6.5, 3.0), (6.5, 5.0), (5.0, 5.5), (8.0, 5.0)]


def tour_poses(start: int = 0, step: float = 0.05, turn_step: float = np.radians(5)):
    """True poses along the tour from waypoint ``start``: turn on the spot, then drive straight."""
    pts = TOUR[start:] + TOUR[:start]
    x, y = pts[0]
    th = np.arctan2(pts[1][1] - y, pts[1][0] - x)
    poses = [(x, y, th)]
    for tx, ty in pts[1:]:
        goal = np.arctan2(ty - y, tx - x)
        while abs(wrap_angle(goal - th)) > 1e-9:
            th += float(np.clip(wrap_angle(goal - th), -turn_step, turn_step))
            poses.append((x, y, th))
        dist = np.hypot(tx - x, ty - y)
        for k in range(1, int(np.ceil(dist / step)) + 1):
            f = min(k * step / dist, 1.0)
            poses.append((x + f * (tx - x), y + f * (ty - y), th))
        x, y = tx, ty
    return np.array(poses)


def drifting_odometry(truth: np.ndarray, rng: np.random.Generator, scale=(0.03, 0.03),
                      noise=(0.01, 0.01), teleport: int | None = None) -> np.ndarray:
    """Odometry integrated from the true increments with scale errors and random noise.

    The wheels do not see the robot carried from ``truth[teleport - 1]`` to ``truth[teleport]``.
    """
    s_t = 1 + rng.normal(0, scale[0])
    s_r = 1 + rng.normal(0, scale[1])
    odom = [np.array([0.0, 0.0, 0.0])]
    for i, (a, b) in enumerate(itertools.pairwise(truth)):
        if i + 1 == teleport:
            odom.append(odom[-1])
            continue
        d = relative(a, b)
        d[:2] *= s_t * (1 + rng.normal(0, noise[0]))
        d[2] = d[2] * s_r + rng.normal(0, noise[1]) * abs(d[2]) + rng.normal(0, 0.002)
        odom.append(compose(odom[-1], d))
    return np.array(odom)
