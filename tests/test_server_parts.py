"""The server's parts without a server: shared map, map frames, hub slots, names, store, limits."""

from __future__ import annotations

import asyncio
import json

import httpx
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.api.saved_maps import MAP_SUFFIXES
from app.core.limits import BodySizeLimit
from app.db.names import check_name
from app.db.store import AlreadyExists, NotFound, Place, Store
from app.robot.scan_slot import ScanSlot
from app.streaming import map_frames
from app.streaming.hub import FULL_MAP, Hub
from app.worker.shared_map import UNKNOWN, SharedMap, grid_cells
from slam_core.occupancy_grid import ROW_BLOCK, OccupancyGrid
from slam_core.scan import Scan
from slam_core.session import SUFFIX as SESSION_SUFFIX

TILE = 16


@pytest.fixture
def shared():
    owner = SharedMap(256 * 256, TILE, create=True)
    reader = SharedMap(256 * 256, TILE, name=owner.name)
    yield owner, reader
    reader.close()
    owner.close()
    owner.unlink()


def naive_changed_tiles(old: np.ndarray, new: np.ndarray, tile: int) -> set[int]:
    h, w = new.shape
    tx = -(-w // tile)
    out = set()
    for iy in range(h):
        for ix in range(w):
            if old[iy, ix] != new[iy, ix]:
                out.add((iy // tile) * tx + ix // tile)
    return out


@settings(max_examples=25, deadline=None)
@given(h=st.integers(1, 70), w=st.integers(1, 70), seed=st.integers(0, 2**32 - 1), n=st.integers(0, 30))
def test_stamps_mark_exactly_the_changed_tiles_and_frames_rebuild_the_map(h, w, seed, n):
    owner = SharedMap(128 * 128, TILE, create=True)
    try:
        rng = np.random.default_rng(seed)
        cells = rng.integers(0, 256, (h, w)).astype(np.uint8)
        owner.publish(cells, (0.5, -1.0), 0.05)
        first = owner.snapshot()
        canvas = map_frames.MapCanvas()
        canvas.apply(map_frames.decode(map_frames.encode(first, TILE)))
        assert np.array_equal(canvas.cells, cells)
        new = cells.copy()
        idx = rng.integers(0, h * w, n)
        new.ravel()[idx] = rng.integers(0, 256, n).astype(np.uint8)
        owner.publish(new, (0.5, -1.0), 0.05)
        second = owner.snapshot()
        changed = np.flatnonzero(second.stamps > first.seq)
        assert set(changed.tolist()) == naive_changed_tiles(cells, new, TILE)
        frame = map_frames.decode(map_frames.encode(second, TILE, changed))
        assert not frame.full and frame.seq == second.seq
        canvas.apply(frame)
        assert np.array_equal(canvas.cells, new)
    finally:
        owner.close()
        owner.unlink()


def test_a_grown_grid_is_a_new_layout_and_a_reader_sees_it(shared):
    owner, reader = shared
    owner.publish(np.zeros((20, 20), np.uint8), (0, 0), 0.05)
    s1 = reader.snapshot()
    owner.publish(np.zeros((40, 20), np.uint8), (0, -1.0), 0.05)
    s2 = reader.snapshot()
    assert s2.epoch == s1.epoch + 1 and (s2.height, s2.width) == (40, 20) and s2.origin == (0.0, -1.0)
    assert owner.publish(np.zeros((40, 20), np.uint8), (0, -1.0), 0.05) == s2.seq  # no change, no new seq


def test_a_writer_killed_mid_write_is_not_read_as_a_map(shared):
    owner, reader = shared
    owner.publish(np.zeros((8, 8), np.uint8), (0, 0), 0.05)
    owner.header[0] += 1  # odd write counter: a write that never finished
    assert reader.snapshot() is None
    owner.header[0] += 1
    assert reader.snapshot() is not None


def test_a_snapshot_rebuilds_the_occupancy_of_every_cell_value(shared):
    owner, reader = shared
    values = np.arange(256, dtype=np.uint8).reshape(16, 16)
    owner.publish(values, (1.0, -2.0), 0.05)
    grid = reader.snapshot().grid()
    assert grid.data.dtype == np.float32 and tuple(grid.origin) == (1.0, -2.0)
    percent = np.clip(values / 100.0, 0.01, 0.99)
    expected = np.where(values == UNKNOWN, 0.0, np.log(percent / (1.0 - percent)))
    np.testing.assert_allclose(grid.data, expected, atol=1e-6)


def test_grid_cells_percent_and_unknown():
    grid = OccupancyGrid(0.1, shape=(2, 2))
    grid.data[0, 0] = 10.0
    grid.data[1, 1] = -10.0
    cells = grid_cells(grid)
    assert cells[0, 0] == 100 and cells[1, 1] == 0 and cells[0, 1] == UNKNOWN
    rebuilt = map_frames.MapCanvas()
    assert rebuilt.cells is None


def test_grid_cells_of_a_map_taller_than_a_block_of_rows_are_each_cells_percent():
    rng = np.random.default_rng(4)
    data = rng.normal(0.0, 3.0, (ROW_BLOCK * 2 + 37, 53)) * (rng.random((ROW_BLOCK * 2 + 37, 53)) < 0.7)
    grid = OccupancyGrid(0.05, data=data.astype(np.float32))
    cells = grid_cells(grid)
    p = 1.0 / (1.0 + np.exp(-grid.data.astype(np.float64)))  # the oracle: every cell on its own
    np.testing.assert_array_equal(cells[grid.data != 0.0], np.rint(100.0 * p[grid.data != 0.0]))
    assert np.all(cells[grid.data == 0.0] == UNKNOWN) and np.count_nonzero(grid.data == 0.0) > 1000


def test_map_frame_header_layout_matches_the_protocol():
    owner = SharedMap(64 * 64, TILE, create=True)
    try:
        owner.publish(np.full((20, 33), 7, np.uint8), (1.25, -2.5), 0.05)
        frame = map_frames.encode(owner.snapshot(), TILE, compress=False)
    finally:
        owner.close()
        owner.unlink()
    kind, flags, tile = frame[0], frame[1], int.from_bytes(frame[2:4], "little")
    assert (kind, flags, tile) == (1, 1, TILE)
    assert np.frombuffer(frame[8:32], "<f8").tolist() == [0.05, 1.25, -2.5]
    assert np.frombuffer(frame[32:44], "<u4").tolist() == [33, 20, 3 * 2]
    assert len(frame) == 44 + 6 * (4 + TILE * TILE)
    with pytest.raises(ValueError, match="shorter"):
        map_frames.decode(frame[:10])
    with pytest.raises(ValueError, match="payload"):
        map_frames.decode(frame[:-1])


class FakeSocket:
    def __init__(self, stall: asyncio.Event | None = None):
        self.sent: list = []
        self.stall = stall

    async def send_text(self, text):
        if self.stall is not None:
            await self.stall.wait()
        self.sent.append(json.loads(text))

    async def send_bytes(self, data):
        if self.stall is not None:
            await self.stall.wait()
        self.sent.append(data)


def test_slow_client_keeps_only_the_newest_frames_and_never_blocks_others():
    async def scenario():
        stall = asyncio.Event()
        hub = Hub(lambda: b"FULL", send_timeout=5.0)
        slow, fast = hub.add(FakeSocket(stall)), hub.add(FakeSocket())
        tasks = [asyncio.create_task(c.run_sender()) for c in (slow, fast)]
        for i in range(100):
            hub.publish("pose", {"i": i})
            await asyncio.sleep(0)
        assert [m["i"] for m in fast.websocket.sent][-1] == 99
        assert len(fast.websocket.sent) >= 50
        stall.set()
        await asyncio.sleep(0.01)
        got = [m["i"] for m in slow.websocket.sent]
        for c in (slow, fast):
            hub.remove(c)
        await asyncio.gather(*tasks)
        assert got[-1] == 99 and len(got) <= 3, got  # stale poses were dropped, not queued

    asyncio.run(scenario())


def test_an_unsent_map_delta_turns_into_a_full_frame():
    hub = Hub(lambda: b"FULL", send_timeout=1.0)
    client = hub.add(FakeSocket())
    client.slots.clear()
    hub.publish_map(b"delta1")
    assert client.slots["map"] == b"delta1"
    hub.publish_map(b"delta2")  # delta1 never went out: the client's map needs a full frame
    assert client.slots["map"] is FULL_MAP
    hub.publish_map(b"delta3")
    assert client.slots["map"] is FULL_MAP
    client.slots.clear()
    hub.publish_map(b"d4")
    hub.publish_map(b"unchanged", empty=True)  # a heartbeat never displaces a real delta
    assert client.slots["map"] == b"d4"


GOOD_NAMES = ["kitchen", "Living room 2", "map_1-v2", "a-b", "Küche", "é", "客厅", "Спальня", "kitchen #2",
              "Kid's room", "(spare)", "x" * 64, "客" * 64]
#: Outside the Basic Multilingual Plane: UTF-16 (so ECMAScript's RegExp, Swagger UI's check) counts
#: each twice, UTF-8 four bytes each; the server takes as many as fit the file names.
ASTRAL_NAME = "\U0001f600" * 50
BAD_NAMES = ["", ".hidden", "../x", "a/b", "a\\b", "x" * 65, "..", "a..b", "tab\t", "home.bak", "v1.2",
             "x.png", " lead", "trail ", "nl\n", "a\x00b", "a:b", "a*b", "why?", 'say "hi"', "<b>", "a|b"]


@pytest.mark.parametrize("name", [*GOOD_NAMES, ASTRAL_NAME])
def test_good_names(name):
    assert check_name(name) == name


@pytest.mark.parametrize("name", [*GOOD_NAMES, ASTRAL_NAME])
def test_every_good_name_makes_every_file_homebot_writes_for_it(tmp_path, name):
    for suffix in (*MAP_SUFFIXES, SESSION_SUFFIX + ".partial"):
        (tmp_path / f"{name}{suffix}").write_bytes(b"")


def test_names_compare_in_nfc_form():
    assert check_name("Ku\u0308che") == "K\u00fcche"


@pytest.mark.parametrize("name", [*BAD_NAMES, "x\ud800", "\U0001f600" * 51])
def test_bad_names_are_refused(name):
    with pytest.raises(ValueError, match="bad"):
        check_name(name)


def test_store_round_trip_and_errors(tmp_path):
    store = Store(tmp_path / "db.sqlite3")
    store.add_place(Place("kitchen", 1.0, 2.0))
    with pytest.raises(AlreadyExists):
        store.add_place(Place("kitchen", 0.0, 0.0))
    store.update_place("kitchen", Place("galley", 1.0, 2.5, 0.3))
    with pytest.raises(NotFound):
        store.get_place("kitchen")
    assert Store(tmp_path / "db.sqlite3").list_places() == [Place("galley", 1.0, 2.5, 0.3)]
    store.add_map("home", 10, 20, 0.05)
    assert [m.name for m in store.list_maps()] == ["home"]
    store.delete_map("home")
    with pytest.raises(NotFound):
        store.delete_map("home")


def test_scan_slot_round_trip():
    slot = ScanSlot.create()
    assert slot.read() == (0, None)
    scan = Scan(np.linspace(-1, 1, 5), np.array([1.0, 2.0, 0.0, np.inf, 3.0]), 0.1, 8.0, 12.5)
    slot.write(scan)
    count, back = slot.read()
    assert count == 1 and np.array_equal(back.angles, scan.angles) and back.timestamp == 12.5
    assert np.array_equal(back.ranges, scan.ranges)


def test_body_size_limit_counts_streamed_bodies():
    async def echo(scope, receive, send):
        body = b""
        while True:
            message = await receive()
            body += message.get("body", b"")
            if not message.get("more_body"):
                break
        await send({"type": "http.response.start", "status": 200, "headers": []})
        await send({"type": "http.response.body", "body": str(len(body)).encode()})

    app = BodySizeLimit(echo, max_bytes=1000)

    async def run():
        async with httpx.AsyncClient(transport=httpx.ASGITransport(app=app), base_url="http://t") as c:
            assert (await c.post("/", content=b"x" * 1000)).text == "1000"
            assert (await c.post("/", content=b"x" * 1001)).status_code == 413

            async def chunks(n):
                for _ in range(n):
                    yield b"y" * 300

            assert (await c.post("/", content=chunks(3))).text == "900"  # no Content-Length: handed on whole
            r = await c.post("/", content=chunks(5))
            assert r.status_code == 413 and "1000" in r.json()["detail"]

    asyncio.run(run())


def test_body_size_limit_refuses_a_streamed_body_the_app_never_reads():
    async def ignores_the_body(scope, receive, send):
        await send({"type": "http.response.start", "status": 200, "headers": []})
        await send({"type": "http.response.body", "body": b"ok"})

    app = BodySizeLimit(ignores_the_body, max_bytes=1000)

    async def run():
        async def chunks():
            for _ in range(5):
                yield b"y" * 300

        async with httpx.AsyncClient(transport=httpx.ASGITransport(app=app), base_url="http://t") as c:
            assert (await c.post("/", content=chunks())).status_code == 413
            assert (await c.get("/")).text == "ok"

    asyncio.run(run())
