"""The room service's cost stays bounded: costly segmentations are spaced out, and a map far
larger than a home (a campus) is not segmented at all."""

from __future__ import annotations

import asyncio

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

import app.rooms.service as service_module
from app.db.rooms import RoomStore
from app.rooms.service import MAX_SHARE, REFRESH_S, RoomService, pause_after
from slam_core.occupancy_grid import OccupancyGrid


def _walled_room(ny: int, nx: int) -> OccupancyGrid:
    data = np.full((ny, nx), -2.0, np.float32)
    data[[0, -1], :] = data[:, [0, -1]] = 2.0
    return OccupancyGrid(0.05, (0.0, 0.0), data=data)


@given(st.floats(0.0, 600.0))
def test_segmenting_takes_at_most_its_share_of_the_time(cost):
    pause = pause_after(cost)
    assert pause >= REFRESH_S
    assert cost <= MAX_SHARE * (cost + pause) + 1e-9


def test_a_map_over_the_limit_is_neither_rebuilt_nor_segmented_and_one_under_it_is(tmp_path, monkeypatch):
    maps, built = [_walled_room(60, 80), _walled_room(40, 40)], []

    def grid():
        built.append(maps[0])
        return maps[0]

    service = RoomService(grid, lambda: maps[0].data.size, RoomStore(tmp_path / "rooms.sqlite3"))
    monkeypatch.setattr(service_module, "MAX_ROOM_CELLS", 40 * 40)
    asyncio.run(service.refresh())
    assert service.layout is None and service.rooms() == [] and built == []  # no grid made for it
    maps.pop(0)
    asyncio.run(service.refresh())
    assert service.layout is not None and len(service.rooms()) == 1 and len(built) == 1
