"""The smart home: homebot on an MQTT broker with Home Assistant discovery (off unless configured)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from app.runtime import Runtime
    from app.smarthome.bridge import MqttBridge


async def start_smart_home(runtime: Runtime) -> MqttBridge | None:
    """Connect to the MQTT broker when ``HOMEBOT_MQTT_HOST`` is set; ``None`` otherwise."""
    if not runtime.settings.mqtt_host:
        return None
    from app.smarthome.bridge import MqttBridge  # paho is imported only when MQTT is on

    bridge = MqttBridge(runtime)
    await bridge.start()
    return bridge
