"""homebot on a real Mosquitto broker, seen the way Home Assistant sees it.

A real ``homebot serve`` (simulated flat) connects to Debian's mosquitto on a free loopback port;
a test client subscribes to the discovery prefix, checks every config against Home Assistant's
documented schemas (``tests/ha_discovery_schema.py``), sends commands, watches the simulated
robot move, and restarts the broker under the running server.
"""

from __future__ import annotations

import io
import itertools
import json
import math
import time

import pytest
from PIL import Image

from app.smarthome.robot_state import STATES
from tests.ha_discovery_schema import check
from tests.live_server import LiveServer
from tests.mqtt_broker import Mosquitto
from tests.mqtt_observer import Observer

PREFIX = "homebot"
EXPECTED = {
    "sensor": {"state", "mode", "room", "position"},
    "binary_sensor": {"localized"},
    "image": {"map"},
    "select": {"go_to", "mode_select"},
    "button": {"stop", "dock"},
    "vacuum": {"vacuum"},
}
CONFIG_COUNT = sum(len(v) for v in EXPECTED.values())


@pytest.fixture(scope="module")
def broker(tmp_path_factory):
    mosquitto = Mosquitto(tmp_path_factory.mktemp("mosquitto")).start()
    yield mosquitto
    mosquitto.stop()


@pytest.fixture(scope="module")
def observer(broker):
    client = Observer(broker.port).start()
    yield client
    client.stop()


@pytest.fixture(scope="module")
def server(broker, observer, tmp_path_factory):
    env = {"HOMEBOT_MQTT_HOST": "127.0.0.1", "HOMEBOT_MQTT_PORT": str(broker.port),
           "HOMEBOT_MQTT_MAP_INTERVAL_S": "2"}
    srv = LiveServer(tmp_path_factory.mktemp("homebot-data"), env=env).start()
    yield srv
    srv.stop()


def _wait_configs(observer: Observer, timeout: float = 30.0) -> dict[str, dict]:
    return observer.wait(lambda: (c := observer.configs()) and len(c) >= CONFIG_COUNT and c,
                         timeout, f"{CONFIG_COUNT} discovery configs")


def _state(observer: Observer) -> dict:
    return observer.json(f"{PREFIX}/state") or {}


def test_discovery_configs_follow_home_assistants_schemas(server, observer):
    configs = _wait_configs(observer)
    found: dict[str, set[str]] = {}
    for topic, payload in configs.items():
        discovery, component, node, object_id, last = topic.split("/")
        assert (discovery, node, last) == ("homeassistant", "homebot", "config"), topic
        assert check(component, payload) == [], (topic, check(component, payload))
        found.setdefault(component, set()).add(object_id)
        assert payload["availability_topic"] == f"{PREFIX}/availability"
        assert payload["device"]["identifiers"] == ["homebot"]
    assert found == EXPECTED
    unique_ids = [p["unique_id"] for p in configs.values()]
    assert len(set(unique_ids)) == len(unique_ids)
    assert observer.latest[f"{PREFIX}/availability"] == b"online"
    # Every topic an entity reads is one homebot publishes, every command topic one it answers on.
    vacuum = configs["homeassistant/vacuum/homebot/vacuum/config"]
    assert {"stop", "return_home", "send_command"} <= set(vacuum["supported_features"])
    modes = configs["homeassistant/select/homebot/mode_select/config"]["options"]
    assert "mapping" in modes and "localization" in modes


def test_state_position_and_map_image(server, observer):
    _wait_configs(observer)
    state = observer.wait(lambda: (s := _state(observer)) and s.get("x") is not None and s, 20, "a state")
    assert state["state"] in STATES and state["mode"] == "mapping" and state["mapping"] is True
    true = server.status()["true_pose"]
    assert math.hypot(state["x"] - true[0], state["y"] - true[1]) < 0.3
    assert json.loads(observer.latest[f"{PREFIX}/vacuum/state"])["state"] in (
        "cleaning", "docked", "paused", "idle", "returning", "error")

    def current_picture():
        """The newest map image once it shows the map the server has now (while the kernels warm up
        on a loaded machine, the preview map's image may come first and differ in size)."""
        png = observer.latest.get(f"{PREFIX}/map/image")
        if png is None:
            return None
        picture = Image.open(io.BytesIO(png))
        return picture if picture.size[0] <= server.status()["map"]["width"] else None

    picture = observer.wait(current_picture, 30, "the map image of the current map")
    assert picture.format == "PNG"
    assert picture.size[0] > 20 and picture.size[1] > 20
    grey = set(picture.convert("L").tobytes())
    assert min(grey) < 60 and max(grey) > 200  # walls and free space are drawn


def test_go_to_point_drives_the_simulated_robot(server, observer):
    start = server.status()["true_pose"]
    goal = (start[0] + 1.2, start[1])
    answer = observer.command(f"{PREFIX}/command", json.dumps({"command": "go_to", "x": goal[0], "y": goal[1],
                                                               "id": 7}))
    assert answer["ok"] is True and answer["id"] == 7 and answer["command"] == "go_to", answer
    observer.wait(lambda: _state(observer).get("state") == "driving", 10, "state driving")
    # the vacuum state is a message of its own, sent just after the state
    observer.wait(lambda: (observer.json(f"{PREFIX}/vacuum/state") or {}).get("state") == "cleaning", 5,
                  "vacuum state cleaning")
    observer.wait(lambda: _state(observer).get("nav_state") == "arrived", 60, "arrival")
    true = server.status()["true_pose"]
    assert math.hypot(true[0] - goal[0], true[1] - goal[1]) < 0.5
    assert math.hypot(true[0] - start[0], true[1] - start[1]) > 0.7
    assert _state(observer)["state"] != "driving"


def test_the_map_image_is_throttled_and_sent_only_when_it_changed(server, observer):
    """HOMEBOT_MQTT_MAP_INTERVAL_S=2: the map grows while the robot drives, yet the images come at
    least 2 s apart, and none repeats the one before it."""
    observer.wait(lambda: _state(observer).get("nav_state") != "driving", 60, "the robot at rest")
    start = server.status()["true_pose"]
    answer = observer.command(f"{PREFIX}/command", json.dumps({"command": "go_to", "x": start[0] - 1.0,
                                                               "y": start[1]}))
    assert answer["ok"] is True, answer
    observer.wait(lambda: _state(observer).get("nav_state") == "arrived", 60, "arrival")
    images = observer.stamped(f"{PREFIX}/map/image")
    assert len(images) >= 3, len(images)
    gaps = [b[0] - a[0] for a, b in itertools.pairwise(images)]
    assert min(gaps) > 2.0 - 0.3, gaps
    assert all(a[1] != b[1] for a, b in itertools.pairwise(images))


@pytest.mark.parametrize(("topic", "payload", "reason"), [
    ("command", "{not json", "not valid JSON"),
    ("command", '{"command": "fly"}', "unknown command"),
    ("command", "[1, 2]", "JSON object"),
    ("command", '{"command": "go_to"}', "exactly one of"),
    ("command", '{"command": "go_to", "x": "one", "y": 2}', "finite number"),
    ("command", '{"command": "go_to", "place": "nowhere"}', "no place named"),
    ("command", '{"command": "go_to", "room": "nowhere"}', "no room named"),
    ("command", '{"command": "go_to", "x": 80.0, "y": -60.0}', "goal_outside_map"),
    ("command", '{"command": "set_mode", "mode": "dance"}', "not available"),
    ("command", b"\xff\xfe", "UTF-8"),
    ("command", '{"command": "add_zone", "points": [[0, 0], [1, 1]]}', "3 to"),
    ("command", '{"command": "add_wall", "points": [[0, 0], [1, "a"]]}', "finite number"),
    ("command", '{"command": "delete_zone", "zone": 999}', "no zone or wall with id 999"),
    ("command", '{"command": "delete_zone", "zone": 99999999999999999999999}', "no zone or wall with id"),
    ("command", '{"command": "delete_zone"}', "positive integer"),
    ("goto/set", "garage", "unknown go-to option"),
    ("mode/set", "", "non-empty"),
    ("vacuum/command", "clean_spot", "unsupported vacuum command"),
])
def test_bad_commands_are_answered_with_a_reason(server, observer, topic, payload, reason):
    answer = observer.command(f"{PREFIX}/{topic}", payload)
    assert answer["ok"] is False and reason in answer["reason"], answer
    assert server.status()["worker"]["alive"]


def test_places_appear_in_the_go_to_select_and_drive_there(server, observer):
    pose = server.status()["true_pose"]
    place = {"name": "hallway", "x": round(pose[0] - 0.8, 2), "y": round(pose[1], 2), "yaw": 1.5}
    with server.client() as http:
        assert http.post("/api/places", json=place).status_code == 201
    select = "homeassistant/select/homebot/go_to/config"
    observer.wait(lambda: "place: hallway" in observer.configs().get(select, {}).get("options", []), 15,
                  "the place in the go-to select")
    answer = observer.command(f"{PREFIX}/goto/set", "place: hallway")
    assert answer["ok"] is True and answer["goal"]["place"] == "hallway", answer
    assert answer["goal"]["yaw"] == pytest.approx(1.5), "the place's heading is part of the goal"
    observer.wait(lambda: _state(observer).get("goal") == "hallway", 10, "the goal in the state")
    stopped = observer.command(f"{PREFIX}/stop/press", "PRESS")
    assert stopped["ok"] is True and stopped["command"] == "stop"
    observer.wait(lambda: _state(observer).get("nav_state") == "idle", 10, "idle after stop")
    assert _state(observer)["state"] in ("idle", "mapping")


def test_the_robots_room_is_published_and_can_be_driven_to(server, observer):
    room = observer.wait(lambda: _state(observer).get("room"), 30, "the robot's room in the state")
    assert room == server.status()["room"]
    select = "homeassistant/select/homebot/go_to/config"
    observer.wait(lambda: f"room: {room}" in observer.configs().get(select, {}).get("options", []), 15,
                  "the room in the go-to select")
    answer = observer.command(f"{PREFIX}/command", json.dumps({"command": "go_to", "room": room.upper()}))
    assert answer["ok"] is True and answer["goal"]["place"] == room, answer
    observer.wait(lambda: _state(observer).get("nav_state") in ("arrived", "idle"), 60, "arrival in the room")
    assert _state(observer)["room"] == room


def test_zones_over_mqtt_refuse_goals_inside_them(server, observer):
    added = observer.command(f"{PREFIX}/command", json.dumps(
        {"command": "add_zone", "points": [[5.0, 3.0], [6.0, 3.0], [6.0, 4.5], [5.0, 4.5]], "id": "z"}))
    assert added["ok"] is True and added["id"] == "z" and added["command"] == "add_zone", added
    zone = added["zone"]
    observer.wait(lambda: [z["id"] for z in observer.json(f"{PREFIX}/zones") or []] == [zone["id"]], 10,
                  "the zone on the zones topic")
    refused = observer.command(f"{PREFIX}/command", '{"command": "go_to", "x": 5.5, "y": 3.75}')
    assert refused["ok"] is False and refused["reason"].startswith("goal_in_no_go_zone"), refused
    with server.client() as http:
        assert [z["id"] for z in http.get("/api/zones").json()] == [zone["id"]]
    delete = {"command": "delete_zone", "zone": zone["id"]}
    deleted = observer.command(f"{PREFIX}/command", json.dumps(delete))
    assert deleted["ok"] is True
    observer.wait(lambda: observer.json(f"{PREFIX}/zones") == [], 10, "no zones on the zones topic")


def test_vacuum_return_to_base_and_send_command(server, observer):
    answer = observer.command(f"{PREFIX}/vacuum/command", "return_to_base")
    assert answer["ok"] is True and answer["command"] == "dock", answer
    observer.wait(lambda: json.loads(observer.latest[f"{PREFIX}/vacuum/state"])["state"] in
                  ("returning", "docked"), 10, "returning")
    answer = observer.command(f"{PREFIX}/vacuum/send_command", json.dumps({"command": "stop", "params": {}}))
    assert answer["ok"] is True and answer["command"] == "stop"
    answer = observer.command(f"{PREFIX}/command", '{"command": "set_mode", "mode": "mapping"}')
    assert answer["ok"] is True and answer["mode"] == "mapping" and answer["switched"] is True, answer


def test_broker_restart_is_survived(server, observer, broker):
    broker.stop()
    time.sleep(1.0)
    observer.latest.clear()
    broker.start()  # same port, empty: no retained messages survive
    _wait_configs(observer, timeout=60)
    assert observer.latest[f"{PREFIX}/availability"] == b"online"
    answer = observer.command(f"{PREFIX}/command", '{"command": "stop", "id": "after-restart"}')
    assert answer["ok"] is True and answer["id"] == "after-restart"
    observer.wait(lambda: observer.latest.get(f"{PREFIX}/map/image"), 30, "the map image again")


def test_clean_shutdown_says_offline(server, observer):
    assert server.stop() in (0, -15), server.output  # uvicorn re-raises SIGTERM after a clean exit
    observer.wait(lambda: observer.latest.get(f"{PREFIX}/availability") == b"offline", 10, "offline")
