"""One SLAM config: the server maps with ``homebot slam``'s settings (its defaults or the same
``--config`` file) and writes the effective robot and SLAM settings beside its outputs."""

from __future__ import annotations

import dataclasses
import json
import types

import numpy as np
import yaml

from app.cli.serve import write_effective_config
from app.cli.slam import effective_config
from app.core.config import Settings
from app.worker.estimators import make_estimator
from slam_core.datasets import resolve_log
from slam_core.io.carmen import laser_mount_of
from slam_core.rbpf.config import RBPFConfig
from slam_core.robot_config import load_robot


def _slam_args(config=None):
    """What ``homebot slam LOG --config FILE`` parses, without the overrides."""
    return types.SimpleNamespace(config=config, particles=None, linear_update=None, angular_update=None,
                                 no_loop_closure=False)


def test_the_server_maps_with_homebot_slams_defaults(tmp_path):
    settings = Settings(data_dir=tmp_path)
    assert settings.slam() == effective_config(_slam_args()) == RBPFConfig()
    slam = make_estimator("mapping", settings, None)
    assert slam.config == RBPFConfig() and settings.resolution == RBPFConfig().resolution


def test_the_server_maps_with_the_file_homebot_slam_takes(tmp_path):
    config = dataclasses.replace(RBPFConfig(), particles=7, linear_update=0.35, angular_update=0.15,
                                 resolution=0.1)
    path = tmp_path / "config.json"
    path.write_text(json.dumps(config.to_dict()))
    settings = Settings(data_dir=tmp_path, slam_config=path)  # a robot, not a replay
    assert effective_config(_slam_args(path)) == config
    slam = make_estimator("mapping", settings, None)
    assert slam.config == config and settings.resolution == 0.1


def test_the_effective_robot_and_slam_settings_are_written_and_read_back(tmp_path):
    data = load_robot().to_dict()
    data["laser"]["mount"] = {"x": 0.1, "y": -0.02, "theta": 0.25}
    robot_file = tmp_path / "mine.yaml"
    robot_file.write_text(yaml.safe_dump(data))
    settings = Settings(data_dir=tmp_path / "data", robot=robot_file)
    written = write_effective_config(settings)
    assert sorted(p.name for p in written) == ["config.json", "robot.yaml"]
    assert load_robot(tmp_path / "data" / "robot.yaml") == load_robot(robot_file)
    again = effective_config(_slam_args(tmp_path / "data" / "config.json"))
    assert again == settings.slam()


def test_a_replay_writes_its_config_and_the_logs_laser_mount_beside_its_outputs(tmp_path):
    settings = Settings(data_dir=tmp_path, replay="mit-csail")
    write_effective_config(settings)
    out = tmp_path / "replay" / "mit-csail"
    assert RBPFConfig.from_dict(json.loads((out / "config.json").read_text())) == settings.slam()
    mount = load_robot(out / "robot.yaml").laser.mount.as_tuple()
    np.testing.assert_allclose(mount, laser_mount_of(resolve_log("mit-csail")))
    assert load_robot(tmp_path / "robot.yaml") == load_robot(out / "robot.yaml")
