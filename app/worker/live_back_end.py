"""The loop-closing back end, live: ``homebot slam``'s pose graph run beside the filter.

Each time the filter completes a submap (``submap_updates`` updates) and no solve is
running, the best particle's poses at its updates are taken (in the worker's thread, so
they are consistent) and a background thread closes their loops
(:func:`slam_core.graph.loop_closure.close_loops`) and renders the map from the
optimised poses; the filter never waits for it. The worker takes the finished
:class:`BackEndResult` when it is ready: its :attr:`~BackEndResult.correction` moves the
filter's frame onto the optimised one (the ``map -> odom`` correction of REP-105, here
``map -> filter``); the published pose is that correction composed with the filter's
pose, and the published map is the optimised one with the updates since drawn in at
corrected poses.

Each solve is a full re-solve over all updates so far (not yet incremental), so its cost
grows with the map.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import numpy as np

from slam_core.geometry import compose, inverse
from slam_core.graph.loop_closure import close_loops
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.pipelines.log_slam import best_updates
from slam_core.rbpf import RBPFConfig, RBPFSlam
from slam_core.rbpf.laser_mount import LaserMount
from slam_core.scan import Scan


@dataclass(frozen=True)
class BackEndResult:
    """One solve: the optimised (robot) pose of each of the first ``len(poses)`` updates, the
    filter's poses it started from, the loop edges kept and the map rendered from the optimised poses."""

    poses: np.ndarray
    filter_poses: np.ndarray
    loop_edges: int
    grid: OccupancyGrid
    seconds: float

    @property
    def correction(self) -> np.ndarray:
        """``map <- filter``: takes the newest solved update's filter pose onto its optimised pose."""
        return compose(self.poses[-1], inverse(self.filter_poses[-1]))


def render(config: RBPFConfig, mount: LaserMount, poses: np.ndarray, scans: list[Scan],
           layout: OccupancyGrid) -> OccupancyGrid:
    """The map of ``scans`` taken from robot ``poses`` by a laser at ``mount``, on the cells of
    ``layout`` (the filter's map: the published map keeps its extent unless a scan reaches out)."""
    grid = OccupancyGrid(config.resolution, layout.origin, layout.shape, model=config.sensor)
    for pose, scan in zip(mount.laser_poses(poses), scans, strict=True):
        grid.integrate(scan, pose)
    return grid


class LiveBackEnd:
    """Feed :meth:`updated` after every filter update; read finished solves with :meth:`take`."""

    def __init__(self, config: RBPFConfig, mount: LaserMount):
        self.config = config
        self.mount = mount
        self.scans: list[Scan] = []  # the scan of every filter update
        self.solves = 0
        self._thread: threading.Thread | None = None
        self._done: BackEndResult | None = None
        self._lock = threading.Lock()

    @classmethod
    def attached_to(cls, estimator) -> LiveBackEnd | None:
        """A back end for a particle filter that closes loops; ``None`` for any other estimator."""
        if isinstance(estimator, RBPFSlam) and estimator.config.loop_closure.enabled:
            return cls(estimator.config, estimator.mount)
        return None

    @property
    def busy(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def updated(self, slam: RBPFSlam, scan: Scan) -> None:
        """The filter updated with ``scan``; start a solve when it completed a submap and none runs."""
        self.scans.append(scan)
        if len(self.scans) % self.config.loop_closure.submap_updates or self.busy:
            return
        poses = best_updates(slam).poses
        layout = slam.occupancy_map()
        self._thread = threading.Thread(target=self._solve, args=(poses, list(self.scans), layout),
                                        name="live-back-end", daemon=True)
        self._thread.start()

    def _solve(self, poses: np.ndarray, scans: list[Scan], layout: OccupancyGrid) -> None:
        started = time.perf_counter()
        c = self.config
        closed, _ = close_loops(poses, scans, c.loop_closure, c.matcher, c.resolution, c.sensor, self.mount)
        grid = render(c, self.mount, closed.poses, scans, layout)
        result = BackEndResult(closed.poses, poses, closed.loop_edges, grid, time.perf_counter() - started)
        with self._lock:
            self._done = result
            self.solves += 1

    def take(self) -> BackEndResult | None:
        """The newest finished solve not taken yet."""
        with self._lock:
            result, self._done = self._done, None
        return result

    def wait(self) -> None:
        """Let a running solve finish (its result is dropped unless taken)."""
        if self._thread is not None:
            self._thread.join()
