"""Particle trajectories as a tree: copies made by resampling share their history."""

from __future__ import annotations

import numpy as np

ROOT = -1


class TrajectoryTree:
    """Nodes ``(parent, update, pose)``; a particle holds the index of its newest node."""

    def __init__(self, capacity: int = 1024):
        self.parent = np.empty(capacity, np.int64)
        self.update = np.empty(capacity, np.int64)
        self.pose = np.empty((capacity, 3))
        self.size = 0

    def add(self, parents: np.ndarray, update: int, poses: np.ndarray) -> np.ndarray:
        """Append one node per particle (``parents`` may be ``ROOT``); returns their indices."""
        n = len(parents)
        if self.size + n > len(self.parent):
            grow = max(len(self.parent), n)
            self.parent = np.concatenate([self.parent, np.empty(grow, np.int64)])
            self.update = np.concatenate([self.update, np.empty(grow, np.int64)])
            self.pose = np.concatenate([self.pose, np.empty((grow, 3))])
        idx = np.arange(self.size, self.size + n)
        self.parent[idx] = parents
        self.update[idx] = update
        self.pose[idx] = poses
        self.size += n
        return idx

    def path(self, node: int) -> tuple[np.ndarray, np.ndarray]:
        """``(updates, poses)`` from the root to ``node``, oldest first."""
        chain = []
        while node != ROOT:
            chain.append(node)
            node = int(self.parent[node])
        chain.reverse()
        chain = np.array(chain, dtype=np.int64)
        return self.update[chain], self.pose[chain]
