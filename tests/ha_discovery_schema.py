"""Home Assistant's documented MQTT discovery schemas, written out from its integration pages
(MQTT Sensor, Binary sensor, Image, Select, Button, Vacuum; the shared entity, device and origin
options), as an oracle independent of ``app/smarthome``. ``check(component, payload)`` returns the
list of problems (empty when the payload is valid)."""

from __future__ import annotations

STR = (str,)
TEMPLATE = (str,)
BOOL = (bool,)
NUMBER = (int, float)

COMMON = {
    "availability": (list,), "availability_mode": STR, "availability_template": TEMPLATE,
    "availability_topic": STR, "device": (dict,), "enabled_by_default": BOOL, "encoding": STR,
    "entity_category": STR, "entity_picture": STR, "icon": STR, "json_attributes_template": TEMPLATE,
    "json_attributes_topic": STR, "name": (str, type(None)), "object_id": STR, "default_entity_id": STR,
    "origin": (dict,), "payload_available": STR, "payload_not_available": STR, "qos": (int,),
    "unique_id": STR, "platform": STR,
}

COMPONENTS = {
    "sensor": ({"state_topic"}, {
        "state_topic": STR, "device_class": STR, "expire_after": (int,), "force_update": BOOL,
        "last_reset_value_template": TEMPLATE, "options": (list,), "suggested_display_precision": (int,),
        "state_class": STR, "unit_of_measurement": STR, "value_template": TEMPLATE}),
    "binary_sensor": ({"state_topic"}, {
        "state_topic": STR, "device_class": STR, "expire_after": (int,), "force_update": BOOL,
        "off_delay": (int,), "payload_off": STR, "payload_on": STR, "value_template": TEMPLATE}),
    "image": (set(), {
        "content_type": STR, "image_encoding": STR, "image_topic": STR, "url_template": TEMPLATE,
        "url_topic": STR}),
    "select": ({"command_topic", "options"}, {
        "command_topic": STR, "options": (list,), "command_template": TEMPLATE, "optimistic": BOOL,
        "retain": BOOL, "state_topic": STR, "value_template": TEMPLATE}),
    "button": ({"command_topic"}, {
        "command_topic": STR, "command_template": TEMPLATE, "device_class": STR, "payload_press": STR,
        "retain": BOOL}),
    "vacuum": (set(), {
        "command_topic": STR, "fan_speed_list": (list,), "payload_clean_spot": STR, "payload_locate": STR,
        "payload_pause": STR, "payload_return_to_base": STR, "payload_start": STR, "payload_stop": STR,
        "retain": BOOL, "send_command_topic": STR, "set_fan_speed_topic": STR, "state_topic": STR,
        "supported_features": (list,)}),
}

DEVICE = {"configuration_url": STR, "connections": (list,), "hw_version": STR, "identifiers": (list, str),
          "manufacturer": STR, "model": STR, "model_id": STR, "name": STR, "serial_number": STR,
          "suggested_area": STR, "sw_version": STR, "via_device": STR}
ORIGIN = {"name": STR, "sw_version": STR, "support_url": STR}
VACUUM_FEATURES = {"start", "stop", "pause", "return_home", "locate", "clean_spot", "fan_speed",
                   "send_command"}
SENSOR_STATE_CLASSES = {"measurement", "measurement_angle", "total", "total_increasing"}
ENTITY_CATEGORIES = {"config", "diagnostic"}


def _typed(where: str, payload: dict, spec: dict) -> list[str]:
    problems = []
    for key, value in payload.items():
        if key not in spec:
            problems.append(f"{where}: unknown option {key!r}")
        elif not isinstance(value, spec[key]) or (isinstance(value, bool) and bool not in spec[key]):
            problems.append(f"{where}: {key!r} has type {type(value).__name__}")
    return problems


def _topic(value: str, wildcards: bool) -> bool:
    return bool(value) and "\0" not in value and (wildcards or not ("+" in value or "#" in value))


def check(component: str, payload: dict) -> list[str]:
    """Problems of one discovery payload against its component's documented schema."""
    if component not in COMPONENTS:
        return [f"unknown component {component!r}"]
    required, own = COMPONENTS[component]
    problems = _typed(component, payload, {**COMMON, **own})
    problems += [f"{component}: missing {key!r}" for key in sorted(required - payload.keys())]
    if "availability" in payload and "availability_topic" in payload:
        problems.append("availability and availability_topic must not be used together")
    for key, value in payload.items():
        if key.endswith("_topic") and isinstance(value, str) and not _topic(value, key == "state_topic"):
            problems.append(f"{key!r} is not a valid topic: {value!r}")
    device = payload.get("device")
    if isinstance(device, dict):
        problems += _typed("device", device, DEVICE)
        if not device.get("identifiers") and not device.get("connections"):
            problems.append("device needs identifiers or connections")
    origin = payload.get("origin")
    if isinstance(origin, dict):
        problems += _typed("origin", origin, ORIGIN)
        if "name" not in origin:
            problems.append("origin needs a name")
    if payload.get("entity_category") not in (None, *ENTITY_CATEGORIES):
        problems.append(f"entity_category {payload['entity_category']!r}")
    if payload.get("qos") not in (None, 0, 1, 2):
        problems.append("qos must be 0, 1 or 2")
    if component == "sensor":
        if payload.get("device_class") == "enum" and not payload.get("options"):
            problems.append("an enum sensor needs options")
        if "options" in payload and payload.get("device_class") != "enum":
            problems.append("options need device_class enum")
        if payload.get("state_class") not in (None, *SENSOR_STATE_CLASSES):
            problems.append(f"state_class {payload['state_class']!r}")
    if component == "select":
        options = payload.get("options")
        if not isinstance(options, list) or not options or not all(isinstance(o, str) for o in options):
            problems.append("select options must be a non-empty list of strings")
    if component == "image":
        if ("image_topic" in payload) == ("url_topic" in payload):
            problems.append("image needs exactly one of image_topic and url_topic")
        content_type = str(payload.get("content_type", "image/jpeg"))
        if "image_topic" in payload and not content_type.startswith("image/"):
            problems.append("image content_type must be an image MIME type")
    if component == "vacuum":
        features = payload.get("supported_features", [])
        if not set(features) <= VACUUM_FEATURES:
            problems.append(f"unknown vacuum features {sorted(set(features) - VACUUM_FEATURES)}")
        if "send_command" in features and "send_command_topic" not in payload:
            problems.append("send_command needs send_command_topic")
        if set(features) & {"start", "stop", "pause", "return_home", "locate", "clean_spot"} and \
                "command_topic" not in payload:
            problems.append("vacuum commands need command_topic")
    return problems
