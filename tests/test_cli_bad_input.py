"""Every subcommand turns a bad input file into one line on stderr that names the file (and the
line, where there is one) and exits 2; no traceback unless ``--debug`` (the corpus is in
``tests/bad_input.py``; ``serve --replay`` refuses a bad log before it serves)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from app.cli import main
from tests.bad_input import (
    BAD_CONFIGS,
    BAD_LOGS,
    BAD_MAPS,
    BAD_ROBOTS,
    BAD_WORLDS,
    GOOD_PGM,
    GOOD_YAML,
    SHIPPED_WORLD,
    write_bad_log,
    write_bad_map,
)
from tests.live_server import ROOT

LOG_COMMANDS = ("map", "slam", "ekf", "localize")


def one_line_error(capsys, argv) -> str:
    code = main(argv)
    err = capsys.readouterr().err.strip()
    assert code == 2, (argv, code, err)
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert err.startswith(f"homebot {argv[0]}: error: "), err
    return err


@pytest.fixture
def good_map(tmp_path):
    (tmp_path / "good.pgm").write_bytes(GOOD_PGM)
    (tmp_path / "good.yaml").write_text(GOOD_YAML.format(image="good.pgm"))
    return tmp_path / "good.yaml"


@pytest.mark.parametrize("command", LOG_COMMANDS)
@pytest.mark.parametrize("case", sorted(BAD_LOGS))
def test_a_bad_log_is_one_line_naming_the_file(capsys, tmp_path, good_map, command, case):
    log, expected = write_bad_log(tmp_path, case)
    extra = ["--map", str(good_map)] if command == "localize" else []
    err = one_line_error(capsys, [command, str(log), "--out", str(tmp_path / "out"), *extra])
    assert expected in err, err


@pytest.fixture
def never_serves(monkeypatch):
    """``homebot serve`` must refuse its input before the server starts."""
    import uvicorn

    class NeverServes:
        def __init__(self, config):
            raise AssertionError("homebot serve started a server on bad input")

    monkeypatch.setattr(uvicorn, "Server", NeverServes)


@pytest.mark.parametrize("case", sorted(BAD_LOGS))
def test_serve_refuses_a_bad_log_to_replay_before_serving(capsys, never_serves, tmp_path, case):
    log, expected = write_bad_log(tmp_path, case)
    err = one_line_error(capsys, ["serve", "--replay", str(log), "--data", str(tmp_path / "data")])
    assert expected in err, err


@pytest.mark.parametrize("case", sorted(BAD_CONFIGS))
def test_a_bad_slam_config_is_refused_by_slam_and_serve(capsys, never_serves, tmp_path, case):
    config = tmp_path / "config.json"
    config.write_bytes(BAD_CONFIGS[case][0])
    log, _ = write_bad_log(tmp_path, "empty")  # read only after the config
    commands = (["slam", str(log), "--out", str(tmp_path / "out")], ["serve", "--data", str(tmp_path / "d")])
    for argv in commands:
        err = one_line_error(capsys, [*argv, "--config", str(config)])
        assert "config.json" in err and BAD_CONFIGS[case][1] in err, err


@pytest.mark.parametrize("option, value, says", [("--particles", "0", "particles >= 1"),
                                                  ("--linear-update", "nan", "linear_update must be"),
                                                  ("--angular-update", "1e300", "angular_update must be")])
def test_slam_options_are_checked_like_a_config_file(capsys, tmp_path, option, value, says):
    log, _ = write_bad_log(tmp_path, "empty")  # read only after the settings
    assert says in one_line_error(capsys, ["slam", str(log), "--out", str(tmp_path / "o"), option, value])


def test_serve_names_a_bad_setting_in_one_line(capsys, never_serves, monkeypatch, tmp_path):
    err = one_line_error(capsys, ["serve", "--data", str(tmp_path), "--port", "99999"])
    assert "port: Input should be less than or equal to 65535" in err and "pydantic.dev" not in err, err
    monkeypatch.setenv("HOMEBOT_TOKEN", "short")
    err = one_line_error(capsys, ["serve", "--data", str(tmp_path)])
    assert "token: String should have at least 32 characters" in err, err


@pytest.mark.parametrize("name, says", [("HOMEBOT_PARTICLES", "the --config file"),
                                         ("HOMEBOT_MAX_SPED", "did you mean HOMEBOT_MAX_SPEED?")])
def test_serve_refuses_a_homebot_variable_that_names_no_setting(capsys, never_serves, monkeypatch, tmp_path,
                                                                name, says):
    monkeypatch.setenv(name, "50")
    err = one_line_error(capsys, ["serve", "--data", str(tmp_path)])
    assert f"unknown setting {name}" in err and says in err, err


@pytest.mark.parametrize("case", sorted(BAD_ROBOTS))
def test_a_bad_robot_file_is_refused_by_every_command_that_reads_one(capsys, never_serves, tmp_path, case):
    robot = tmp_path / "robot.yaml"
    robot.write_bytes(BAD_ROBOTS[case][0])
    commands = (["serve", "--data", str(tmp_path / "d")], ["link", "/dev/null", "--seconds", "0.1"],
                ["sim", "record", "flat", "--out", str(tmp_path / "o")])
    for argv in commands:
        err = one_line_error(capsys, [*argv, "--robot", str(robot)])
        assert "robot.yaml" in err and BAD_ROBOTS[case][1] in err, err


@pytest.mark.parametrize("case", sorted(BAD_MAPS))
def test_localize_refuses_a_bad_map_by_name(capsys, tmp_path, case):
    problem = write_bad_map(tmp_path, case, case)
    log, _ = write_bad_log(tmp_path, "empty")
    err = one_line_error(capsys, ["localize", str(log), "--map", str(tmp_path / f"{case}.yaml"),
                                  "--out", str(tmp_path / "out")])
    assert problem in err and case in err, err


@pytest.mark.parametrize("case", ["binary", "empty", "directory", "nan_pose"])
def test_eval_refuses_bad_trajectories_and_relations(capsys, tmp_path, case):
    bad, _ = write_bad_log(tmp_path, case)
    good = tmp_path / "good.txt"
    good.write_text("0.0 0 0 0\n1.0 1 0 0\n")
    relations = tmp_path / "good.relations"
    relations.write_text("0.0 1.0 1 0 0 0 0 0\n")
    assert bad.name in one_line_error(capsys, ["eval", str(bad), str(relations)])
    assert bad.name in one_line_error(capsys, ["eval", str(good), str(bad)])


@pytest.mark.parametrize("case", ["binary", "empty", "directory"])
def test_sim_record_refuses_a_bad_world_file(capsys, tmp_path, case):
    world, _ = write_bad_log(tmp_path, case)
    assert world.name in one_line_error(capsys, ["sim", "record", str(world), "--out", str(tmp_path / "o")])


@pytest.mark.parametrize("trajectory, relations", [("0 0 0 0\n1 1e300 0 0\n", "0 1 1 0 0 0 0 0\n"),
                                                    ("0 0 0 0\n1 1 0 0\n", "0 1 1e300 0 0 0 0 0\n")])
def test_eval_refuses_huge_numbers(capsys, tmp_path, trajectory, relations):
    (tmp_path / "t.txt").write_text(trajectory)
    (tmp_path / "r.relations").write_text(relations)
    err = one_line_error(capsys, ["eval", str(tmp_path / "t.txt"), str(tmp_path / "r.relations")])
    assert "within ±1e+06" in err and ("t.txt" in err or "r.relations" in err), err


@pytest.mark.parametrize("case", sorted(BAD_WORLDS))
def test_sim_record_refuses_nan_huge_numbers_and_a_start_outside_the_walls(capsys, tmp_path, case):
    world = tmp_path / "world.txt"
    text, expected = BAD_WORLDS[case]
    assert text != SHIPPED_WORLD.read_text(), "the case changed the shipped world"
    world.write_text(text)
    assert expected in one_line_error(capsys, ["sim", "record", str(world), "--out", str(tmp_path / "o")])


@pytest.mark.parametrize("case", ["binary", "directory"])
def test_link_refuses_what_is_not_a_serial_device(capsys, tmp_path, case):
    port, _ = write_bad_log(tmp_path, case)
    assert f"{port}: not a serial device" in one_line_error(capsys, ["link", str(port), "--seconds", "0.1"])


def test_the_process_prints_no_traceback_unless_debug(tmp_path):
    log, _ = write_bad_log(tmp_path, "directory")

    def run(*flags):
        command = [sys.executable, "-m", "app.cli", *flags, "slam", str(log), "--out", str(tmp_path)]
        return subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=120)

    quiet, loud = run(), run("--debug")
    assert quiet.returncode == 2 and quiet.stderr.strip() == f"homebot slam: error: {log}: Is a directory"
    assert loud.returncode != 0 and "Traceback" in loud.stderr and "IsADirectoryError" in loud.stderr
