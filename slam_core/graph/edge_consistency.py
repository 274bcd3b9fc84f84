"""Loop edges into one submap from updates a few steps apart must agree on the motion between them.

Two edges ``(a, q)`` and ``(a, q')`` into the same submap anchor imply the laser's motion from
``q`` to ``q'``: the second measured pose seen from the first. Both edges true, that motion is
the one the robot made, which the filter's step and the wheel odometry's each saw: one of them
may be wrong (a slid match, a stalled wheel), seldom both at once. An edge that a look-alike
place put in the wrong spot implies a motion that neither witness saw. So an edge is
inconsistent when, against most of the edges into its anchor within ``reach`` updates of it,
the implied motion lands farther than ``tolerance`` from both the filter's and the odometry's
steps; an edge with no such neighbour is not judged here (the robust pose graph still is).
"""

from __future__ import annotations

import numpy as np

from slam_core.geometry import relative

#: How many updates apart two edges into one anchor are compared.
REACH = 3


def inconsistent_edges(edges: dict, poses: np.ndarray, odometry: np.ndarray | None,
                       tolerance: float, reach: int = REACH) -> list[tuple[int, int]]:
    """Keys of the loop ``edges`` ``{(anchor, update): (z, information)}`` whose implied motion
    disagrees with more of their neighbours' than it agrees with. ``poses`` are the filter's
    laser poses at the updates, ``odometry`` the odometry's laser poses there (or None: the
    filter is the only witness)."""
    keys = sorted(edges)
    if len(keys) < 2:
        return []
    anchors, updates = np.array(keys, np.int64).T
    z = np.array([edges[k][0] for k in keys], dtype=np.float64)
    first, second = [], []
    for gap in range(1, reach + 1):  # keys are sorted by anchor, then update
        for shift in range(1, gap + 1):
            i = np.arange(len(keys) - shift)
            pick = (anchors[i] == anchors[i + shift]) & (updates[i + shift] - updates[i] == gap)
            first.append(i[pick])
            second.append(i[pick] + shift)
    i, j = np.concatenate(first), np.concatenate(second)
    implied = relative(z[i], z[j])
    agree = _near(implied, relative(poses[updates[i]], poses[updates[j]]), tolerance)
    if odometry is not None:
        agree |= _near(implied, relative(odometry[updates[i]], odometry[updates[j]]), tolerance)
    votes = np.zeros(len(keys), np.int64)  # disagreeing neighbours minus agreeing ones
    np.add.at(votes, i, np.where(agree, -1, 1))
    np.add.at(votes, j, np.where(agree, -1, 1))
    return [keys[k] for k in np.flatnonzero(votes > 0)]


def _near(implied: np.ndarray, steps: np.ndarray, tolerance: float) -> np.ndarray:
    return np.hypot(implied[:, 0] - steps[:, 0], implied[:, 1] - steps[:, 1]) <= tolerance
