"""``homebot link``: a bring-up report over a real pty."""

from __future__ import annotations

import json

import numpy as np
import yaml

from app.cli import main
from app.robot_link.virtual_mcu import LineFaults, VirtualMCU
from slam_core.robot_config import load_robot


class Rolling:
    """Wheels creeping forward one tick per sample (a stand-in for the simulator)."""

    def __init__(self):
        self.n = 0

    def ticks(self):
        self.n += 1
        return self.n, self.n

    def set_velocity(self, v, w):
        pass


def test_link_reports_frames_and_pose(capsys):
    with VirtualMCU(Rolling()) as mcu:
        assert main(["link", mcu.path, "--seconds", "0.6", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["frames_ok"] >= 10
    assert report["rate_hz"] > 15
    assert report["pose"][0] > 0 and abs(report["pose"][1]) < 1e-12
    assert report["ticks"][0] == report["ticks"][1] > 0


def test_link_explains_a_line_without_valid_frames(capsys):
    every_byte_corrupt = LineFaults(np.random.default_rng(3), flip_rate=1.0)
    with VirtualMCU(Rolling(), faults=every_byte_corrupt) as mcu:
        assert main(["link", mcu.path, "--seconds", "0.4"]) == 1
    out = capsys.readouterr().out
    assert "no valid frame" in out and "PROTOCOL.md" in out


def test_link_rejects_bad_geometry(capsys, tmp_path):
    robot = load_robot().to_dict()
    robot["wheels"]["wheel_base"] = 0
    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump(robot))
    assert main(["link", "/dev/null", "--robot", str(path)]) == 2
    err = capsys.readouterr().err
    assert "wheels.wheel_base" in err and str(path) in err and "Traceback" not in err
