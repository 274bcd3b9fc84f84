"""Room segmentation against the simulator's worlds, whose rooms are known.

The flat's rooms are its ``room`` statements; the house's are written out below from its
floor plan (``slam_core/sim/worlds/house.txt``: the corridor is the ring between the outer
side and the inner side of the loop). Each true room must be found, with an intersection
over union >= 0.8 over the map's free cells.
"""

from __future__ import annotations

import numpy as np
import pytest

from slam_core.rooms import NO_ROOM, segment_rooms
from slam_core.sim.ground_truth import ground_truth_map
from slam_core.sim.world import WORLDS_DIR, load_world

#: Rooms as unions of rectangles (x0, y0, x1, y1); minus ``holes``.
HOUSE = {
    "bedroom 1": [(0, 0, 7, 3)], "office": [(7, 0, 13, 3)], "bedroom 2": [(13, 0, 20, 3)],
    "entrance": [(0, 3, 3, 11)], "laundry": [(17, 3, 20, 11)], "bathroom": [(0, 11, 6, 14)],
    "dining room": [(6, 11, 14, 14)], "utility": [(14, 11, 20, 14)],
    "kitchen": [(4.5, 4.5, 10, 9.5)], "living room": [(10, 4.5, 15.5, 9.5)],
    "corridor": [(3, 3, 17, 4.5), (3, 9.5, 17, 11), (3, 4.5, 4.5, 9.5), (15.5, 4.5, 17, 9.5)],
}


def _flat_rooms() -> dict[str, list[tuple[float, ...]]]:
    rooms = {}
    for line in (WORLDS_DIR / "flat.txt").read_text().splitlines():
        words = line.split("#")[0].split()
        if words[:1] == ["room"]:
            rooms[words[1]] = [tuple(float(v) for v in words[2:6])]
    return rooms


def _truth(grid, rooms: dict) -> dict[str, np.ndarray]:
    ny, nx = grid.shape
    ix, iy = np.meshgrid(np.arange(nx), np.arange(ny))
    centres = grid.cell_to_world(np.stack([ix, iy], -1))
    masks = {}
    for name, rects in rooms.items():
        inside = np.zeros((ny, nx), bool)
        for x0, y0, x1, y1 in rects:
            inside |= ((centres[..., 0] > x0) & (centres[..., 0] < x1) &
                       (centres[..., 1] > y0) & (centres[..., 1] < y1))
        masks[name] = inside
    return masks


def _ious(labels: np.ndarray, truth: dict[str, np.ndarray], free: np.ndarray) -> dict[str, float]:
    best = {}
    for name, mask in truth.items():
        room = mask & free
        scores = [0.0]
        for label in np.unique(labels[room]):
            if label == NO_ROOM:
                continue
            found = (labels == label) & free
            scores.append((room & found).sum() / (room | found).sum())
        best[name] = max(scores)
    return best


@pytest.mark.parametrize("world", ["flat", "house"])
def test_segmentation_recovers_every_room_of_the_world(world):
    grid = ground_truth_map(load_world(world), 0.05)
    truth = _truth(grid, _flat_rooms() if world == "flat" else HOUSE)
    labels = segment_rooms(grid)
    free = grid.probability() < 0.5
    ious = _ious(labels, truth, free)
    assert min(ious.values()) >= 0.8, ious
    assert labels.max() == len(truth), f"{labels.max()} rooms found, {len(truth)} true"
    assert (labels[~free] == NO_ROOM).all()
    assert (labels[free] != NO_ROOM).mean() > 0.99


def test_labels_do_not_depend_on_where_the_grid_starts():
    grid = ground_truth_map(load_world("flat"), 0.05)
    shifted = ground_truth_map(load_world("flat"), 0.05)
    pad = 13
    shifted.data = np.pad(grid.data, ((pad, 0), (pad, 0)))
    shifted.origin = grid.origin - pad * grid.resolution
    a, b = segment_rooms(grid), segment_rooms(shifted)
    assert np.array_equal(a, b[pad:, pad:])


def test_an_empty_or_unknown_map_has_no_rooms():
    grid = ground_truth_map(load_world("flat"), 0.05)
    grid.data[:] = 0.0  # nothing seen
    assert segment_rooms(grid).max() == NO_ROOM
