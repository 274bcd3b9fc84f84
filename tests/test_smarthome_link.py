"""The MQTT link alone on a real mosquitto: last will on a dropped connection, reconnection,
TLS with a CA file and a username/password."""

from __future__ import annotations

import socket
import subprocess
import time

import pytest

from app.core.config import Settings
from app.smarthome.link import MqttLink
from app.smarthome.topics import Topics
from tests.debian import system_tool
from tests.mqtt_broker import Mosquitto
from tests.mqtt_observer import Observer

TOPICS = Topics("linktest", "homeassistant", "linktest")


def _link(tmp_path, port: int, messages: list, **settings) -> MqttLink:
    s = Settings(**{"data_dir": tmp_path, "mqtt_host": "127.0.0.1", "mqtt_port": port,
                    "mqtt_client_id": "linktest", **settings})
    return MqttLink(s, TOPICS, lambda: None, lambda topic, payload: messages.append((topic, payload)))


@pytest.fixture
def broker(tmp_path):
    mosquitto = Mosquitto(tmp_path).start()
    yield mosquitto
    mosquitto.stop()


def test_a_dropped_connection_leaves_the_last_will_and_reconnects(tmp_path, broker):
    observer = Observer(broker.port, (TOPICS.availability,)).start()
    link = _link(tmp_path, broker.port, [])
    try:
        link.start()
        observer.wait(lambda: observer.latest.get(TOPICS.availability) == b"online", 10, "online")
        assert link.connected.wait(5)
        # Cut the TCP connection without an MQTT DISCONNECT, as a crash or a pulled cable would.
        link._client.socket().shutdown(socket.SHUT_RDWR)
        observer.wait(lambda: b"offline" in [p for _, t, p, _ in observer.messages], 10, "the last will")
        observer.wait(lambda: link.connections >= 2 and observer.latest.get(TOPICS.availability) == b"online",
                      15, "online again after reconnecting")
    finally:
        link.stop()
        observer.stop()


def test_commands_reach_the_link(tmp_path, broker):
    messages: list = []
    link = _link(tmp_path, broker.port, messages)
    observer = Observer(broker.port, ()).start()
    try:
        link.start()
        assert link.connected.wait(10)
        observer.wait(lambda: observer.client.is_connected(), 10, "observer connected")
        deadline = time.monotonic() + 10
        while not messages and time.monotonic() < deadline:  # the subscription may still be on its way
            observer.publish("linktest/not-a-command-topic", "x")
            observer.publish(TOPICS.command, '{"command": "stop"}')
            time.sleep(0.3)
        assert messages and set(messages) == {(TOPICS.command, b'{"command": "stop"}')}
    finally:
        link.stop()
        observer.stop()


def _openssl(*args: str, cwd) -> None:
    subprocess.run([system_tool("openssl", "openssl"), *args], cwd=cwd, check=True, capture_output=True,
                   timeout=60)


def test_tls_with_a_ca_file_and_a_password(tmp_path):
    _openssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "2", "-subj", "/CN=test CA",
             "-keyout", "ca.key", "-out", "ca.crt", cwd=tmp_path)
    _openssl("req", "-newkey", "rsa:2048", "-nodes", "-subj", "/CN=127.0.0.1", "-keyout", "server.key",
             "-out", "server.csr", cwd=tmp_path)
    (tmp_path / "san.ext").write_text("subjectAltName=IP:127.0.0.1\n")
    _openssl("x509", "-req", "-in", "server.csr", "-CA", "ca.crt", "-CAkey", "ca.key", "-CAcreateserial",
             "-days", "2", "-extfile", "san.ext", "-out", "server.crt", cwd=tmp_path)
    passwd = system_tool("mosquitto_passwd", "mosquitto")
    subprocess.run([passwd, "-b", "-c", str(tmp_path / "passwd"), "robot", "s3cret-pass"], check=True,
                   capture_output=True, timeout=30)
    options = (f"cafile {tmp_path / 'ca.crt'}\ncertfile {tmp_path / 'server.crt'}\n"
               f"keyfile {tmp_path / 'server.key'}\npassword_file {tmp_path / 'passwd'}\n")
    broker = Mosquitto(tmp_path, listener_options=options, anonymous=False).start()
    good = _link(tmp_path, broker.port, [], mqtt_tls=True, mqtt_ca_file=tmp_path / "ca.crt",
                 mqtt_username="robot", mqtt_password="s3cret-pass")
    wrong = _link(tmp_path, broker.port, [], mqtt_tls=True, mqtt_ca_file=tmp_path / "ca.crt",
                  mqtt_username="robot", mqtt_password="wrong", mqtt_client_id="intruder")
    try:
        good.start()
        wrong.start()
        assert good.connected.wait(15), "TLS + password should connect"
        assert not wrong.connected.wait(2), "a wrong password must be refused"
    finally:
        good.stop()
        wrong.stop()
        broker.stop()
