"""MQTT commands the robot cannot carry out are answered on the result topic with the reason:
a room no part of which can be reached, and driving while a log replays."""

from __future__ import annotations

import asyncio
import json
from types import SimpleNamespace

from app.core.config import Settings
from app.smarthome.bridge import MqttBridge
from slam_core.rooms.target import RoomUnreachable


class CutOffRooms:
    def find(self, name: str) -> int:
        return 3

    async def goal(self, room: int, navigator):
        raise RoomUnreachable("no part of room 'Hall' can be reached from the robot")


async def _never(goal):
    raise AssertionError(f"no goal should be started, got {goal}")


def _answer(tmp_path, payload: dict, **settings) -> dict:
    published = []
    runtime = SimpleNamespace(settings=Settings(data_dir=tmp_path, mqtt_host="127.0.0.1", **settings),
                              rooms=CutOffRooms(), navigator=SimpleNamespace(set_goal=_never), status=dict)

    async def run():
        bridge = MqttBridge(runtime)
        bridge.link.connected.set()
        bridge.link.publish = lambda topic, body, **_: published.append((topic, body)) or True
        await bridge._handle("homebot/command", json.dumps(payload).encode())

    asyncio.run(run())
    results = [json.loads(body) for topic, body in published if topic == "homebot/command/result"]
    assert len(results) == 1, published
    return results[0]


def test_a_room_that_cannot_be_reached_is_answered_with_the_reason(tmp_path):
    answer = _answer(tmp_path, {"command": "go_to", "room": "Hall", "id": 5})
    assert answer["ok"] is False and answer["id"] == 5
    assert answer["reason"].startswith("room_unreachable: no part of room 'Hall'"), answer


def test_driving_is_refused_while_a_log_replays(tmp_path):
    answer = _answer(tmp_path, {"command": "go_to", "x": 1.0, "y": 2.0}, replay="intel")
    assert answer["ok"] is False and "replaying the log 'intel'" in answer["reason"], answer
