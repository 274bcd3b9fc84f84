"""Finding the robot again in a restored map before anything is written into it.

After every start and restart the worker's last pose may be stale: the robot moved while
no worker ran, its microcontroller restarted (counters back at 0), or it was carried. A
first scan drawn into the map at a wrong pose doubles the home, so until
:meth:`Relocalizer.locate` succeeds the worker maps nothing.

``locate(scan, guess)`` tries two correlative searches (Olson, ICRA 2009) on the restored
map's likelihood field, each refined by the Gauss-Newton scan matcher:

1. local: a window of :data:`LOCAL_LINEAR_M` and :data:`LOCAL_ANGULAR` around the guess
   (the last pose carried on by the odometry since the start);
2. global: the whole map, every heading, by branch and bound (Hess et al., ICRA 2016).

A pose is accepted only when at least :data:`ACCEPT_FIT` of the scan's beams then find a
surface; otherwise the robot stays "not localized" and the next scan tries again. A home with
two rooms alike must not fool the global search: it also finds its best pose elsewhere (the
runner-up, refined alike) and accepts only a best pose that fits :data:`RUNNER_UP_MARGIN` better.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam_core.geometry import wrap_angle
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.rbpf.config import RBPFConfig
from slam_core.rbpf.correlative import NO_SKIP, bound_levels, bounded_search, likelihood_window
from slam_core.rbpf.hit_render import SparseHits
from slam_core.rbpf.laser_mount import LaserMount
from slam_core.rbpf.scan_matcher import P_OCCUPIED, beam_rows, match
from slam_core.rbpf.tiled_map import TiledMaps
from slam_core.scan import Scan

#: Half-widths of the local search window around the guess (m, rad).
LOCAL_LINEAR_M = 1.0
LOCAL_ANGULAR = 0.6
#: Heading step of the global search (rad); the fine matcher refines it.
GLOBAL_ANGULAR_STEP = 0.02
#: Fraction of beams that must find a surface for a pose to be accepted.
ACCEPT_FIT = 0.8
#: Side (cells) of the blocks the branch and bound search bounds first.
BLOCK_CELLS = 8
#: The global search's runner-up is its best pose farther than these from the best (m, rad) ...
SKIP_M = 1.0
SKIP_HEADING = 0.5
#: ... and, once refined, a place of its own unless within these of the best pose (m, rad).
SAME_PLACE_M = 0.3
SAME_HEADING = 0.2
#: The best pose is accepted only when it fits this much better than a runner-up of its own.
RUNNER_UP_MARGIN = 0.05


@dataclass(frozen=True)
class Fix:
    """Where the robot was found: its pose, the fraction of beams that fit, and by which search."""

    pose: np.ndarray
    fit: float
    search: str  # "local" or "global"


class Relocalizer:
    """Scan matching of live scans against one restored map (see the module docstring)."""

    def __init__(self, grid: OccupancyGrid, hit_sums: SparseHits | None, config: RBPFConfig | None = None,
                 mount: LaserMount | None = None):
        self.config = config or RBPFConfig(resolution=grid.resolution)
        self.mount = mount or LaserMount()  # where the scans' laser sits on the robot
        self.params = self.config.matcher.packed()
        self.maps = TiledMaps(1, grid.resolution, self.config.sensor)
        self.maps.seed_from_grid(grid, None if hit_sums is None else hit_sums.dense())
        m, matcher = self.maps, self.config.matcher
        res = m.resolution
        # One field over the whole map: the robot is somewhere on it, and so are its scan's echoes.
        size = np.array(grid.shape[::-1])
        self.half = int(np.ceil(max(size) / 2)) + matcher.coarse_reach_cells
        self.centre = np.round((grid.origin - m.origin) / res).astype(int) + size // 2
        self.field = likelihood_window(m.tables[0], m.lo, m.origin[0], m.origin[1], res, self.centre[0],
                                       self.centre[1], self.half, self.params[P_OCCUPIED],
                                       matcher.coarse_sigma, matcher.coarse_reach_cells)
        self.corner = m.origin + (self.centre - self.half) * res
        self.pooled = bound_levels(self.field, BLOCK_CELLS)

    def locate(self, scan: Scan, guess) -> Fix | None:
        """The robot's pose in the map from ``scan`` (see the module docstring), or ``None``."""
        fix = self._locate_laser(scan, self.mount.laser_poses(np.asarray(guess, float)))
        return fix if fix is None else Fix(self.mount.robot_poses(fix.pose), fix.fit, fix.search)

    def global_search(self, scan: Scan) -> tuple[Fix, Fix | None]:
        """The global search's best laser pose and its runner-up, both refined (``None`` for a
        runner-up that refines back onto the best pose): what :meth:`locate` weighs."""
        points, beams = self._rows(scan)
        return self._global(points, beams, 0.0)

    def _locate_laser(self, scan: Scan, guess: np.ndarray) -> Fix | None:
        """The laser's pose in the map from its ``scan``, searched around the laser pose ``guess``."""
        points, beams = self._rows(scan)
        if len(beams) < 10:
            return None
        cells = int(np.ceil(LOCAL_LINEAR_M / self.maps.resolution))
        start = self._search(points, guess, cells, LOCAL_ANGULAR, self.config.matcher.coarse_angular_step)
        pose, fit = self._refine(start, beams)
        if fit >= ACCEPT_FIT:
            return Fix(pose, fit, "local")
        best, runner_up = self._global(points, beams, ACCEPT_FIT)
        if best.fit < ACCEPT_FIT or (runner_up is not None and runner_up.fit > best.fit - RUNNER_UP_MARGIN):
            return None
        return best

    def _rows(self, scan: Scan) -> tuple[np.ndarray, np.ndarray]:
        """The scan's endpoints for the coarse search and its beams for the fine matcher."""
        matcher = self.config.matcher
        return (beam_rows(scan, matcher.coarse_range, matcher.coarse_beams)[:, :2],
                beam_rows(scan, matcher.max_range, matcher.max_beams))

    def _global(self, points: np.ndarray, beams: np.ndarray, min_fit: float) -> tuple[Fix, Fix | None]:
        """The best pose of the whole map and, when it fits at least ``min_fit``, its runner-up."""
        whole = np.array([*(self.maps.origin + (self.centre + 0.5) * self.maps.resolution), 0.0])
        start = self._search(points, whole, self.half, np.pi, GLOBAL_ANGULAR_STEP)
        best = Fix(*self._refine(start, beams), "global")
        if best.fit < min_fit:
            return best, None
        elsewhere = self._search(points, whole, self.half, np.pi, GLOBAL_ANGULAR_STEP, skip=start)
        other = Fix(*self._refine(elsewhere, beams), "global")
        alike = (np.hypot(*(other.pose[:2] - best.pose[:2])) <= SAME_PLACE_M
                 and abs(wrap_angle(other.pose[2] - best.pose[2])) <= SAME_HEADING)
        return best, None if alike else other

    def _search(self, points: np.ndarray, around: np.ndarray, linear_cells: int, angular_half: float,
                angular_step: float, skip: np.ndarray | None = None) -> np.ndarray:
        """The correlative search's best pose; with ``skip``, the best one away from that pose."""
        res = self.maps.resolution
        skipping = NO_SKIP if skip is None else (*skip, round(SKIP_M / res),
                                                 round(SKIP_HEADING / angular_step))
        x, y, th, _ = bounded_search(self.field, *self.pooled, BLOCK_CELLS, res, self.corner[0],
                                     self.corner[1], around[0], around[1], around[2], points,
                                     angular_half, angular_step, linear_cells, *skipping)
        return np.array([x, y, wrap_angle(th)])

    def _refine(self, start: np.ndarray, beams: np.ndarray) -> tuple[np.ndarray, float]:
        m, matcher = self.maps, self.config.matcher
        fine = (m.tables[0], m.lo, m.hits, m.origin[0], m.origin[1], m.resolution)
        x, y, th, _, _, _, matched = match(*fine, start[0], start[1], start[2], beams, self.params,
                                           matcher.iterations, matcher.wide_iterations)
        return np.array([x, y, wrap_angle(th)]), matched / len(beams)
