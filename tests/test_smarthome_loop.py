"""Nothing of the smart home blocks the event loop: rebuilding the map for the MQTT map image and
for the room segmentation happens in threads, so a ticker on the loop keeps its pace while it
takes a second."""

from __future__ import annotations

import asyncio
import time
from types import SimpleNamespace

import numpy as np

from app.core.config import Settings
from app.db.rooms import RoomStore
from app.rooms.service import RoomService
from app.smarthome.bridge import MqttBridge
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.rooms import segment_rooms

SLOW_S = 1.0
TICK_S = 0.01


def _slow_grid() -> OccupancyGrid:
    time.sleep(SLOW_S)  # as rebuilding a large map from the shared block would
    data = np.full((60, 80), -2.0, np.float32)
    data[[0, -1], :] = data[:, [0, -1]] = 2.0
    return OccupancyGrid(0.05, (0.0, 0.0), data=data)


async def _longest_stall(work) -> float:
    """The longest the loop went without running a ticker while ``work`` ran."""
    longest, running = 0.0, True

    async def ticker():
        nonlocal longest
        last = time.monotonic()
        while running:
            await asyncio.sleep(TICK_S)
            now = time.monotonic()
            longest, last = max(longest, now - last), now

    task = asyncio.create_task(ticker())
    await asyncio.sleep(TICK_S)  # the ticker runs before the work starts
    await work()
    running = False
    await task
    return longest


def test_the_map_image_is_rendered_off_the_loop(tmp_path):
    published = []
    runtime = SimpleNamespace(settings=Settings(data_dir=tmp_path, mqtt_host="127.0.0.1"),
                              map_snapshot=SimpleNamespace(seq=1), current_grid=_slow_grid)

    async def run():
        bridge = MqttBridge(runtime)
        bridge.link.connected.set()
        bridge.link.publish = lambda topic, payload, **_: published.append((topic, payload)) or True
        pump = asyncio.create_task(bridge._map_pump())

        async def until_published():
            while not published:
                await asyncio.sleep(0.05)

        stall = await _longest_stall(until_published)
        pump.cancel()
        return stall

    stall = asyncio.run(run())
    assert published and published[0][0] == "homebot/map/image" and published[0][1][:4] == b"\x89PNG"
    assert stall < SLOW_S / 2, f"the loop stalled {stall:.2f} s"


def test_the_rooms_are_segmented_off_the_loop(tmp_path):
    segment_rooms(_slow_grid())  # loading numba's cached kernels holds the GIL once per process
    service = RoomService(_slow_grid, lambda: 60 * 80, RoomStore(tmp_path / "rooms.sqlite3"))  # its size
    stall = asyncio.run(_longest_stall(service.refresh))
    assert service.layout is not None and len(service.rooms()) == 1
    assert stall < SLOW_S / 2, f"the loop stalled {stall:.2f} s"
