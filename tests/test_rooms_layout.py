"""Rooms keep their ids, names and people's edits while the map grows."""

from __future__ import annotations

from collections import deque

import numpy as np
import pytest

from app.db.rooms import RoomStore
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.rooms import segment_rooms
from slam_core.rooms.layout import RoomEditError, follow
from slam_core.sim.ground_truth import ground_truth_map
from slam_core.sim.world import load_world

STEPS_M = (3.0, 5.0, 7.0, 9.0, 12.0, 30.0)


def _seen_within(grid: OccupancyGrid, start, reach_m: float) -> OccupancyGrid:
    """The map as a robot that went at most ``reach_m`` (through free space) from ``start`` knows it,
    cropped to what it knows (so the origin moves as it grows)."""
    free = grid.data < 0
    ny, nx = free.shape
    reach = int(reach_m / grid.resolution)
    sx, sy = grid.world_to_cell(start)
    dist = np.full(free.shape, -1)
    dist[sy, sx] = 0
    queue = deque([(sx, sy)])
    while queue:
        x, y = queue.popleft()
        if dist[y, x] >= reach:
            continue
        for ax, ay in ((x + 1, y), (x - 1, y), (x, y + 1), (x, y - 1)):
            if 0 <= ax < nx and 0 <= ay < ny and free[ay, ax] and dist[ay, ax] < 0:
                dist[ay, ax] = dist[y, x] + 1
                queue.append((ax, ay))
    near = np.zeros_like(free)
    ys, xs = np.nonzero(dist >= 0)
    for dy in (-2, -1, 0, 1, 2):  # the walls around what was seen
        for dx in (-2, -1, 0, 1, 2):
            near[np.clip(ys + dy, 0, ny - 1), np.clip(xs + dx, 0, nx - 1)] = True
    data = np.where(near, grid.data, 0.0).astype(np.float32)
    rows, cols = np.nonzero(near.any(1))[0], np.nonzero(near.any(0))[0]
    y0, y1, x0, x1 = max(rows[0] - 8, 0), rows[-1] + 9, max(cols[0] - 8, 0), cols[-1] + 9
    origin = grid.origin + np.array([x0, y0]) * grid.resolution
    return OccupancyGrid(grid.resolution, origin, data=data[y0:y1, x0:x1])


@pytest.mark.parametrize("world", ["flat", "house"])
def test_rooms_keep_their_ids_while_the_map_grows(world):
    w = load_world(world)
    full = ground_truth_map(w, 0.05)
    layout, history = None, []
    for reach in STEPS_M:
        grid = _seen_within(full, w.start[:2], reach)
        layout = follow(layout, segment_rooms(grid), grid)
        history.append(layout)
    final = history[-1]
    final_areas = {r: final.summary(r)["area"] for r in final.ids()}
    kept = 0
    for earlier in history[:-1]:
        for room in earlier.ids():
            s = earlier.summary(room)
            cells = earlier.centres(room)
            inside = cells[len(cells) // 2]  # a cell of the room (a centroid may lie outside it)
            now = final.room_at(*inside)
            if now is not None and abs(final_areas[now] - s["area"]) <= 0.1 * final_areas[now]:
                assert now == room, f"room {room} ({s}) became {now}"
                kept += 1
    assert kept >= 3
    start_room = history[0].room_at(*w.start[:2])
    assert all(layout.room_at(*w.start[:2]) == start_room for layout in history)
    # Ids are never reused for a different room: the final ids are all distinct rooms of the world.
    assert len(final.ids()) == len(set(final.ids())) == int(segment_rooms(full).max())


def test_names_merges_and_splits_survive_the_next_segmentation():
    grid = ground_truth_map(load_world("flat"), 0.05)
    segments = segment_rooms(grid)
    layout = follow(None, segments, grid)
    kitchen, study = layout.room_at(3.0, 1.5), layout.room_at(5.2, 1.5)
    bedroom, living = layout.room_at(2.8, 5.2), layout.room_at(8.0, 4.0)
    layout = layout.renamed(kitchen, "Kitchen").merged(bedroom, layout.room_at(5.2, 6.0))
    layout = layout.split(living, (6.5, 4.0), (10.0, 4.0))
    north = layout.room_at(8.0, 6.0)
    assert north not in (None, living) and layout.room_at(8.0, 2.0) == living
    again = follow(layout, segments, grid)
    assert again.name(kitchen) == "Kitchen" and again.find("kitchen") == kitchen
    assert again.room_at(5.2, 6.0) == bedroom  # the bathroom stays merged into the bedroom
    assert again.room_at(8.0, 6.0) == north and again.room_at(8.0, 2.0) == living
    assert again.room_at(5.2, 1.5) == study
    assert len(again.ids()) == len(layout.ids()) == 6


def test_a_split_merged_back_stays_merged(tmp_path):
    grid = ground_truth_map(load_world("flat"), 0.05)
    segments = segment_rooms(grid)
    layout = follow(None, segments, grid)
    hall = layout.room_at(1.0, 3.75)
    split = layout.split(hall, (3.0, 3.0), (3.0, 4.5))
    west = split.room_at(1.0, 3.75)
    assert west != hall
    merged = split.merged(hall, west)
    for again in (follow(merged, segments, grid), follow(follow(merged, segments, grid), segments, grid)):
        assert again.room_at(1.0, 3.75) == again.room_at(5.0, 3.75) == hall
        assert len(again.ids()) == len(layout.ids())
    # and the edits come back from the database in the same order
    store = RoomStore(tmp_path / "rooms.sqlite3")
    store.save("home", merged)
    loaded = store.load("home")
    assert loaded.edits == merged.edits and np.array_equal(loaded.labels, merged.labels)


def test_bad_edits_are_refused_with_a_reason():
    grid = ground_truth_map(load_world("flat"), 0.05)
    layout = follow(None, segment_rooms(grid), grid)
    kitchen, study = layout.room_at(3.0, 1.5), layout.room_at(5.2, 1.5)
    with pytest.raises(RoomEditError, match="itself"):
        layout.merged(kitchen, kitchen)
    with pytest.raises(RoomEditError, match="no room with id 99"):
        layout.merged(kitchen, 99)
    with pytest.raises(RoomEditError, match="does not cut"):
        layout.split(kitchen, (20.0, 0.0), (20.0, 1.0))
    with pytest.raises(RoomEditError, match="distinct"):
        layout.split(kitchen, (1.0, 1.0), (1.0, 1.0))
    with pytest.raises(RoomEditError, match="exists"):
        layout.renamed(kitchen, "x").renamed(study, "X")
    with pytest.raises(KeyError):
        layout.find("garage")
