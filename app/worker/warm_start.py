"""A first map while numba compiles: the warm-up runs in a thread, a preview maps meanwhile.

On a fresh install numba compiles the filter's kernels for half a minute or more (minutes on a
busy machine). Rather than show nothing for that long, the worker starts its sources at once and
runs :func:`app.worker.estimators.warm_up` in a :class:`BackgroundWarmUp`. Until it is done,
each scan goes to a :class:`PreviewMap`: drawn into a plain occupancy grid at the odometry's
pose (no filter, so "not localized") and, when it moved the robot, kept. Once the kernels are
ready the filter catches up on the kept scans and the preview is dropped, so the map the filter
builds is the one a warm start would have built.
"""

from __future__ import annotations

import threading

import numpy as np

from app.worker.estimators import WARM_UP_BEAMS, warm_up
from app.worker.map_limits import check_room, scan_reach
from app.worker.shared_map import MapTooLarge
from slam_core.geometry import relative
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.scan import Scan

#: A scan is kept for the filter when the robot moved this far (m, rad) since the last kept one;
#: a fraction of the filter's update thresholds, so the filter sees the motion as it would live.
KEEP_LINEAR_M = 0.05
KEEP_ANGULAR = 0.025


class BackgroundWarmUp:
    """:func:`warm_up` in a daemon thread; :meth:`done` re-raises what it raised."""

    def __init__(self, settings, mode: str, progress=None):
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, args=(settings, mode, progress), name="warm-up",
                                        daemon=True)
        self._thread.start()

    def _run(self, settings, mode: str, progress) -> None:
        try:
            warm_up(settings, progress, mode)
        except BaseException as exc:  # handed to the loop's thread by done()
            self._error = exc

    def done(self) -> bool:
        if self._thread.is_alive():
            return False
        if self._error is not None:
            raise self._error
        return True


class PreviewMap:
    """Scans drawn at the odometry's pose while the filter is not ready, and the pairs to replay."""

    def __init__(self, resolution: float, mount, capacity_cells: int):
        self.grid = OccupancyGrid(resolution)
        self.mount = mount
        self.capacity_cells = capacity_cells
        self.pairs: list = []
        self._kept_at: np.ndarray | None = None
        # Compile (or load) the one kernel drawing needs now, before the warm-up holds numba's lock.
        angles = np.linspace(-np.pi, np.pi, WARM_UP_BEAMS, endpoint=False)
        OccupancyGrid(resolution).integrate(Scan(angles, np.full(WARM_UP_BEAMS, 1.0), 0.1, 8.0), np.zeros(3))

    def add(self, pair, pose: np.ndarray) -> None:
        """Draw ``pair``'s scan at the robot ``pose`` (map frame), within the map's size limit;
        keep the pair if the robot moved."""
        g = self.grid
        box = (*g.origin, *(g.origin + np.array(g.shape[::-1]) * g.resolution)) if g.data.size else None
        try:
            check_room(box, pose, scan_reach(pair.scan, g.model), g.resolution, self.capacity_cells)
            g.integrate(pair.scan, self.mount.laser_poses(pose))
        except MapTooLarge:
            pass  # the filter, catching up, pauses mapping there with an event
        odometry = np.asarray(pair.odometry.pose, float)
        if self._kept_at is not None:
            dx, dy, dth = relative(self._kept_at, odometry)
            if np.hypot(dx, dy) < KEEP_LINEAR_M and abs(dth) < KEEP_ANGULAR:
                return
        self.pairs.append(pair)
        self._kept_at = odometry
