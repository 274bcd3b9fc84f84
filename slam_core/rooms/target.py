"""Where to drive to reach a room: of the room's cells the robot can reach, the one deepest inside.

"Reach" is the planner's: cells of the (zone-restricted) costmap a robot at the start can get to
through passable cells, 4-connected (a subset of what the 8-connected, no-corner-cutting A*
reaches, so every target it picks can be planned to). A start that lies in a lethal cell (next to
a wall, or carried into a zone) counts from the nearest passable cell, where the planner leaves to.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from slam_core.distance_transform import distance_to_features
from slam_core.planning.costmap import Costmap
from slam_core.planning.errors import PlanningError
from slam_core.rooms.layout import RoomLayout


class RoomUnreachable(PlanningError):
    reason = "room_unreachable"


def reachable(costmap: Costmap, start_xy) -> np.ndarray:
    """``bool[iy, ix]``: the passable cells connected to the start (all ``False`` when none is passable)."""
    passable = costmap.traversable()
    if not passable.any():
        return passable
    start = np.clip(costmap.world_to_cell(np.asarray(start_xy, float)[:2]), 0,
                    [costmap.shape[1] - 1, costmap.shape[0] - 1])
    _, (iy, ix) = ndimage.distance_transform_edt(~passable, return_indices=True)
    labels, _ = ndimage.label(passable)
    return labels == labels[iy[start[1], start[0]], ix[start[1], start[0]]]


def room_target(layout: RoomLayout, room: int, costmap: Costmap, start_xy) -> tuple[float, float]:
    """The point of ``room`` farthest from its borders among the cells reachable from ``start_xy``;
    ``KeyError`` for an unknown room, :class:`RoomUnreachable` when no cell of it can be reached."""
    if room not in layout.ids():
        raise KeyError(f"no room with id {room}")
    iy, ix = np.nonzero(layout.labels == room)
    y0, x0 = iy.min(), ix.min()
    inside = np.pad(layout.labels[y0:iy.max() + 1, x0:ix.max() + 1] == room, 1)
    depth = distance_to_features(~inside)[iy - y0 + 1, ix - x0 + 1]
    res = layout.resolution
    centres = np.asarray(layout.origin, float) + (np.stack([ix, iy], axis=1) + 0.5) * res
    cells = costmap.world_to_cell(centres)
    ny, nx = costmap.shape
    ok = (cells[:, 0] >= 0) & (cells[:, 0] < nx) & (cells[:, 1] >= 0) & (cells[:, 1] < ny)
    ok[ok] = reachable(costmap, start_xy)[cells[ok, 1], cells[ok, 0]]
    if not ok.any():
        raise RoomUnreachable(f"no part of room {layout.name(room)!r} can be reached from the robot "
                              "(walls, no-go zones or unmapped space in the way)")
    best = np.flatnonzero(ok)[int(np.argmax(depth[ok]))]
    return float(centres[best, 0]), float(centres[best, 1])
