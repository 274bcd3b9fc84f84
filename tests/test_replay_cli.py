"""``homebot serve --replay``: bad arguments are refused with a reason before anything is served."""

import json

import pytest

from app.cli import main


def refused(capsys, argv) -> str:
    assert main(argv) == 2
    return capsys.readouterr().err


def test_an_unknown_log_is_refused(capsys, tmp_path):
    err = refused(capsys, ["serve", "--data", str(tmp_path), "--replay", "no-such-log"])
    assert "no log file 'no-such-log'" in err and "intel" in err


def test_a_log_without_laser_records_is_refused(capsys, tmp_path):
    log = tmp_path / "empty.clf"
    log.write_text("# nothing but a comment\n")
    assert "no laser records" in refused(capsys, ["serve", "--data", str(tmp_path), "--replay", str(log)])


def test_a_garbled_laser_line_is_refused_with_its_line(capsys, tmp_path):
    log = tmp_path / "bad.clf"
    log.write_text("FLASER 3 1.0 2.0\n")
    assert "bad.clf" in refused(capsys, ["serve", "--data", str(tmp_path), "--replay", str(log)])


def test_speed_and_exit_at_end_need_a_replay(capsys, tmp_path):
    for flag in (["--speed", "2"], ["--exit-at-end"]):
        assert "go with --replay" in refused(capsys, ["serve", "--data", str(tmp_path), *flag])


@pytest.mark.parametrize("speed", ["0", "-1", "fast", "inf", "nan"])
def test_a_speed_must_be_positive_or_max(capsys, speed):
    with pytest.raises(SystemExit) as info:
        main(["serve", "--replay", "mit-csail", "--speed", speed])
    assert info.value.code == 2
    assert "positive number or 'max'" in capsys.readouterr().err


def test_a_config_that_is_not_a_slam_config_is_refused(capsys, tmp_path):
    config = tmp_path / "config.json"
    config.write_text(json.dumps({"particles": 8, "no_such_setting": 1}))
    err = refused(capsys, ["serve", "--data", str(tmp_path), "--config", str(config)])
    assert "not a SLAM config" in err
    config.write_text("{not json")
    assert "config.json" in refused(capsys, ["serve", "--data", str(tmp_path), "--config", str(config)])
