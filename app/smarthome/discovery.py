"""Home Assistant MQTT discovery configs for the robot: one device, one config per entity.

Each config follows the schema Home Assistant documents for its component (``sensor``,
``binary_sensor``, ``image``, ``select``, ``button``, ``vacuum``): a ``unique_id``, the
shared ``device`` block, ``availability`` on homebot's availability topic, and the
component's own topics. They are published retained under ``<discovery>/<component>/<node>/``.
"""

from __future__ import annotations

from dataclasses import dataclass

from app.smarthome.robot_state import STATES
from app.smarthome.topics import OFFLINE, ONLINE, Topics

#: The go-to select's target for the dock (or, without a place named ``dock``, the start pose).
DOCK_OPTION = "dock"
PLACE_OPTION = "place: "
ROOM_OPTION = "room: "
BUTTON_PRESS = "PRESS"
VACUUM_STOP = "stop"
VACUUM_RETURN = "return_to_base"
VACUUM_FEATURES = ("stop", "return_home", "send_command")


@dataclass(frozen=True)
class Device:
    """Who the entities belong to."""

    client_id: str
    name: str = "homebot"
    version: str = "0.1.0"

    def block(self) -> dict:
        return {"identifiers": [self.client_id], "name": self.name, "manufacturer": "homebot",
                "model": "homebot home robot", "sw_version": self.version}


def goto_options(places: list[str], rooms: list[str]) -> list[str]:
    """The go-to select's options: the dock, every place, every room."""
    return [DOCK_OPTION, *(PLACE_OPTION + p for p in places), *(ROOM_OPTION + r for r in rooms)]


def discovery_configs(topics: Topics, device: Device, modes: list[str],
                      places: list[str], rooms: list[str]) -> dict[str, dict]:
    """``{config topic: payload}`` for every entity of the robot."""
    def entity(component: str, object_id: str, name: str, **fields) -> tuple[str, dict]:
        payload = {"name": name, "unique_id": f"{device.client_id}_{object_id}",
                   "availability_topic": topics.availability, "payload_available": ONLINE,
                   "payload_not_available": OFFLINE, "device": device.block(),
                   "origin": {"name": "homebot", "sw_version": device.version}, **fields}
        return topics.config(component, object_id), payload

    state = topics.state
    entities = [
        entity("sensor", "state", "State", state_topic=state, value_template="{{ value_json.state }}",
               device_class="enum", options=list(STATES), json_attributes_topic=state,
               icon="mdi:robot"),
        entity("sensor", "mode", "Mode", state_topic=state, value_template="{{ value_json.mode }}",
               icon="mdi:map-search"),
        entity("binary_sensor", "localized", "Localized", state_topic=state,
               value_template="{{ 'ON' if value_json.localized else 'OFF' }}",
               payload_on="ON", payload_off="OFF", icon="mdi:crosshairs-gps"),
        entity("sensor", "room", "Room", state_topic=state,
               value_template="{{ value_json.room if value_json.room else 'none' }}", icon="mdi:floor-plan"),
        entity("sensor", "position", "Position", state_topic=state,
               value_template="{{ value_json.x }}, {{ value_json.y }}", json_attributes_topic=state,
               json_attributes_template="{{ {'x': value_json.x, 'y': value_json.y, 'yaw': value_json.yaw}"
                                        " | tojson }}",
               icon="mdi:map-marker"),
        entity("image", "map", "Map", image_topic=topics.map_image, content_type="image/png"),
        entity("select", "go_to", "Go to", command_topic=topics.goto_set,
               options=goto_options(places, rooms), icon="mdi:map-marker-path"),
        entity("select", "mode_select", "Mode select", command_topic=topics.mode_set, state_topic=state,
               value_template="{{ value_json.mode }}", options=list(modes), icon="mdi:map-search"),
        entity("button", "stop", "Stop", command_topic=topics.stop_press, payload_press=BUTTON_PRESS,
               icon="mdi:stop"),
        entity("button", "dock", "Go to dock", command_topic=topics.dock_press, payload_press=BUTTON_PRESS,
               icon="mdi:home-import-outline"),
        entity("vacuum", "vacuum", None, state_topic=topics.vacuum_state, command_topic=topics.vacuum_command,
               send_command_topic=topics.vacuum_send_command, payload_stop=VACUUM_STOP,
               payload_return_to_base=VACUUM_RETURN, supported_features=list(VACUUM_FEATURES),
               json_attributes_topic=state),
    ]
    return dict(entities)
