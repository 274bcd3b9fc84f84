"""Commands that arrive over MQTT, parsed into typed values; anything else is a ``CommandError``.

On ``<prefix>/command`` (and the vacuum's ``send_command`` topic) a command is JSON::

    {"command": "go_to", "place": "kitchen"}      {"command": "go_to", "room": "Room 2"}
    {"command": "go_to", "x": 1.5, "y": 2.0}      {"command": "stop"}
    {"command": "set_mode", "mode": "localization"}   {"command": "dock"}
    {"command": "add_zone", "points": [[x, y], ...]}  {"command": "add_wall", "points": [[x, y], [x, y]]}
    {"command": "delete_zone", "zone": 3}

optionally with an ``"id"`` that the answer repeats; Home Assistant's ``vacuum.send_command``
puts the fields in ``"params"``, which is accepted too, and a bare word (``stop``, ``dock``)
is a command without fields. The entities' own topics carry plain payloads (an option of the
go-to select, a mode, a button press).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

from app.smarthome.discovery import DOCK_OPTION, PLACE_OPTION, ROOM_OPTION, VACUUM_RETURN, VACUUM_STOP
from app.smarthome.topics import Topics

MAX_PAYLOAD_BYTES = 4096


class CommandError(ValueError):
    """A command that cannot be understood; ``str()`` is the reason sent back."""


@dataclass(frozen=True)
class GoToPlace:
    name: str


@dataclass(frozen=True)
class GoToRoom:
    name: str


@dataclass(frozen=True)
class GoToPoint:
    x: float
    y: float


@dataclass(frozen=True)
class GoToDock:
    pass


@dataclass(frozen=True)
class Stop:
    pass


@dataclass(frozen=True)
class SetMode:
    mode: str


@dataclass(frozen=True)
class AddZone:
    kind: str  # "zone" or "wall"
    points: list[list[float]]


@dataclass(frozen=True)
class DeleteZone:
    id: int


Command = GoToPlace | GoToRoom | GoToPoint | GoToDock | Stop | SetMode | AddZone | DeleteZone
COMMANDS = "go_to, stop, dock, set_mode, add_zone, add_wall, delete_zone"


@dataclass(frozen=True)
class Request:
    """A parsed command and the ``id`` its answer carries (``None`` when none was given)."""

    command: Command
    id: str | int | None = None


def parse(topics: Topics, topic: str, payload: bytes) -> Request:
    """The request a message on one of :meth:`Topics.commands` carries."""
    if len(payload) > MAX_PAYLOAD_BYTES:
        raise CommandError(f"payload too large ({len(payload)} bytes, at most {MAX_PAYLOAD_BYTES})")
    try:
        text = payload.decode("utf-8").strip()
    except UnicodeDecodeError:
        raise CommandError("payload is not UTF-8 text") from None
    if topic in (topics.command, topics.vacuum_send_command):
        return _parse_json_command(text)
    if topic == topics.goto_set:
        return Request(_parse_goto_option(text))
    if topic == topics.mode_set:
        return Request(SetMode(_name(text, "mode")))
    if topic == topics.stop_press:
        return Request(Stop())
    if topic == topics.dock_press:
        return Request(GoToDock())
    if topic == topics.vacuum_command:
        if text == VACUUM_STOP:
            return Request(Stop())
        if text == VACUUM_RETURN:
            return Request(GoToDock())
        raise CommandError(f"unsupported vacuum command {text[:40]!r} (have: {VACUUM_STOP}, {VACUUM_RETURN})")
    raise CommandError(f"no commands on topic {topic!r}")


def _parse_json_command(text: str) -> Request:
    if not text:
        raise CommandError("empty command")
    if not text.startswith(("{", "[", '"')):
        body: object = {"command": text}  # a bare word, as vacuum.send_command sends without params
    else:
        try:
            body = json.loads(text)
        except json.JSONDecodeError as exc:
            raise CommandError(f"command is not valid JSON: {exc.msg} at character {exc.pos}") from None
    if isinstance(body, str):
        body = {"command": body}
    if not isinstance(body, dict):
        raise CommandError("a command is a JSON object with a \"command\" field")
    params = body.get("params")
    if params is not None:
        if not isinstance(params, dict):
            raise CommandError("\"params\" must be a JSON object")
        body = {**params, **{k: v for k, v in body.items() if k != "params"}}
    request_id = body.get("id")
    if request_id is not None and not isinstance(request_id, str | int):
        raise CommandError("\"id\" must be a string or an integer")
    return Request(_command(body), request_id)


def _command(body: dict) -> Command:
    name = body.get("command")
    if not isinstance(name, str):
        raise CommandError(f"missing \"command\" (one of {COMMANDS})")
    if name == "stop":
        return Stop()
    if name in ("dock", VACUUM_RETURN):
        return GoToDock()
    if name == "set_mode":
        return SetMode(_name(body.get("mode"), "mode"))
    if name == "go_to":
        given = [k for k in ("place", "room") if k in body] + (["x/y"] if "x" in body or "y" in body else [])
        if len(given) != 1:
            raise CommandError("go_to needs exactly one of \"place\", \"room\" or \"x\" and \"y\"")
        if given[0] == "place":
            return GoToPlace(_name(body["place"], "place"))
        if given[0] == "room":
            return GoToRoom(_name(body["room"], "room"))
        return GoToPoint(_coordinate(body.get("x"), "x"), _coordinate(body.get("y"), "y"))
    if name in ("add_zone", "add_wall"):
        return AddZone(name.removeprefix("add_"), _points(body.get("points")))
    if name == "delete_zone":
        zone_id = body.get("zone")
        if isinstance(zone_id, bool) or not isinstance(zone_id, int) or zone_id < 1:
            raise CommandError("delete_zone needs \"zone\": the zone's id (a positive integer)")
        return DeleteZone(zone_id)
    raise CommandError(f"unknown command {name[:40]!r} (have: {COMMANDS})")


def _parse_goto_option(text: str) -> Command:
    if text == DOCK_OPTION:
        return GoToDock()
    if text.startswith(PLACE_OPTION):
        return GoToPlace(_name(text[len(PLACE_OPTION):], "place"))
    if text.startswith(ROOM_OPTION):
        return GoToRoom(_name(text[len(ROOM_OPTION):], "room"))
    raise CommandError(f"unknown go-to option {text[:60]!r}")


def _name(value, what: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise CommandError(f"{what} must be a non-empty string")
    if len(value) > 64:
        raise CommandError(f"{what} is longer than 64 characters")
    return value.strip()


def _coordinate(value, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise CommandError(f"{what} must be a finite number of metres")
    return float(value)


def _points(value) -> list[list[float]]:
    if not isinstance(value, list) or not 2 <= len(value) <= 64:
        raise CommandError("\"points\" must be a list of 2 to 64 [x, y] pairs")
    out = []
    for point in value:
        if not isinstance(point, list) or len(point) != 2:
            raise CommandError("each point is an [x, y] pair")
        out.append([_coordinate(point[0], "x"), _coordinate(point[1], "y")])
    return out
