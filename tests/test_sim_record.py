import numpy as np
import pytest

from app.cli import main
from slam_core.io.carmen import CarmenReader, LaserRecord, OdomRecord
from slam_core.io.ros_map import load_map
from slam_core.io.trajectory import Trajectory
from slam_core.occupancy_grid import OccupancyGrid, SensorModel
from slam_core.sim.record import record_tour
from slam_core.sim.world import load_world

DURATION = 12.0


@pytest.fixture(scope="module")
def flat_recording(tmp_path_factory):
    out = tmp_path_factory.mktemp("flat")
    world = load_world("flat")
    return world, record_tour(world, out, seed=3, duration=DURATION)


def test_log_reads_back_with_the_right_counts(flat_recording):
    world, rec = flat_recording
    reader = CarmenReader(rec.log)
    records = list(reader)
    lasers = [r for r in records if isinstance(r, LaserRecord)]
    odoms = [r for r in records if isinstance(r, OdomRecord)]
    assert len(lasers) == len(odoms) == rec.scans == int(DURATION * 20) + 1
    assert not reader.skipped
    scan = lasers[0].scan
    assert len(scan) == 360 and scan.range_max == 8.0
    assert scan.angles[0] == pytest.approx(-np.pi) and np.allclose(np.diff(scan.angles), 2 * np.pi / 360)
    truth = Trajectory.load(rec.ground_truth)
    assert truth.stamps == [r.stamp.ipc_text for r in lasers]
    assert np.allclose(truth.poses[0], world.start, atol=1e-6)
    # the log carries odometry: equal to the truth at the start, drifted from it at the end
    assert np.allclose(lasers[0].pose, world.start, atol=1e-6)
    odo = np.array([r.pose for r in lasers])
    assert np.allclose(odo[-1], truth.poses[-1] + rec.final_odometry_error, atol=1e-5)
    assert 0.001 < np.hypot(*rec.final_odometry_error[:2]) < 1.0
    assert np.hypot(*(truth.poses[-1, :2] - truth.poses[0, :2])) > 1.0  # it actually drove


def test_scans_match_ray_casting_from_the_true_pose(flat_recording):
    world, rec = flat_recording
    from slam_core.sim.lidar import Lidar
    lidar = Lidar(world)
    truth = Trajectory.load(rec.ground_truth)
    lasers = [r for r in CarmenReader(rec.log) if isinstance(r, LaserRecord)]
    for i in (0, len(lasers) // 2, len(lasers) - 1):
        expected = lidar.true_ranges(truth.poses[i])
        got = lasers[i].scan.ranges
        ok = (got > 0) & (expected < 8.0)
        assert np.median(np.abs(got[ok] - expected[ok])) < 0.02  # 1 cm noise, mm text


def test_ground_truth_scans_rebuild_the_ground_truth_walls(flat_recording):
    world, rec = flat_recording
    gt = load_map(rec.map_yaml)
    truth = Trajectory.load(rec.ground_truth)
    grid = OccupancyGrid(gt.resolution, model=SensorModel(usable_range=8.0))
    for rec_i, pose in zip([r for r in CarmenReader(rec.log) if isinstance(r, LaserRecord)],
                           truth.poses, strict=True):
        grid.integrate(rec_i.scan, pose)
    occ = grid.trinary() == 100
    gt_occ = gt.trinary() == 100
    assert gt_occ.sum() > 500 and occ.sum() > 300
    # put both on the ground-truth lattice; the grids share the resolution and the cell lattice
    offset = np.round((grid.origin - gt.origin) / gt.resolution).astype(int)
    iy, ix = np.nonzero(occ)
    gx, gy = ix + offset[0], iy + offset[1]
    inside = (gx >= 1) & (gy >= 1) & (gx < gt_occ.shape[1] - 1) & (gy < gt_occ.shape[0] - 1)
    assert inside.mean() > 0.99
    near = np.zeros_like(gt_occ)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            near |= np.roll(np.roll(gt_occ, dy, 0), dx, 1)
    precision = near[gy[inside], gx[inside]].mean()
    assert precision > 0.97
    # and the start pose is free floor in the ground-truth map
    sx, sy = gt.world_to_cell(world.start[:2])
    assert gt.trinary()[sy, sx] == 0


def test_cli_records_depth_camera_logs(tmp_path):
    out = tmp_path / "run"
    assert main(["sim", "record", "house", "--out", str(out), "--sensor", "depth", "--duration", "2",
                 "--seed", "4"]) == 0
    for name in ("sim.clf", "groundtruth.txt", "groundtruth_map.pgm", "groundtruth_map.yaml",
                 "groundtruth_map.png", "world.txt"):
        assert (out / name).is_file()
    lasers = [r for r in CarmenReader(out / "sim.clf") if isinstance(r, LaserRecord)]
    assert len(lasers) == 41
    span = lasers[0].scan.angles[-1] - lasers[0].scan.angles[0]
    assert span == pytest.approx(np.radians(57.0), rel=0.02)
    assert lasers[0].scan.valid.sum() > 0


def test_cli_rejects_bad_input(tmp_path, capsys):
    assert main(["sim", "record", "nowhere", "--out", str(tmp_path)]) == 2
    assert "no world file" in capsys.readouterr().err
    assert main(["sim", "record", "flat", "--out", str(tmp_path), "--duration", "-1"]) == 2
    assert main(["sim", "worlds"]) == 0
    assert "house" in capsys.readouterr().out
