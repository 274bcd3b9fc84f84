"""The robot description file: the shipped simulated robot, round trips and strict validation."""

import math

import pytest
import yaml

from slam_core.robot_config import RobotConfigError, load_robot


def _write(tmp_path, data, name="robot.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def _simulated() -> dict:
    return load_robot().to_dict()


def test_the_shipped_robot_is_the_simulated_one_and_round_trips(tmp_path):
    robot = load_robot()
    assert robot.name == "simulated"
    assert robot.wheels.ticks_per_rev == 1440 and isinstance(robot.wheels.ticks_per_rev, int)
    assert robot.laser.mount.as_tuple() == (0.0, 0.0, 0.0)
    assert load_robot(_write(tmp_path, robot.to_dict())) == robot
    (tmp_path / "dumped.yaml").write_text(robot.to_yaml())
    assert load_robot(tmp_path / "dumped.yaml") == robot


def test_a_different_robot_is_read_as_written(tmp_path):
    data = _simulated()
    data.update(name="vacuum", footprint_radius=0.21)
    data["wheels"] = {"wheel_radius": 0.04, "wheel_base": 0.31, "ticks_per_rev": 600}
    data["laser"]["mount"] = {"x": -0.05, "y": 0.02, "theta": -math.pi / 2}
    robot = load_robot(_write(tmp_path, data))
    assert robot.footprint_radius == 0.21
    assert robot.wheels.wheel_base == 0.31 and robot.wheels.ticks_per_rev == 600
    assert robot.laser.mount.as_tuple() == (-0.05, 0.02, -math.pi / 2)
    assert robot.wheels.metres_per_tick == pytest.approx(2 * math.pi * 0.04 / 600)


@pytest.mark.parametrize(("change", "key", "says"), [
    (lambda d: d["wheels"].update(tyre=0.1), "wheels.tyre", "unknown key"),
    (lambda d: d.update(colour="red"), "colour", "unknown key"),
    (lambda d: d["wheels"].pop("wheel_base"), "wheels.wheel_base", "missing key"),
    (lambda d: d.pop("laser"), "laser", "missing key"),
    (lambda d: d["laser"]["mount"].pop("theta"), "laser.mount.theta", "missing key"),
    (lambda d: d["wheels"].update(wheel_radius=-0.03), "wheels.wheel_radius", "positive"),
    (lambda d: d.update(footprint_radius=0), "footprint_radius", "positive"),
    (lambda d: d["laser"].update(height=-0.1), "laser.height", "negative"),
    (lambda d: d["limits"].update(v_max=float("nan")), "limits.v_max", "finite"),
    (lambda d: d["laser"]["mount"].update(x=float("inf")), "laser.mount.x", "finite"),
    (lambda d: d["wheels"].update(ticks_per_rev=1440.5), "wheels.ticks_per_rev", "integer"),
    (lambda d: d["limits"].update(w_max="fast"), "limits.w_max", "number"),
    (lambda d: d["limits"].update(a_max=True), "limits.a_max", "number"),
    (lambda d: d.update(wheels=[1, 2, 3]), "wheels", "mapping"),
    (lambda d: d["laser"].update(range_min=9.0), "laser.range_min", "below"),
])
def test_a_bad_robot_file_names_the_file_and_the_key(tmp_path, change, key, says):
    data = _simulated()
    change(data)
    path = _write(tmp_path, data)
    with pytest.raises(RobotConfigError) as info:
        load_robot(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ") and key in message and says in message


def test_a_negative_mount_offset_is_a_position_not_an_error(tmp_path):
    data = _simulated()
    data["laser"]["mount"] = {"x": -0.1, "y": -0.2, "theta": -3.0}
    assert load_robot(_write(tmp_path, data)).laser.mount.as_tuple() == (-0.1, -0.2, -3.0)


def test_a_file_that_is_not_yaml_is_refused(tmp_path):
    path = tmp_path / "robot.yaml"
    path.write_text("name: [unclosed\n")
    with pytest.raises(RobotConfigError, match=str(path)):
        load_robot(path)
