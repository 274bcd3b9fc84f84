"""No-go zones and virtual walls over REST on a real server (simulated flat): goals inside a zone
are refused, plans keep out, a robot inside a zone leaves it, bad shapes are refused, and the
zones are stored with a saved map."""

from __future__ import annotations

import time

import numpy as np
import pytest

from app.db.rooms import RoomStore
from app.db.zones import ZoneStore
from app.rooms.service import REFRESH_S
from slam_core.planning.zones import NoGoZone
from tests.live_server import LiveServer, until


@pytest.fixture(scope="module")
def data_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("homebot-zones")


@pytest.fixture(scope="module")
def server(data_dir):
    srv = LiveServer(data_dir).start()
    yield srv
    srv.stop()


def _arrive(http) -> None:
    until(lambda: http.get("/api/path").json()["state"] in ("arrived", "failed"), 60, "the end of the drive")


def test_a_zone_refuses_goals_inside_and_plans_keep_out(server):
    blocker = [[1.6, 3.0], [2.0, 3.0], [2.0, 4.5], [1.6, 4.5]]  # across the hall, east of the robot
    with server.client() as http:
        added = http.post("/api/zones", json={"kind": "zone", "points": blocker})
        assert added.status_code == 201, added.text
        inside = http.post("/api/goal", json={"x": 1.8, "y": 3.75})
        assert inside.status_code == 422 and inside.json()["reason"] == "goal_in_no_go_zone"
        beyond = http.post("/api/goal", json={"x": 2.4, "y": 3.75})
        if beyond.status_code == 202:  # a way around (through a door) is allowed, through the zone is not
            path = np.array(beyond.json()["path"])
            assert not NoGoZone(tuple(map(tuple, blocker))).contains(path).any()
            http.delete("/api/goal")
        else:
            assert beyond.status_code == 422 and beyond.json()["reason"] != "goal_in_no_go_zone"
        assert http.delete(f"/api/zones/{added.json()['id']}").status_code == 204
        free = http.post("/api/goal", json={"x": 2.4, "y": 3.75})
        assert free.status_code == 202, free.text
        _arrive(http)
    assert server.status()["true_pose"][0] > 2.0


def test_a_robot_carried_into_a_zone_leaves_it_by_the_nearest_way(server):
    x, y = server.status()["true_pose"][:2]
    around = [[x - 0.3, y - 0.5], [x + 0.6, y - 0.5], [x + 0.6, y + 0.5], [x - 0.3, y + 0.5]]
    with server.client() as http:
        added = http.post("/api/zones", json={"kind": "zone", "points": around})
        assert added.status_code == 201
        go = http.post("/api/goal", json={"x": x - 1.2, "y": 3.75})
        assert go.status_code == 202, go.text
        path = np.array(go.json()["path"])
        # Out through the west side (0.3 m away, the nearest), not the east side (0.6 m).
        assert path[1][0] < x - 0.3 and not NoGoZone(tuple(map(tuple, around))).contains(path[2:]).any()
        _arrive(http)
        true = server.status()["true_pose"]
        assert not NoGoZone(tuple(map(tuple, around))).contains(np.array(true[:2]))
        assert http.delete(f"/api/zones/{added.json()['id']}").status_code == 204


def test_a_zone_drawn_across_the_path_while_driving_is_avoided_at_once(server):
    x = server.status()["true_pose"][0]
    with server.client() as http:
        assert http.post("/api/goal", json={"x": x + 1.5, "y": 3.75}).status_code == 202
        # Across the whole hall, 0.6 m ahead of the robot: the old path runs straight through it.
        ahead = [[x + 0.6, 2.9], [x + 0.9, 2.9], [x + 0.9, 4.6], [x + 0.6, 4.6]]
        zone = NoGoZone(tuple(map(tuple, ahead)))
        added = http.post("/api/zones", json={"kind": "zone", "points": ahead})
        assert added.status_code == 201
        path = http.get("/api/path").json()
        assert path["state"] == "failed" or not zone.contains(np.array(path["path"]).reshape(-1, 2)).any()
        for _ in range(15):  # the robot stops short of it
            assert not zone.contains(np.array(server.status()["true_pose"][:2]))
            time.sleep(0.2)
        assert http.delete(f"/api/zones/{added.json()['id']}").status_code == 204
        http.delete("/api/goal")


@pytest.mark.parametrize(("body", "text"), [
    ({"kind": "circle", "points": [[0, 0], [1, 1]]}, "zone"),
    ({"kind": "zone", "points": [[0, 0], [1, 1]]}, "3 to"),
    ({"kind": "zone", "points": [[0, 0], [1, 1], [2, 2]]}, "enclose an area"),
    ({"kind": "wall", "points": [[0, 0], [1, 1], [2, 0]]}, "exactly 2 points"),
    ({"kind": "wall", "points": [[0, 0], [0, 0]]}, "distinct"),
    ({"kind": "wall", "points": [[0, 0], [1]]}, "at least 2"),
    ({"kind": "wall", "points": [[0, 0], [1, 1]], "colour": "red"}, "Extra inputs"),
])
def test_bad_zones_are_refused_with_a_reason(server, body, text):
    with server.client() as http:
        answer = http.post("/api/zones", json=body)
        assert answer.status_code == 422 and text.lower() in answer.text.lower(), answer.text
        assert http.delete("/api/zones/4242").status_code == 404


def test_zones_are_stored_with_a_saved_map(server, data_dir):
    with server.client() as http:
        wall = http.post("/api/zones", json={"kind": "wall", "points": [[0.5, 3.0], [0.5, 4.5]]})
        assert wall.status_code == 201
        assert http.post("/api/maps", json={"name": "with-zones"}).status_code == 201
        assert [z["kind"] for z in http.get("/api/zones").json()] == ["wall"]
    saved = ZoneStore(data_dir / "homebot.sqlite3").list("with-zones")
    assert [(z.kind, z.points) for z in saved] == [("wall", [[0.5, 3.0], [0.5, 4.5]])]


def test_a_loaded_map_brings_its_own_zones_and_rooms(server):
    """Zones and room names drawn after a map was saved stay with the live map; loading the saved
    map plans with the zones and names stored with it."""
    with server.client() as http:
        rooms = until(lambda: http.get("/api/rooms").json(), 30, "rooms on the live map")
        assert http.patch(f"/api/rooms/{rooms[0]['id']}", json={"name": "Saved hall"}).status_code == 200
        assert http.post("/api/maps", json={"name": "zoned"}).status_code == 201
        saved = {z["id"]: z for z in http.get("/api/zones").json()}
        later = http.post("/api/zones", json={"kind": "zone", "points": [[1, 1], [2, 1], [2, 2]]})
        assert later.status_code == 201
        refused = http.post("/api/goal", json={"x": 1.7, "y": 1.3})
        assert refused.json().get("reason") == "goal_in_no_go_zone", refused.text
        assert http.patch(f"/api/rooms/{rooms[0]['id']}", json={"name": "Live hall"}).status_code == 200
        loaded = http.post("/api/maps/zoned/load")
        assert loaded.status_code in (200, 202), loaded.text
        assert [(z["kind"], z["points"]) for z in http.get("/api/zones").json()] == \
            [(z["kind"], z["points"]) for z in saved.values()]
        names = until(lambda: {r["name"] for r in http.get("/api/rooms").json()}, 30, "the saved map's rooms")
        assert "Saved hall" in names and "Live hall" not in names
        inside = http.post("/api/goal", json={"x": 1.7, "y": 1.3})  # in the live map's later zone
        assert inside.json().get("reason") != "goal_in_no_go_zone", inside.text


def test_the_loaded_maps_zones_apply_after_a_restart_and_a_new_map_has_the_live_ones(server, data_dir):
    """The worker resumes on the saved map after a restart, and the server plans with that map's
    zones again; a new map afterwards is no saved map: the live map's zones apply, the saved
    map's stored zones and rooms stay as they were."""
    store, rooms = ZoneStore(data_dir / "homebot.sqlite3"), RoomStore(data_dir / "homebot.sqlite3")
    saved, live, saved_rooms = store.list("zoned"), store.list(""), rooms.load("zoned")
    assert len(live) == len(saved) + 1  # the zone drawn on the live map after saving
    server.stop()
    server.start()
    with server.client() as http:
        assert http.get("/api/status").json()["mode"] == "localization"
        assert [z["id"] for z in http.get("/api/zones").json()] == [z.id for z in saved]
        new = http.put("/api/mode", json={"mode": "mapping", "new_map": True})
        assert new.status_code == 200, new.text
        until(lambda: [z["id"] for z in http.get("/api/zones").json()] == [z.id for z in live], 10,
              "the live map's zones")
        time.sleep(REFRESH_S + 1.0)  # the new map is segmented in the meantime
    assert store.list("zoned") == saved
    again = rooms.load("zoned")
    assert np.array_equal(again.labels, saved_rooms.labels) and again.edits == saved_rooms.edits
