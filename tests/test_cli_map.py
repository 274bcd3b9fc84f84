"""``homebot map`` and ``homebot eval`` end to end, on a synthetic room and on a bundled log."""

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import yaml
from PIL import Image

from app.cli import main
from slam_core.io.ros_map import load_map
from slam_core.io.trajectory import Trajectory

ROOT = Path(__file__).resolve().parents[1]

#: The synthetic room: walls at x = XMIN, XMAX and y = YMIN, YMAX (metres).
XMIN, XMAX, YMIN, YMAX = -3.0, 4.0, -2.0, 2.5


def range_to_walls(x, y, bearing):
    """Distance from (x, y) inside the room to its walls along ``bearing``."""
    c, s = math.cos(bearing), math.sin(bearing)
    hits = []
    if c > 1e-12:
        hits.append((XMAX - x) / c)
    if c < -1e-12:
        hits.append((XMIN - x) / c)
    if s > 1e-12:
        hits.append((YMAX - y) / s)
    if s < -1e-12:
        hits.append((YMIN - y) / s)
    return min(hits)


def room_log(path, n_scans=24, truncate=False, bad_line=None):
    lines = ["# synthetic room log\n", "PARAM robot_frontlaser_offset 0.0 nohost 0\n"]
    stamps, poses = [], []
    for k in range(n_scans):
        t = k / n_scans
        pose = (2.0 * math.cos(2 * math.pi * t) + 0.3, 1.2 * math.sin(2 * math.pi * t), 2 * math.pi * t)
        bearings = np.radians(np.arange(-90, 90))
        ranges = [range_to_walls(pose[0], pose[1], pose[2] + b) for b in bearings]
        stamp = f"{1000 + 0.4 * k:.6f}"
        nums = " ".join(f"{r:.3f}" for r in ranges) + " " + " ".join(f"{v:.6f}" for v in pose * 2)
        lines.append(f"FLASER 180 {nums} {stamp} synth {0.4 * k:.6f}\n")
        lines.append(f"ODOM {pose[0]:.6f} {pose[1]:.6f} {pose[2]:.6f} 0.3 0.1 0.0 {stamp} synth 0.1\n")
        stamps.append(stamp)
        poses.append(pose)
    if bad_line is not None:
        lines.insert(bad_line, "FLASER 3 1.0 oops 1.0 0 0 0 0 0 0 1.0 synth 0.1\n")
    text = "".join(lines)
    if truncate:
        text += lines[2][:300]
    path.write_text(text)
    return stamps, np.array(poses)


def test_map_of_a_synthetic_room(tmp_path, capsys):
    log = tmp_path / "room.clf"
    stamps, poses = room_log(log)
    out = tmp_path / "out"
    assert main(["map", str(log), "--out", str(out), "--resolution", "0.05"]) == 0
    printed = capsys.readouterr().out
    assert "integrated 24 scans" in printed and "no SLAM" in printed and "map.yaml" in printed

    for name in ("map.pgm", "map.yaml", "map.png", "trajectory.txt"):
        assert (out / name).is_file(), name
    meta = yaml.safe_load((out / "map.yaml").read_text())
    assert meta["image"] == "map.pgm" and meta["resolution"] == 0.05

    traj = Trajectory.load(out / "trajectory.txt")
    assert traj.stamps == stamps
    assert np.allclose(traj.poses[:, :2], poses[:, :2], atol=1e-6)

    grid = load_map(out / "map.yaml")
    with Image.open(out / "map.png") as png:
        assert png.size == (grid.shape[1], grid.shape[0])
    tri = grid.trinary()
    iy, ix = np.nonzero(tri == 100)
    assert len(ix) > 200
    centres = grid.cell_to_world(np.column_stack([ix, iy]))
    # Every occupied cell touches a wall (cell centres within one cell diagonal of it).
    gap = np.minimum.reduce([np.abs(centres[:, 0] - XMIN), np.abs(centres[:, 0] - XMAX),
                             np.abs(centres[:, 1] - YMIN), np.abs(centres[:, 1] - YMAX)])
    assert gap.max() <= 0.05
    # The walls are there: nearly every cell along them is occupied.
    along_x = np.linspace(XMIN + 0.2, XMAX - 0.2, 100)
    along_y = np.linspace(YMIN + 0.2, YMAX - 0.2, 100)
    wall_points = np.concatenate([
        np.column_stack([along_x, np.full(100, YMIN)]),
        np.column_stack([along_x, np.full(100, YMAX)]),
        np.column_stack([np.full(100, XMIN), along_y]),
        np.column_stack([np.full(100, XMAX), along_y]),
    ])
    # Echoes land within a rounding error of a wall, so in the cell on either side of it.
    normal = np.repeat([[0, 1], [0, 1], [1, 0], [1, 0]], 100, axis=0) * 0.01
    near = np.maximum(state(grid, wall_points + normal), state(grid, wall_points - normal))
    assert (near == 100).mean() > 0.95
    # Between the robot's circle and the walls is free (the robot faces outwards), outside unknown.
    assert (state(grid, np.array([[3.5, 0.2], [0.3, 2.0], [-2.5, 0.0], [0.3, -1.7]])) == 0).all()
    assert (state(grid, np.array([[XMAX + 0.5, 0.0], [0.0, YMIN - 0.5], [XMIN - 1, YMAX + 1]])) == -1).all()


def state(grid, points):
    """Trinary value at world points (-1 outside the grid)."""
    cells = grid.world_to_cell(points)
    tri = grid.trinary()
    return np.array([tri[iy, ix] if grid.contains_cell(ix, iy) else -1 for ix, iy in cells])


def test_map_of_a_missing_file_fails_clearly(tmp_path, capsys):
    missing = tmp_path / "nope.clf"
    code = main(["map", str(missing), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code != 0
    assert "nope.clf" in err and "error" in err
    assert not (tmp_path / "out").exists()


def test_map_of_a_malformed_log_names_the_line(tmp_path, capsys):
    log = tmp_path / "bad.clf"
    room_log(log, n_scans=4, bad_line=5)
    code = main(["map", str(log), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code != 0 and "bad.clf:6:" in err and "oops" in err


def test_map_of_a_log_without_scans_fails_clearly(tmp_path, capsys):
    log = tmp_path / "empty.clf"
    log.write_text("# nothing but a comment\nODOM 1 2 3 4 5 6 100.0 h 0\n")
    assert main(["map", str(log), "--out", str(tmp_path / "out")]) != 0
    assert "empty.clf: no laser records" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_map_of_a_truncated_log_warns_and_keeps_the_scans(tmp_path, capsys):
    log = tmp_path / "cut.clf"
    room_log(log, n_scans=5, truncate=True)
    assert main(["map", str(log), "--out", str(tmp_path / "out")]) == 0
    printed = capsys.readouterr().out
    assert "warning:" in printed and "cut short" in printed and "integrated 5 scans" in printed
    assert len((tmp_path / "out" / "trajectory.txt").read_text().splitlines()) == 5


def test_eval_of_the_ground_truth_scores_zero(tmp_path, capsys):
    stamps, poses = room_log(tmp_path / "room.clf", n_scans=10)
    traj = Trajectory(stamps, poses).save(tmp_path / "truth.txt")
    rel = tmp_path / "room.relations"
    rows = []
    for i in range(9):
        c, s = math.cos(poses[i, 2]), math.sin(poses[i, 2])
        dx, dy = poses[i + 1, :2] - poses[i, :2]
        dth = math.remainder(poses[i + 1, 2] - poses[i, 2], 2 * math.pi)
        local = (c * dx + s * dy, -s * dx + c * dy)
        rows.append(f"{stamps[i]} {stamps[i + 1]} {local[0]:.6f} {local[1]:.6f} 0 0 0 {dth:.6f}")
    rel.write_text("\n".join(rows) + "\n")
    assert main(["eval", str(traj), str(rel), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["relations"] == 9 and s["unmatched"] == 0
    assert s["trans_mean_m"] < 1e-5 and s["rot_mean_deg"] < 1e-3


def test_eval_missing_relations_fails_clearly(tmp_path, capsys):
    traj = Trajectory(["1.0", "2.0"], np.zeros((2, 3))).save(tmp_path / "t.txt")
    assert main(["eval", str(traj), str(tmp_path / "gone.relations")]) != 0
    assert "gone.relations" in capsys.readouterr().err


def test_map_mit_csail_as_a_subprocess_then_eval(tmp_path, capsys):
    out = tmp_path / "mit"
    proc = subprocess.run([sys.executable, "-m", "app.cli", "map", "mit-csail", "--out", str(out)],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "integrated 1988 scans" in proc.stdout and "CC-BY" in proc.stdout
    for name in ("map.pgm", "map.png"):
        assert (out / name).stat().st_size > 1000
    lines = (out / "trajectory.txt").read_text().splitlines()
    assert len(lines) == 1988 and lines[0].split()[0] == "1134864629.895182"
    grid = load_map(out / "map.yaml")
    assert (grid.trinary() == 100).sum() > 1000 and (grid.trinary() == 0).sum() > 10000
    # The log's laser poses are its raw odometry: eval prints the raw-odometry figures.
    assert main(["eval", str(out / "trajectory.txt"), "mit-csail"]) == 0
    printed = capsys.readouterr().out
    assert "1172 matched, 0 unmatched" in printed
    assert "1.6815 ± 5.2945 m" in printed and "5.072 ± 8.245 deg" in printed
