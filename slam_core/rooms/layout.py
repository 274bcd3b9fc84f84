"""Rooms with ids and names that last: segment after segment as the map grows, and people's edits.

A :class:`RoomLayout` is a label grid (room id per cell, world frame given by origin and
resolution) and the rooms' names. :func:`follow` turns a fresh segmentation into the next
layout: a new segment takes the id of the old room it mostly lies in (or that mostly lies in
it), so rooms keep their ids and names while the map grows; segments that are new get new ids.
Merges and splits that a person made are kept as :class:`Edits` and applied again after
every segmentation.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from slam_core.occupancy_grid import OccupancyGrid
from slam_core.rooms.segmentation import NO_ROOM

#: A new segment keeps an old id when at least this share of it (or of the old room) overlaps.
KEEP_SHARE = 0.5
#: Both halves of a split need at least this many cells.
MIN_SPLIT_CELLS = 20


class RoomEditError(ValueError):
    """An edit that cannot be made; ``str()`` says why."""


@dataclass(frozen=True)
class Split:
    """Room ``room`` cut by the line through ``a`` and ``b``; the cells left of it became ``new``."""

    room: int
    new: int
    a: tuple[float, float]
    b: tuple[float, float]


@dataclass(frozen=True)
class Merge:
    """Room ``absorb`` joined room ``keep``."""

    keep: int
    absorb: int


@dataclass(frozen=True)
class Edits:
    """What people changed: names, and merges and splits in the order they were made."""

    names: dict[int, str] = field(default_factory=dict)
    operations: tuple[Merge | Split, ...] = ()


@dataclass(frozen=True)
class RoomLayout:
    labels: np.ndarray
    origin: tuple[float, float]
    resolution: float
    next_id: int = 1
    edits: Edits = field(default_factory=Edits)

    # reading
    def ids(self) -> list[int]:
        return [int(i) for i in np.unique(self.labels) if i != NO_ROOM]

    def name(self, room: int) -> str:
        return self.edits.names.get(room, f"Room {room}")

    def find(self, name: str) -> int:
        """The id of the room called ``name`` (case-insensitive); ``KeyError`` when there is none."""
        for room in self.ids():
            if self.name(room).casefold() == name.casefold():
                return room
        raise KeyError(f"no room named {name!r}")

    def cell_of(self, x: float, y: float) -> tuple[int, int] | None:
        ix = int(np.floor((x - self.origin[0]) / self.resolution))
        iy = int(np.floor((y - self.origin[1]) / self.resolution))
        ny, nx = self.labels.shape
        return (ix, iy) if 0 <= ix < nx and 0 <= iy < ny else None

    def room_at(self, x: float, y: float) -> int | None:
        """The room under a world point (``None`` outside every room)."""
        cell = self.cell_of(x, y)
        if cell is None:
            return None
        label = int(self.labels[cell[1], cell[0]])
        return None if label == NO_ROOM else label

    def centres(self, room: int) -> np.ndarray:
        """World centres ``(n, 2)`` of the room's cells."""
        iy, ix = np.nonzero(self.labels == room)
        return np.asarray(self.origin) + (np.stack([ix, iy], 1) + 0.5) * self.resolution

    def summary(self, room: int) -> dict:
        centres = self.centres(room)
        return {"id": room, "name": self.name(room),
                "area": round(len(centres) * self.resolution ** 2, 2),
                "centroid": [round(float(v), 3) for v in centres.mean(0)]}

    # editing
    def renamed(self, room: int, name: str) -> RoomLayout:
        self._check(room)
        for other in self.ids():
            if other != room and self.name(other).casefold() == name.casefold():
                raise RoomEditError(f"a room named {name!r} exists")
        return replace(self, edits=replace(self.edits, names={**self.edits.names, room: name}))

    def merged(self, keep: int, absorb: int) -> RoomLayout:
        self._check(keep)
        self._check(absorb)
        if keep == absorb:
            raise RoomEditError("a room cannot be merged with itself")
        labels = np.where(self.labels == absorb, keep, self.labels).astype(np.int32)
        names = {k: v for k, v in self.edits.names.items() if k != absorb}
        edits = replace(self.edits, names=names, operations=(*self.edits.operations, Merge(keep, absorb)))
        return replace(self, labels=labels, edits=edits)

    def split(self, room: int, a, b) -> RoomLayout:
        """Cut ``room`` along the line through world points ``a`` and ``b``."""
        self._check(room)
        cut = Split(room, self.next_id, (float(a[0]), float(a[1])), (float(b[0]), float(b[1])))
        if np.hypot(cut.b[0] - cut.a[0], cut.b[1] - cut.a[1]) < self.resolution:
            raise RoomEditError("the split line needs two distinct points")
        labels = _apply_split(self.labels, self.origin, self.resolution, cut)
        if (labels == cut.new).sum() < MIN_SPLIT_CELLS or (labels == room).sum() < MIN_SPLIT_CELLS:
            raise RoomEditError("the line does not cut the room in two")
        edits = replace(self.edits, operations=(*self.edits.operations, cut))
        return replace(self, labels=labels, next_id=self.next_id + 1, edits=edits)

    def _check(self, room: int) -> None:
        if room not in self.ids():
            raise RoomEditError(f"no room with id {room}")


def follow(previous: RoomLayout | None, segments: np.ndarray, grid: OccupancyGrid) -> RoomLayout:
    """The layout for a fresh segmentation ``segments`` of ``grid``, keeping ``previous``'s ids and edits."""
    origin = (float(grid.origin[0]), float(grid.origin[1]))
    if previous is None:
        return RoomLayout(segments.astype(np.int32), origin, grid.resolution, int(segments.max()) + 1)
    old = _aligned(previous, origin, segments.shape)
    for cut in reversed(previous.edits.operations):  # match against the rooms as segmented: splits undone
        if isinstance(cut, Split):
            old[old == cut.new] = cut.room
    labels = np.zeros(segments.shape, np.int32)
    next_id = previous.next_id
    n = int(segments.max())
    pairs = np.stack([segments.ravel(), old.ravel()], 1)
    pairs = pairs[(pairs[:, 0] != NO_ROOM) & (pairs[:, 1] != NO_ROOM)]
    overlap: dict[tuple[int, int], int] = {}
    if len(pairs):
        keys, counts = np.unique(pairs, axis=0, return_counts=True)
        overlap = {(int(k[0]), int(k[1])): int(c) for k, c in zip(keys, counts, strict=True)}
    sizes = np.bincount(segments.ravel(), minlength=n + 1)
    old_sizes = np.bincount(old.ravel())
    for segment in range(1, n + 1):
        candidates = [(c, o) for (s, o), c in overlap.items() if s == segment]
        keep = None
        if candidates:
            count, room = max(candidates)
            if count >= KEEP_SHARE * sizes[segment] or count >= KEEP_SHARE * old_sizes[room]:
                keep = room
        if keep is None:
            keep, next_id = next_id, next_id + 1
        labels[segments == segment] = keep
    for edit in previous.edits.operations:
        if isinstance(edit, Merge):
            labels[labels == edit.absorb] = edit.keep
        else:
            labels = _apply_split(labels, origin, grid.resolution, edit)
    return RoomLayout(labels, origin, grid.resolution, next_id, previous.edits)


def _aligned(layout: RoomLayout, origin: tuple[float, float], shape: tuple[int, int]) -> np.ndarray:
    """``layout.labels`` on a grid of ``shape`` at ``origin`` (same resolution; 0 where it had none)."""
    out = np.zeros(shape, np.int32)
    dx, dy = (round((layout.origin[i] - origin[i]) / layout.resolution) for i in (0, 1))
    ny, nx = layout.labels.shape
    y0, x0 = max(dy, 0), max(dx, 0)
    y1, x1 = min(dy + ny, shape[0]), min(dx + nx, shape[1])
    if y1 > y0 and x1 > x0:
        out[y0:y1, x0:x1] = layout.labels[y0 - dy:y1 - dy, x0 - dx:x1 - dx]
    return out


def _apply_split(labels: np.ndarray, origin, resolution: float, cut: Split) -> np.ndarray:
    iy, ix = np.nonzero(labels == cut.room)
    if len(iy) == 0:
        return labels
    x = origin[0] + (ix + 0.5) * resolution
    y = origin[1] + (iy + 0.5) * resolution
    (ax, ay), (bx, by) = cut.a, cut.b
    left = (bx - ax) * (y - ay) - (by - ay) * (x - ax) > 0
    out = labels.copy()
    out[iy[left], ix[left]] = cut.new
    return out
