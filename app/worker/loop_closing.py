"""The live back end as the worker loop sees it: solves taken, the corrected estimate, the published map.

:class:`~app.worker.live_back_end.LiveBackEnd` solves in its own thread; :class:`LoopClosing`
takes its finished solves in the worker's thread, counts loop closures (a solve with more loop
edges than any before), moves the filter's estimate into the optimised frame, and keeps the
published map: the optimised one with the filter's updates since drawn in at corrected poses, and
gives its hit sums for a checkpoint (:meth:`LoopClosing.published_hits`). It also keeps the mapping
session (:mod:`slam_core.session`) across estimator rebuilds.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from app.worker.live_back_end import BackEndResult, LiveBackEnd
from slam_core.estimator import Estimate
from slam_core.geometry import compose, wrap_angle
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.pipelines.log_slam import best_updates
from slam_core.rbpf import RBPFSlam
from slam_core.rbpf.hit_render import SparseHits, sparse_hit_sums
from slam_core.session import MappingSession


class LoopClosing:
    """Loop closures counted over the worker's life; the back end of the current estimator."""

    def __init__(self) -> None:
        self.closures = self.edges_seen = 0
        self.back_end: LiveBackEnd | None = None
        self.solved: BackEndResult | None = None
        self.published_grid: OccupancyGrid | None = None  # optimised map + updates since
        self.prior: MappingSession | None = None  # the session the back end went on from

    def attach(self, estimator, seeded: bool, prior: MappingSession | None = None) -> None:
        """A back end for a particle filter that starts from an empty map or goes on from a mapping
        session ``prior`` (it needs every scan of the map; a filter resumed on a checkpoint's map
        alone goes on without)."""
        self.prior = prior
        self.back_end = None if seeded and prior is None else LiveBackEnd.attached_to(estimator, prior)
        self.solved = None
        self.published_grid = None

    def map_pose(self, pose: np.ndarray) -> np.ndarray:
        """A filter pose in the map frame (the last solve's correction applied)."""
        return np.array(pose, float) if self.solved is None else compose(self.solved.correction, pose)

    def session(self, estimator, pose: np.ndarray) -> MappingSession | None:
        """The mapping session so far (``pose``: the filter's newest), else the one gone on from."""
        if self.back_end is not None and isinstance(estimator, RBPFSlam):
            return self.back_end.session(estimator, self.solved, self.map_pose(pose)) or self.prior
        return self.prior

    def updated(self, estimator, scan) -> None:
        """The filter just updated with ``scan``: hand it to the back end, draw it into the published map."""
        if self.back_end is None:
            return
        self.back_end.updated(estimator, scan)
        if self.published_grid is not None:
            laser = estimator.poses[estimator.best_index()]  # the filter's poses are the laser's
            self.published_grid.integrate(scan, compose(self.solved.correction, laser))

    def failure(self) -> str | None:
        """Why the back end's last solve failed, once (see :meth:`LiveBackEnd.failure`)."""
        return self.back_end.failure() if self.back_end is not None else None

    def take(self, estimator, pose: np.ndarray) -> np.ndarray | None:
        """Use a finished solve: its correction, and its map with the updates since drawn in.
        Returns the jump ``[dx, dy, dyaw]`` of the filter's ``pose`` as published (corrected) when
        the solve closed a loop: the correction turns, so the jump depends on where it is measured."""
        if self.back_end is None or not self.back_end.finished:
            return None
        before = self.map_pose(pose)
        # the last solve and its map (the published one) go before this solve's map is drawn:
        # one whole map held at a time
        self.solved = self.published_grid = None
        result = self.back_end.take()
        best = best_updates(estimator).poses
        jump = None
        if result.loop_edges > self.edges_seen:
            self.edges_seen = result.loop_edges
            self.closures += 1
            jump = compose(result.correction, pose) - before
            jump[2] = wrap_angle(jump[2])
        self.solved = result
        scans = self.back_end.scans
        mount = estimator.mount
        for k in range(len(result.poses) - self.back_end.prior_updates, len(scans)):
            result.grid.integrate(scans[k], mount.laser_poses(compose(result.correction, best[k])))
        self.published_grid = result.grid
        return jump

    def published_hits(self, session: MappingSession) -> SparseHits:
        """The published map's hit sums: the last solve's, with those of ``session``'s updates after it
        (:meth:`session`: at their corrected poses) added; after a solve only."""
        grid, solved = self.published_grid, self.solved
        hits = solved.hit_sums.on(grid.origin, grid.shape, grid.resolution)  # the grid only grows
        done = len(solved.poses)
        laser = session.laser_mount.laser_poses(session.poses[done:])
        return hits.plus(sparse_hit_sums(grid, laser, session.scans[done:], grid.model))

    def wait(self) -> None:
        """Until the running solve (if any) is done."""
        if self.back_end is not None:
            self.back_end.wait()

    def corrected(self, estimate: Estimate) -> Estimate:
        """The filter's estimate in the map frame: the back end's correction composed with it."""
        if self.solved is None:
            return estimate
        c = self.solved.correction
        particles = None if estimate.particles is None else compose(c, estimate.particles)
        return replace(estimate, pose=compose(c, estimate.pose), particles=particles)

    def published_map(self, estimator) -> OccupancyGrid | None:
        return self.published_grid if self.published_grid is not None else estimator.occupancy_map()

    def stats(self) -> dict:
        """``{"closures", "edges", "solves"}`` for the status."""
        return {"closures": self.closures, "edges": self.solved.loop_edges if self.solved else 0,
                "solves": self.back_end.solves if self.back_end else 0}
