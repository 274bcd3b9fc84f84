"""Rooms over REST on a real server (simulated flat): found on the live map, renamed, split,
merged, driven to, reported in the status, kept across a restart and stored with a saved map."""

from __future__ import annotations

import time

import pytest

from app.db.rooms import RoomStore
from tests.live_server import LiveServer, until

#: The flat's hall (slam_core/sim/worlds/flat.txt), where the robot starts.
HALL = (0.0, 3.0, 6.5, 4.5)


def _inside(point, box, margin=0.0) -> bool:
    x0, y0, x1, y1 = box
    return x0 - margin <= point[0] <= x1 + margin and y0 - margin <= point[1] <= y1 + margin


@pytest.fixture(scope="module")
def data_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("homebot-rooms")


@pytest.fixture(scope="module")
def server(data_dir):
    srv = LiveServer(data_dir).start()
    yield srv
    srv.stop()


def _drive(server: LiveServer, http, x: float, y: float) -> None:
    answer = http.post("/api/goal", json={"x": x, "y": y})
    assert answer.status_code == 202, answer.text
    until(lambda: http.get("/api/path").json()["state"] == "arrived", 60, f"arrival at ({x}, {y})")


def test_rooms_are_found_and_the_status_names_the_robots_room(server):
    with server.client() as http:
        for x in (2.2, 3.4, 4.6):  # map the hall on the way east
            _drive(server, http, x, 3.75)
        time.sleep(6)  # the rooms are segmented every few seconds
        rooms = until(lambda: http.get("/api/rooms").json(), 30, "rooms on the live map")
        here = until(lambda: http.get("/api/status").json()["room"], 10, "a room in the status")
    assert here in {r["name"] for r in rooms}
    hall = next(r for r in rooms if r["name"] == here)
    assert hall["area"] > 4.0 and _inside(hall["centroid"], HALL, 0.3)
    assert all(r["area"] >= 1.0 for r in rooms)


def test_rename_split_go_and_merge(server):
    with server.client() as http:
        here = http.get("/api/status").json()["room"]
        hall = next(r for r in http.get("/api/rooms").json() if r["name"] == here)
        renamed = http.patch(f"/api/rooms/{hall['id']}", json={"name": "Hall"})
        assert renamed.status_code == 200 and "Hall" in {r["name"] for r in renamed.json()}
        until(lambda: http.get("/api/status").json()["room"] == "Hall", 5, "the new name in the status")
        # Split along x = 3 drawn from south to north: the part west of it (left of a->b) is new.
        split = http.post(f"/api/rooms/{hall['id']}/split", json={"a": [3.0, 3.0], "b": [3.0, 4.5]})
        assert split.status_code == 200, split.text
        # The new room is the west part (what the map shows through doorways counts with the hall).
        west = [r for r in split.json() if r["id"] not in {room["id"] for room in renamed.json()}]
        assert len(west) == 1 and len(split.json()) == len(renamed.json()) + 1, split.json()
        east = next(r for r in split.json() if r["id"] == hall["id"])
        assert west[0]["centroid"][0] < 3.0 < east["centroid"][0]
        assert http.get("/api/status").json()["room"] == "Hall"  # the robot (x = 4.6) is east of the line
        go = http.post(f"/api/rooms/{west[0]['id']}/go")
        assert go.status_code == 202, go.text
        until(lambda: http.get("/api/path").json()["state"] == "arrived", 60, "arrival in the west part")
        true = server.status()["true_pose"]
        assert true[0] < 3.0
        assert http.get("/api/status").json()["room"] == west[0]["name"]
        merged = http.post("/api/rooms/merge", json={"keep": hall["id"], "absorb": west[0]["id"]})
        assert merged.status_code == 200 and west[0]["id"] not in {r["id"] for r in merged.json()}
        assert http.get("/api/status").json()["room"] == "Hall"


@pytest.mark.parametrize(("method", "path", "body", "code", "text"), [
    ("patch", "/api/rooms/999", {"name": "x"}, 404, "no room with id 999"),
    ("patch", "/api/rooms/1", {"name": "../etc"}, 422, "room name"),
    ("patch", "/api/rooms/1", {"name": "x", "colour": 3}, 422, "Extra inputs"),
    ("post", "/api/rooms/merge", {"keep": 1, "absorb": 1}, 409, "itself"),
    ("post", "/api/rooms/1/split", {"a": [0, 0], "b": [0]}, 422, "at least 2"),
    ("post", "/api/rooms/1/split", {"a": [50, 50], "b": [51, 50]}, 409, "does not cut"),
    ("post", "/api/rooms/999/go", None, 404, "no room with id 999"),
    ("post", "/api/rooms/0/go", None, 422, "greater than or equal to 1"),
])
def test_bad_room_requests_are_answered_with_a_reason(server, method, path, body, code, text):
    with server.client() as http:
        first = http.get("/api/rooms").json()[0]["id"]
        path = path.replace("/1", f"/{first}") if "999" not in path and "/0/" not in path else path
        if "merge" in path and body:
            body = {"keep": first, "absorb": first}
        answer = getattr(http, method)(path, **({"json": body} if body is not None else {}))
    assert answer.status_code == code and text.lower() in answer.text.lower(), answer.text


def test_rooms_are_stored_with_a_saved_map_and_kept_across_a_restart(server, data_dir):
    with server.client() as http:
        assert http.post("/api/maps", json={"name": "home"}).status_code == 201
        names = {r["name"] for r in http.get("/api/rooms").json()}
    saved = RoomStore(data_dir / "homebot.sqlite3").load("home")
    assert saved is not None and "Hall" in {saved.name(r) for r in saved.ids()}
    server.stop()
    server.start()
    with server.client() as http:
        again = until(lambda: http.get("/api/rooms").json(), 30, "rooms after the restart")
    assert "Hall" in {r["name"] for r in again} and names & {r["name"] for r in again}
