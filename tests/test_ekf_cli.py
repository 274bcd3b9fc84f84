"""``homebot ekf LOG --out DIR`` end to end on a slice of the MIT CSAIL log."""

import numpy as np
from PIL import Image

from app.cli import main
from slam_core.datasets import resolve_log
from slam_core.ekf.log_runner import LINE_COLUMNS, lines_csv_path, load_landmarks_csv
from slam_core.io.trajectory import Trajectory


def test_ekf_command_writes_map_image_table_and_per_scan_trajectory(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["ekf", str(resolve_log("mit-csail")), "--out", str(out), "--max-scans", "120"]) == 0
    traj = Trajectory.load(out / "trajectory.txt")
    assert len(traj.poses) == 120
    pos, cov, kinds = load_landmarks_csv(out / "landmarks.csv")
    assert len(pos) > 0 and set(kinds) <= {"spike", "corner"}
    assert np.all(np.linalg.eigvalsh(cov) > 0)
    lines = (out / "landmarks.csv").with_name("landmarks_lines.csv")
    assert lines == lines_csv_path(out / "landmarks.csv")
    rows = lines.read_text().splitlines()
    assert rows[0].split(",") == list(LINE_COLUMNS) and len(rows) > 1
    assert all(r.split(",")[1] == "line" for r in rows[1:])
    with Image.open(out / "landmarks.png") as img:
        assert img.size[0] > 50 and img.size[1] > 50
    assert "landmarks:" in capsys.readouterr().out


def test_ekf_command_runs_without_scan_matching(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["ekf", "mit-csail", "--out", str(out), "--max-scans", "40", "--no-scan-matching"]) == 0
    assert len(Trajectory.load(out / "trajectory.txt").poses) == 40
    assert "scan-matching failures: 0" in capsys.readouterr().out


def test_ekf_command_rejects_a_bad_scan_limit(tmp_path, capsys):
    assert main(["ekf", "mit-csail", "--out", str(tmp_path), "--max-scans", "0"]) == 2
    assert "--max-scans" in capsys.readouterr().err


def test_ekf_command_names_a_missing_log(tmp_path, capsys):
    assert main(["ekf", str(tmp_path / "nope.clf"), "--out", str(tmp_path)]) == 2
    assert "nope.clf" in capsys.readouterr().err
