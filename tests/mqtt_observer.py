"""A test client that listens the way Home Assistant does: discovery configs and homebot's topics."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable

import paho.mqtt.client as mqtt


class Observer:
    """Keeps every message (and the newest per topic) on the topics it subscribed to."""

    def __init__(self, port: int, topics: tuple[str, ...] = ("homeassistant/#", "homebot/#")):
        self.port = port
        self.topics = topics
        self.messages: list[tuple[float, str, bytes, bool]] = []
        self.latest: dict[str, bytes] = {}
        self._lock = threading.Lock()
        self.client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=f"observer-{id(self)}")
        self.client.on_connect = lambda c, *_: self.topics and c.subscribe([(t, 1) for t in self.topics])
        self.client.on_message = self._message
        self.client.reconnect_delay_set(1, 2)

    def start(self) -> Observer:
        self.client.connect_async("127.0.0.1", self.port, 10)
        self.client.loop_start()
        return self

    def stop(self) -> None:
        self.client.disconnect()
        self.client.loop_stop()

    def _message(self, client, userdata, message) -> None:
        with self._lock:
            self.messages.append((time.monotonic(), message.topic, bytes(message.payload), message.retain))
            self.latest[message.topic] = bytes(message.payload)

    def since(self, t0: float, topic: str) -> list[bytes]:
        with self._lock:
            return [p for t, top, p, _ in self.messages if t >= t0 and top == topic]

    def stamped(self, topic: str) -> list[tuple[float, bytes]]:
        """Every message on ``topic`` with the monotonic time it arrived."""
        with self._lock:
            return [(t, p) for t, top, p, _ in self.messages if top == topic]

    def publish(self, topic: str, payload: str | bytes) -> None:
        self.client.publish(topic, payload, qos=1).wait_for_publish(5)

    def wait(self, condition: Callable[[], object], timeout: float, what: str):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            value = condition()
            if value:
                return value
            time.sleep(0.05)
        raise AssertionError(f"timed out after {timeout} s waiting for {what}")

    def json(self, topic: str) -> dict | None:
        with self._lock:
            raw = self.latest.get(topic)
        return None if raw is None else json.loads(raw)

    def configs(self, prefix: str = "homeassistant/") -> dict[str, dict]:
        with self._lock:
            return {t: json.loads(p) for t, p in self.latest.items()
                    if t.startswith(prefix) and t.endswith("/config") and p}

    def command(self, topic: str, payload: str | bytes, result_topic: str = "homebot/command/result",
                timeout: float = 30.0) -> dict:
        """Send a command and return the first answer on the result topic after it."""
        t0 = time.monotonic()
        self.publish(topic, payload)
        raw = self.wait(lambda: self.since(t0, result_topic), timeout, f"an answer to {payload!r} on {topic}")
        return json.loads(raw[0])
