"""``homebot localize`` on a short simulator recording, scored against its ground truth."""

import re

import numpy as np
import pytest
from PIL import Image

from app.cli import main
from slam_core.geometry import wrap_angle
from slam_core.io.carmen import laser_records
from slam_core.io.ros_map import load_map
from slam_core.io.trajectory import Trajectory
from slam_core.localization.picture import LOCALIZED, NOT_LOCALIZED
from slam_core.sim.record import record_tour
from slam_core.sim.simulator import SimConfig
from slam_core.sim.world import load_world


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    world = load_world("flat")
    return record_tour(world, tmp_path_factory.mktemp("rec"), seed=3, duration=25.0,
                       config=SimConfig(sensing_hz=5.0)), world


def test_localize_writes_one_pose_per_scan_close_to_the_truth(recording, tmp_path, capsys):
    rec, world = recording
    x, y, th = world.start
    code = main(["localize", str(rec.log), "--map", str(rec.map_yaml), "--initial", f"{x},{y},{th}",
                 "--particles", "200,3000", "--out", str(tmp_path)])
    assert code == 0
    out = capsys.readouterr().out
    assert "first localized at scan" in out
    assert "localized rate: 100.0% of scans; lost 0 times" in out
    # the simulated wheels are 0.05 % off in size: the matches find the travel within 1 %
    scale = re.search(r"travel scale error ([+-][0-9.]+) %", out)
    assert scale is not None, out
    assert abs(float(scale.group(1))) <= 1.0
    picture = np.asarray(Image.open(tmp_path / "localization.png").convert("RGB"))
    assert picture.shape[:2] == load_map(rec.map_yaml).shape
    assert (picture == LOCALIZED).all(axis=2).sum() > 20  # the track, drawn as localized
    assert not (picture == NOT_LOCALIZED).all(axis=2).any()
    traj = Trajectory.load(tmp_path / "trajectory.txt")
    truth = Trajectory.load(rec.ground_truth)
    assert traj.stamps == truth.stamps == [r.stamp.ipc_text for r in laser_records(rec.log)]
    err = np.hypot(*(traj.poses[:, :2] - truth.poses[:, :2]).T)
    assert np.median(err) < 0.05
    assert np.median(np.abs(wrap_angle(traj.poses[:, 2] - truth.poses[:, 2]))) < np.radians(2)


def test_localize_refuses_a_malformed_initial_pose(recording, tmp_path, capsys):
    rec, _ = recording
    with pytest.raises(SystemExit):
        main(["localize", str(rec.log), "--map", str(rec.map_yaml), "--initial", "1,2",
              "--out", str(tmp_path)])
    assert "--initial must be 3 comma-separated numbers" in capsys.readouterr().err


def test_localize_reports_a_missing_map(recording, tmp_path, capsys):
    rec, _ = recording
    code = main(["localize", str(rec.log), "--map", str(tmp_path / "nope.yaml"), "--out", str(tmp_path)])
    assert code == 2
    assert "nope.yaml" in capsys.readouterr().err


def test_run_picture_marks_where_the_robot_was_lost(tmp_path):
    from slam_core.localization.picture import LOST, save_run_png
    from slam_core.occupancy_grid import OccupancyGrid

    grid = OccupancyGrid(0.1, origin=(0.0, 0.0), shape=(40, 60))
    poses = np.column_stack([np.linspace(0.5, 5.5, 50), np.full(50, 2.0), np.zeros(50)])
    flags = np.ones(50, bool)
    flags[20:30] = False
    picture = np.asarray(Image.open(save_run_png(grid, poses, flags, tmp_path / "p.png")).convert("RGB"))
    lost = np.argwhere((picture == LOST).all(axis=2))
    assert len(lost) > 0
    # the red ring sits where the flag dropped: scan 20, x = 0.5 + 20 * 5 / 49 m
    assert abs(lost[:, 1].mean() - (0.5 + 20 * 5 / 49) / 0.1) < 2
    assert (picture == NOT_LOCALIZED).all(axis=2).any()
    with pytest.raises(ValueError, match="localized flags"):
        save_run_png(grid, poses, flags[:3], tmp_path / "q.png")
