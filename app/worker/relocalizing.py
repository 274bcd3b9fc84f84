"""The worker's relocalization step: the guess it searches around, scan after scan, until the robot is found.

:class:`~app.worker.relocalize.Relocalizer` searches a restored map for one scan. Between scans
:class:`Relocalizing` keeps where the search began (the odometry and the pose then), so each guess
is that pose carried on by the odometry since. After a worker restart the search begins at the last
worker's ``map -> odom`` correction composed with the odometry: the robot link kept the odometry
(and maybe the robot) going while no worker ran.
"""

from __future__ import annotations

import numpy as np

from app.worker.frames import pose_in_map
from app.worker.relocalize import Fix, Relocalizer
from slam_core.geometry import compose, relative


class Relocalizing:
    """One search for the robot in ``relocalizer``'s map; ``correction`` the last worker's map -> odom."""

    def __init__(self, relocalizer: Relocalizer, correction: np.ndarray | None = None):
        self.relocalizer = relocalizer
        self.correction = correction
        self.began: tuple[np.ndarray, np.ndarray] | None = None  # (odometry, pose) when the search began

    def restart(self) -> None:
        """A person gave the pose: the search begins again at the worker's pose (theirs)."""
        self.began = self.correction = None

    def locate(self, odometry, scan, pose: np.ndarray) -> tuple[Fix | None, np.ndarray]:
        """``(fix or None, guess)`` for ``scan`` taken at ``odometry``; ``pose`` is the worker's pose,
        where the search begins unless a correction says better."""
        odometry = np.asarray(odometry, float)
        if self.began is None:
            start = pose.copy() if self.correction is None else pose_in_map(self.correction, odometry)
            self.began, self.correction = (odometry.copy(), start), None
        odo0, pose0 = self.began
        guess = compose(pose0, relative(odo0, odometry))
        return self.relocalizer.locate(scan, guess), guess
