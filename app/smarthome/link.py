"""The MQTT connection: paho-mqtt on its own network thread, so nothing here blocks the event loop.

paho reconnects by itself with an exponential back-off (``RECONNECT_MIN_S`` to ``RECONNECT_MAX_S``);
after every (re)connection the link announces itself online (retained), subscribes again and
calls ``on_connected``. The broker publishes the last will, ``offline`` on the availability topic,
when the connection drops without a goodbye.
"""

from __future__ import annotations

import contextlib
import logging
import threading
from collections.abc import Callable

import paho.mqtt.client as mqtt

from app.core.config import Settings
from app.smarthome.topics import OFFLINE, ONLINE, Topics

log = logging.getLogger(__name__)

RECONNECT_MIN_S = 1
RECONNECT_MAX_S = 30
KEEPALIVE_S = 30
GOODBYE_TIMEOUT_S = 2.0


class MqttLink:
    """One client session with the broker named by the settings."""

    def __init__(self, settings: Settings, topics: Topics, on_connected: Callable[[], None],
                 on_message: Callable[[str, bytes], None]):
        self.settings = settings
        self.topics = topics
        self._on_connected = on_connected
        self._on_message = on_message
        self.connected = threading.Event()
        self.connections = 0
        client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=settings.mqtt_client_id,
                             clean_session=True)
        client.will_set(topics.availability, OFFLINE, qos=1, retain=True)
        if settings.mqtt_username:
            client.username_pw_set(settings.mqtt_username, settings.mqtt_password)
        if settings.mqtt_tls:
            client.tls_set(ca_certs=str(settings.mqtt_ca_file) if settings.mqtt_ca_file else None)
        client.reconnect_delay_set(RECONNECT_MIN_S, RECONNECT_MAX_S)
        client.on_connect = self._connected
        client.on_disconnect = self._disconnected
        client.on_message = self._message
        self._client = client

    def start(self) -> None:
        """Connect in the background (retrying until the broker answers)."""
        self._client.connect_async(self.settings.mqtt_host, self.settings.mqtt_port, KEEPALIVE_S)
        self._client.loop_start()

    def stop(self) -> None:
        """Say ``offline`` (retained), disconnect, end the network thread. Blocks briefly: use a thread."""
        if self.connected.is_set():
            info = self._client.publish(self.topics.availability, OFFLINE, qos=1, retain=True)
            with contextlib.suppress(RuntimeError, ValueError):
                info.wait_for_publish(GOODBYE_TIMEOUT_S)
        self._client.disconnect()
        self._client.loop_stop()

    def publish(self, topic: str, payload: str | bytes, retain: bool = False, qos: int = 0) -> bool:
        """Queue a message for the network thread; ``False`` when not connected (it is dropped)."""
        if not self.connected.is_set():
            return False
        return self._client.publish(topic, payload, qos=qos, retain=retain).rc == mqtt.MQTT_ERR_SUCCESS

    # paho's callbacks (network thread)
    def _connected(self, client, userdata, flags, reason_code, properties) -> None:
        if reason_code.is_failure:
            log.warning("MQTT broker refused the connection: %s", reason_code)
            return
        self.connections += 1
        client.publish(self.topics.availability, ONLINE, qos=1, retain=True)
        client.subscribe([(topic, 1) for topic in self.topics.commands()])
        self.connected.set()
        log.info("MQTT connected to %s:%s", self.settings.mqtt_host, self.settings.mqtt_port)
        self._on_connected()

    def _disconnected(self, client, userdata, flags, reason_code, properties) -> None:
        self.connected.clear()
        log.info("MQTT disconnected (%s); paho reconnects with back-off", reason_code)

    def _message(self, client, userdata, message) -> None:
        self._on_message(message.topic, bytes(message.payload))
