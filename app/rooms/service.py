"""The room service: segments the live map every few seconds (in a thread) when it changed.

Segmenting a large map takes seconds, so the pause between two refreshes grows with the last
one's cost (at most :data:`MAX_SHARE` of the time is spent segmenting), and a map larger than
:data:`MAX_ROOM_CELLS` (far beyond any home: a campus) is not segmented at all.

It keeps the current :class:`~slam_core.rooms.layout.RoomLayout` (ids, names and edits that
last as the map grows), stores it per map (:class:`~app.db.rooms.RoomStore`), answers which
room a point is in, and where to drive to reach a room (a point inside it the robot can reach).
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable

import numpy as np

from app.db.rooms import LIVE, RoomStore
from app.navigation.navigator import Goal, Navigator
from slam_core.distance_transform import distance_to_features
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.rooms import segment_rooms
from slam_core.rooms.layout import RoomEditError, RoomLayout, follow
from slam_core.rooms.target import room_target

log = logging.getLogger(__name__)

REFRESH_S = 5.0
#: Largest share of the time spent segmenting: the next refresh waits the last one's cost over this.
MAX_SHARE = 0.1
#: Maps with more cells are not segmented (4096 x 4096 cells: 4 ha at 5 cm).
MAX_ROOM_CELLS = 4096 * 4096


def pause_after(cost_s: float) -> float:
    """Seconds to wait after a refresh that took ``cost_s``: :data:`REFRESH_S`, longer for costly ones."""
    return max(REFRESH_S, cost_s / MAX_SHARE)


class RoomService:
    """The rooms of the map in use (the live one, or a saved one being localized in)."""

    def __init__(self, grid: Callable[[], OccupancyGrid | None], cells: Callable[[], int], store: RoomStore):
        self._grid = grid
        self._cells = cells  # the current map's cell count, known without building its grid
        self.store = store
        self.key = LIVE
        self.layout: RoomLayout | None = store.load(LIVE)
        self._segmented: OccupancyGrid | None = None
        self._too_large = False  # the last map was over MAX_ROOM_CELLS (said once)
        self._lock = asyncio.Lock()

    async def run(self) -> None:
        """Refresh until cancelled."""
        while True:
            started = time.monotonic()
            try:
                await self.refresh()
            except Exception:  # a segmentation bug must not stop the server; try again later
                log.exception("room segmentation failed")
            await asyncio.sleep(pause_after(time.monotonic() - started))

    async def refresh(self) -> None:
        """Segment the current map if it changed since the last time (a map over the limit is not
        even rebuilt as a grid)."""
        if self._oversized(self._cells()):
            return
        grid = await asyncio.to_thread(self._grid)  # rebuilt from the shared map: not on the loop
        if grid is None or grid is self._segmented:
            return
        async with self._lock:
            previous = self.layout
            self.layout = await asyncio.to_thread(lambda: follow(previous, segment_rooms(grid), grid))
            self._segmented = grid
            await asyncio.to_thread(self.store.save, self.key, self.layout)

    def _oversized(self, cells: int) -> bool:
        too_large = cells > MAX_ROOM_CELLS
        if too_large and not self._too_large:
            log.warning("the map has %d cells, over %d: its rooms are not segmented", cells, MAX_ROOM_CELLS)
        self._too_large = too_large
        return too_large

    async def edit(self, change: Callable[[RoomLayout], RoomLayout]) -> RoomLayout:
        """Apply one edit (rename, merge, split) and store it; ``RoomEditError`` when impossible."""
        async with self._lock:
            if self.layout is None:
                raise RoomEditError("there are no rooms yet: the map is still empty")
            self.layout = await asyncio.to_thread(change, self.layout)  # label grids: not on the loop
            await asyncio.to_thread(self.store.save, self.key, self.layout)
            return self.layout

    async def use_map(self, name: str) -> None:
        """Rooms of the saved map ``name`` from now on (stored with it when it was saved)."""
        async with self._lock:
            self.key = name
            self.layout = await asyncio.to_thread(self.store.load, name)
            self._segmented = None

    async def save_as(self, name: str) -> None:
        """Store the current rooms with a map just saved as ``name``."""
        if self.layout is not None:
            await asyncio.to_thread(self.store.save, name, self.layout)

    # reading
    def rooms(self) -> list[dict]:
        layout = self.layout
        return [] if layout is None else [layout.summary(r) for r in layout.ids()]

    def name_at(self, x: float, y: float) -> str | None:
        layout = self.layout
        room = None if layout is None else layout.room_at(x, y)
        return None if room is None else layout.name(room)

    def find(self, name: str) -> int:
        """The id of a room by name; ``KeyError`` (the reason) when there is none."""
        if self.layout is None:
            raise KeyError(f"no room named {name!r}: there are no rooms yet")
        return self.layout.find(name)

    async def goal(self, room: int, navigator: Navigator) -> Goal:
        """A goal inside ``room`` that the robot can reach (its reachable point deepest inside, see
        :func:`~slam_core.rooms.target.room_target`); ``KeyError`` when there is no such room,
        ``PlanningError`` (the reason) when no part of it can be reached."""
        layout = self.layout
        if layout is None or room not in layout.ids():
            raise KeyError(f"no room with id {room}")

        def where() -> tuple[float, float]:
            costmap, pose = navigator.navigable()
            return room_target(layout, room, costmap, pose)

        x, y = await asyncio.to_thread(where)
        return Goal(x, y, layout.name(room))


def room_centre(layout: RoomLayout, room: int) -> tuple[float, float]:
    """The point of ``room`` farthest from its borders (where the dashboard writes its name)."""
    iy, ix = np.nonzero(layout.labels == room)
    y0, y1, x0, x1 = iy.min(), iy.max() + 1, ix.min(), ix.max() + 1
    inside = np.pad(layout.labels[y0:y1, x0:x1] == room, 1)
    depth = distance_to_features(~inside)
    cy, cx = np.unravel_index(int(np.argmax(depth)), depth.shape)
    res = layout.resolution
    return (float(layout.origin[0] + (x0 + cx - 1 + 0.5) * res),
            float(layout.origin[1] + (y0 + cy - 1 + 0.5) * res))
