"""The loop-closing back end, live: ``homebot slam``'s pose graph run beside the filter.

Each time the filter completes a submap (``submap_updates`` updates) and no solve is running, the
best particle's poses at its updates are taken (in the worker's thread, so they are consistent) and
a background thread closes their loops (:func:`slam_core.graph.loop_closure.close_loops`) and brings
the map up to the optimised poses; the filter never waits for it. The worker takes the finished
:class:`BackEndResult` when it is ready, and only then is its grid drawn (after the published grid
it replaces is let go: one whole grid held, not two): its :attr:`~BackEndResult.correction` moves
the filter's frame onto the optimised one (the ``map -> odom`` correction of REP-105, here
``map -> filter``); the published pose is that correction composed with the filter's pose, and the published
map is the optimised one with the updates since drawn in at corrected poses. Each solve also gives
the map's hit sums (:mod:`slam_core.rbpf.hit_render`, in its thread), so that a checkpoint of the
optimised map resumes a filter that matches to the mean beam endpoints as its own map would.

A back end may start from a saved mapping session (:mod:`slam_core.session`): its updates
come first in every solve, so loops close against the old part, and :meth:`LiveBackEnd.session`
gives the session to save or to carry over when the estimator is rebuilt.

Solves are incremental: each goes on from the last one's :class:`~slam_core.graph.loop_closure.LoopMemory`
(the loop edges found stay, only the updates since are searched, the graph starts from the
edges kept and is optimised from the last optimum), and every time the map has doubled since
the last full solve, a full one searches every update again from the optimised poses
(closures the drift hid at first). The map is kept by submap (:class:`~slam_core.count_map.CountMap`,
blocks of ``submap_updates`` updates): a solve traces again only the submaps whose optimised poses
moved and the newest, and the map is clamped after the sum of their counts, as ``homebot slam``'s
final map is. Its hit sums stay sparse (:class:`~slam_core.rbpf.hit_render.SparseHits`).
"""

from __future__ import annotations

import threading
import time
import traceback
from dataclasses import dataclass

import numpy as np

from slam_core.count_map import CountMap
from slam_core.geometry import compose, inverse
from slam_core.graph.loop_closure import LoopMemory, close_loops
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.pipelines.log_slam import BestUpdates, best_updates
from slam_core.rbpf import RBPFConfig, RBPFSlam
from slam_core.rbpf.hit_render import SparseHits
from slam_core.rbpf.laser_mount import LaserMount
from slam_core.scan import Scan
from slam_core.session import MappingSession

#: A full solve (every update searched again) once the updates have grown this much since the last.
FULL_SOLVE_GROWTH = 2.0


@dataclass(frozen=True)
class BackEndResult:
    """One solve: the optimised (robot) pose of each of the first ``len(poses)`` updates (a prior
    session's first), the poses it started from, the loop edges kept and the map of the optimised
    poses (blank until :meth:`LiveBackEnd.take` draws it), with its hit sums (on the grid's cells as it
    was: the worker draws the updates since into the grid and may grow it), and how many submaps this
    solve traced again."""

    poses: np.ndarray
    filter_poses: np.ndarray
    loop_edges: int
    grid: OccupancyGrid
    seconds: float
    hit_sums: SparseHits
    traced: int

    @property
    def correction(self) -> np.ndarray:
        """``map <- filter``: takes the newest solved update's filter pose onto its optimised pose."""
        return compose(self.poses[-1], inverse(self.filter_poses[-1]))


class LiveBackEnd:
    """Feed :meth:`updated` after every filter update; read finished solves with :meth:`take`."""

    def __init__(self, config: RBPFConfig, mount: LaserMount, prior: MappingSession | None = None):
        self.config = config
        self.mount = mount
        self.prior = prior
        self.scans: list[Scan] = []  # the scan of every filter update (after the prior's)
        self.solves = 0
        self._thread: threading.Thread | None = None
        self._done: BackEndResult | None = None
        self._blank: OccupancyGrid | None = None  # the last solve's grid, until drawn (_draw)
        self._failure: str | None = None  # why the last solve raised, until taken
        self._lock = threading.Lock()
        self._memory: LoopMemory | None = None  # the last solve's (read and written by solves only)
        self._full_at = 0  # updates at the last full solve
        # the map by submap, traced again where the poses moved (read and written by solves only)
        self._map = CountMap(config.resolution, config.sensor, config.loop_closure.submap_updates)

    @classmethod
    def attached_to(cls, estimator, prior: MappingSession | None = None) -> LiveBackEnd | None:
        """A back end for a particle filter that closes loops; ``None`` for any other estimator."""
        if isinstance(estimator, RBPFSlam) and estimator.config.loop_closure.enabled:
            return cls(estimator.config, estimator.mount, prior)
        return None

    @property
    def prior_updates(self) -> int:
        return 0 if self.prior is None else len(self.prior.scans)

    @property
    def busy(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def updated(self, slam: RBPFSlam, scan: Scan) -> None:
        """The filter updated with ``scan``; start a solve when it completed a submap and none runs."""
        self.scans.append(scan)
        if len(self.scans) % self.config.loop_closure.submap_updates or self.busy:
            return
        self._draw()  # the next solve changes the map a solve not taken yet is drawn from
        best, scans = best_updates(slam), list(self.scans)
        poses, odometry = best.poses, self._odometry(best)
        if self.prior is not None:
            poses, scans = np.vstack([self.prior.poses, poses]), self.prior.scans + scans
        extent = slam.map_extent()  # the filter's map: the solve's grid covers it too
        self._thread = threading.Thread(target=self._solve, args=(poses, odometry, scans, extent),
                                        name="live-back-end", daemon=True)
        self._thread.start()

    def session(self, slam: RBPFSlam, solved: BackEndResult | None,
                end_pose: np.ndarray) -> MappingSession | None:
        """Every update so far as a session: the prior's and the solved ones at their optimised
        poses, the newer ones at the filter's poses moved by the last solve's correction."""
        first = self.prior_updates
        best = best_updates(slam)
        poses = best.poses
        old = self.prior.poses if self.prior is not None else np.zeros((0, 3))
        if solved is not None:
            done = len(solved.poses) - first
            old = solved.poses[:first]
            poses = np.vstack([solved.poses[first:], compose(solved.correction, poses[done:]).reshape(-1, 3)])
        if first + len(poses) == 0:
            return None
        scans = (self.prior.scans if self.prior is not None else []) + self.scans
        return MappingSession(self.config, self.mount, np.vstack([old, poses]), self._odometry(best), scans,
                              end_pose)

    def _odometry(self, best: BestUpdates) -> np.ndarray:
        """The odometry at every update so far, the prior's first."""
        odometry = best.odometry.reshape(-1, 3)
        return odometry if self.prior is None else np.vstack([self.prior.odometry, odometry])

    def _solve(self, poses: np.ndarray, odometry: np.ndarray, scans: list[Scan],
               extent: tuple[float, float, float, float] | None) -> None:
        """One solve; one that raises leaves its reason for :meth:`failure` (and its traceback in
        the worker's log), and the next completed submap starts the next."""
        try:
            self._solve_once(poses, odometry, scans, extent)
        except Exception as exc:  # a thread's exception would only be printed
            traceback.print_exc()
            with self._lock:
                self._failure = f"{type(exc).__name__}: {exc}"

    def _solve_once(self, poses: np.ndarray, odometry: np.ndarray, scans: list[Scan],
                    extent: tuple[float, float, float, float] | None) -> None:
        started = time.perf_counter()
        c = self.config
        memory = self._memory if len(poses) < FULL_SOLVE_GROWTH * self._full_at else None
        closed, _ = close_loops(poses, scans, c.loop_closure, c.matcher, c.resolution, c.sensor, self.mount,
                                memory, odometry)
        self._memory = closed.memory
        if memory is None:
            self._full_at = len(poses)
        traced = self._map.update(self.mount.laser_poses(closed.poses), scans)
        grid = self._map.blank(extent)
        result = BackEndResult(closed.poses, poses, closed.loop_edges, grid, time.perf_counter() - started,
                               self._map.hit_sums(grid), traced)
        with self._lock:
            self._done, self._blank = result, grid
            self.solves += 1

    @property
    def finished(self) -> bool:
        """Whether a finished solve waits to be taken."""
        with self._lock:
            return self._done is not None

    def take(self) -> BackEndResult | None:
        """The newest finished solve not taken yet, its map drawn now (in the taker's thread)."""
        with self._lock:
            result, self._done = self._done, None
        if result is not None:
            self._draw()
        return result

    def _draw(self) -> None:
        """Draw the last solve's map into its grid. A solve leaves its grid blank, so that the worker can
        let the published map go first and hold one whole map, not two; only the worker's thread
        draws, with no solve running (the map is the solve's)."""
        if self._blank is not None:
            self._map.draw(self._blank)
            self._blank = None

    def failure(self) -> str | None:
        """Why the last solve failed, if it did and this was not asked since."""
        with self._lock:
            failure, self._failure = self._failure, None
        return failure

    def wait(self) -> None:
        """Let a running solve finish (its result is dropped unless taken)."""
        if self._thread is not None:
            self._thread.join()
