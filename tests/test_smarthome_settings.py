"""The MQTT settings: ones that do not fit together stop ``homebot serve`` with one line before it
starts, and a custom topic prefix, discovery prefix and client id reach every discovery payload."""

from __future__ import annotations

import pytest

from app.cli import main
from app.smarthome import commands as cmd
from app.smarthome.discovery import Device, discovery_configs
from app.smarthome.topics import Topics
from tests.ha_discovery_schema import check


@pytest.mark.parametrize(("env", "reason"), [
    ({"HOMEBOT_MQTT_TLS": "1", "HOMEBOT_MQTT_CA_FILE": "missing-ca.crt"}, "missing-ca.crt is not a file"),
    ({"HOMEBOT_MQTT_CA_FILE": "ca.crt"}, "used only with HOMEBOT_MQTT_TLS=1"),
    ({"HOMEBOT_MQTT_USERNAME": "", "HOMEBOT_MQTT_PASSWORD": "hunter2-secret"}, "needs HOMEBOT_MQTT_USERNAME"),
    ({"HOMEBOT_MQTT_CLIENT_ID": "robot#1"}, "mqtt_client_id"),
    ({"HOMEBOT_MQTT_PORT": "0"}, "mqtt_port"),
])
def test_mqtt_settings_that_do_not_fit_are_one_line_before_the_start(capsys, monkeypatch, tmp_path, env,
                                                                       reason):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "ca.crt").write_text("not used\n")
    for key, value in {"HOMEBOT_DATA_DIR": str(tmp_path / "data"), "HOMEBOT_MQTT_HOST": "127.0.0.1",
                       **env}.items():
        monkeypatch.setenv(key, value)
    assert main(["serve"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("homebot serve: error: ") and reason in err, err
    assert "hunter2" not in err  # the settings' values are not echoed
    assert not (tmp_path / "data").exists()


def test_a_custom_prefix_and_client_id_reach_every_discovery_payload():
    topics = Topics("home/robot-1", "ha", "robot-1")
    configs = discovery_configs(topics, Device("robot-1"), ["mapping", "localization"], ["kitchen"], ["Hall"])
    assert len(configs) == 11
    for topic, payload in configs.items():
        component = topic.split("/")[1]
        assert topic.startswith("ha/") and topic.split("/")[2] == "robot-1", topic
        assert check(component, payload) == [], (topic, check(component, payload))
        assert payload["unique_id"].startswith("robot-1_") and payload["device"]["identifiers"] == ["robot-1"]
        own = [v for k, v in payload.items() if k.endswith("_topic")]
        assert own and all(t.startswith("home/robot-1/") for t in own), payload
    assert set(topics.commands()) == {v for p in configs.values() for k, v in p.items()
                                      if k.endswith("command_topic")} | {topics.command}
    request = cmd.parse(topics, "home/robot-1/goto/set", b"room: Hall")
    assert request.command == cmd.GoToRoom("Hall")
    with pytest.raises(cmd.CommandError, match="no commands on topic"):
        cmd.parse(topics, "homebot/command", b'{"command": "stop"}')
