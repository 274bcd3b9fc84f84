"""Mapping sessions saved and continued (``homebot slam LOG --save-session NAME``, ``--resume FILE``).

The oracle is the simulator: a recorded tour of the flat split in two logs, the second
continuing where the first ended; the continued trajectory and map are held against the
ground truth.
"""

from __future__ import annotations

import json
import zipfile

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.ndimage import binary_dilation

from app.cli import main
from slam_core.graph.config import LoopClosureConfig
from slam_core.io.ros_map import load_map
from slam_core.io.trajectory import Trajectory
from slam_core.rbpf import RBPFConfig
from slam_core.rbpf.laser_mount import LaserMount
from slam_core.scan import Scan
from slam_core.session import SUFFIX, VERSION, MappingSession, SessionError, load_session, save_session
from slam_core.sim.record import record_tour
from slam_core.sim.world import load_world

TOUR_S = 110.0  # the flat's tour, long enough to come back to rooms seen in the first half
PARTICLES = 8
#: Occupied cells of the continued map within this many cells of a true wall.
WALL_CELLS = 2


def _session(rng: np.random.Generator, sizes: list[int]) -> MappingSession:
    scans = [Scan(np.sort(rng.uniform(-2.0, 2.0, n)),
                  np.where(rng.random(n) < 0.1, np.inf, rng.uniform(0.1, 9, n)), 0.05, 10.0, float(k))
             for k, n in enumerate(sizes)]
    poses = rng.normal(size=(len(sizes), 3))
    return MappingSession(RBPFConfig(particles=7), LaserMount(0.1, -0.02, 0.3), poses, poses + 0.5, scans,
                          poses[-1] + 0.1)


@settings(max_examples=25, deadline=None)
@given(sizes=st.lists(st.integers(0, 40), min_size=1, max_size=6), seed=st.integers(0, 2**32 - 1))
def test_a_session_reads_back_as_it_was_written(tmp_path_factory, sizes, seed):
    session = _session(np.random.default_rng(seed), sizes)
    path = save_session(session, tmp_path_factory.mktemp("s") / f"home{SUFFIX}")
    back = load_session(path)
    assert back.config == session.config and back.laser_mount == session.laser_mount
    assert np.array_equal(back.poses, session.poses) and np.array_equal(back.odometry, session.odometry)
    assert np.array_equal(back.end_pose, session.end_pose)
    assert len(back.scans) == len(session.scans)
    for a, b in zip(back.scans, session.scans, strict=True):
        assert (a.range_min, a.range_max, a.timestamp) == (b.range_min, b.range_max, b.timestamp)
        assert np.allclose(a.angles, b.angles, atol=1e-6)
        assert np.array_equal(np.isinf(a.ranges), np.isinf(b.ranges))
        assert np.allclose(a.ranges[np.isfinite(a.ranges)], b.ranges[np.isfinite(b.ranges)], rtol=1e-6)


def _rewrite(path, **changes) -> None:
    with np.load(path) as data:
        arrays = {key: data[key] for key in data.files}
    arrays.update(changes)
    with open(path, "wb") as f:
        np.savez(f, **arrays)


def _write_npy(path) -> None:
    with open(path, "wb") as f:
        np.save(f, np.zeros(3))


@pytest.mark.parametrize("damage, says", [
    (lambda p: p.write_bytes(p.read_bytes()[: len(p.read_bytes()) // 2]), "not a complete .npz"),
    (lambda p: p.write_bytes(b"\x89PNG garbage"), "not a complete .npz"),
    (lambda p: _write_npy(p), "not a complete .npz"),  # a bare array crashed the server's worker
    (lambda p: _rewrite(p, version=np.array(VERSION + 1)), f"version {VERSION + 1}"),
    (lambda p: _rewrite(p, format=np.array("something-else")), "not a homebot session"),
    (lambda p: _rewrite(p, offsets=np.array([0, 3, 2], np.int64)), "do not fit together"),
    (lambda p: _rewrite(p, poses=np.full((2, 3), np.nan)), "poses must be finite"),
    (lambda p: _rewrite(p, config=np.array("{not json")), "damaged session"),
])
def test_a_damaged_session_or_another_version_is_refused_by_name(tmp_path, damage, says):
    path = save_session(_session(np.random.default_rng(0), [3, 4]), tmp_path / f"home{SUFFIX}")
    damage(path)
    with pytest.raises(SessionError) as error:
        load_session(path)
    assert str(path) in str(error.value) and says in str(error.value)


def test_the_cli_refuses_a_bad_session_in_one_line(tmp_path, capsys):
    bad = tmp_path / f"bad{SUFFIX}"
    with zipfile.ZipFile(bad, "w") as z:
        z.writestr("poses.npy", b"nothing")
    assert main(["slam", "intel", "--resume", str(bad), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert str(bad) in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert main(["slam", "intel", "--save-session", "a/b", "--out", str(tmp_path / "out")]) == 2
    assert "session name" in capsys.readouterr().err


@pytest.fixture(scope="module")
def continued(tmp_path_factory):
    """The tour in two logs; the first mapped and saved, the second continued from its session."""
    root = tmp_path_factory.mktemp("session")
    rec = record_tour(load_world("flat"), root / "rec", seed=2, duration=TOUR_S)
    lines = rec.log.read_text().splitlines(keepends=True)
    lasers = [i for i, line in enumerate(lines) if line.startswith("ROBOTLASER1")]
    header = [line for line in lines[: lasers[0]] if line.startswith(("#", "PARAM"))]
    cut = lasers[len(lasers) // 2]  # the second log starts with the first one's last scan
    (root / "first.clf").write_text("".join(lines[: cut + 1]))
    (root / "second.clf").write_text("".join(header + lines[cut:]))
    config = root / "config.json"
    # submaps of 8 updates (a few metres here): at the default 20 the flat's 33 m tour is three
    # submaps, and the second half's updates are never far enough along the path from the first
    # half's for a loop search (the trajectories hold this module's bounds either way)
    config.write_text(json.dumps(RBPFConfig(particles=PARTICLES,
                                            loop_closure=LoopClosureConfig(submap_updates=8)).to_dict()))
    assert main(["slam", str(root / "first.clf"), "--config", str(config), "--out", str(root / "a"),
                 "--save-session", "flat"]) == 0
    session = root / "a" / f"flat{SUFFIX}"
    assert main(["slam", str(root / "second.clf"), "--resume", str(session), "--out", str(root / "b"),
                 "--save-session", "flat"]) == 0
    return rec, root, len(lasers) - len(lasers) // 2


def test_the_continued_trajectory_follows_the_ground_truth(continued):
    rec, root, scans = continued
    truth = Trajectory.load(rec.ground_truth).poses
    second = Trajectory.load(root / "b" / "trajectory.txt").poses
    assert len(second) == scans
    error = np.hypot(*(second[:, :2] - truth[-scans:, :2]).T)
    assert error.mean() < 0.05 and error.max() < 0.15, (error.mean(), error.max())
    first = Trajectory.load(root / "a" / "trajectory.txt").poses
    assert np.allclose(first[-1], second[0], atol=0.05)  # it went on from where the first ended


def test_one_map_of_the_whole_flat_with_no_doubled_walls(continued):
    rec, root, _ = continued
    truth = load_map(rec.map_yaml)
    walls = binary_dilation(truth.data > 0, iterations=WALL_CELLS)
    both, first = load_map(root / "b" / "map.yaml"), load_map(root / "a" / "map.yaml")
    iy, ix = np.nonzero(both.data > 0)
    cells = truth.world_to_cell(both.cell_to_world(np.stack([ix, iy], 1)))
    inside = np.all((cells >= 0) & (cells < walls.shape[::-1]), axis=1)
    on_walls = walls[cells[inside, 1], cells[inside, 0]].sum() / len(cells)
    assert on_walls > 0.9, on_walls
    assert (both.data != 0).sum() > 1.1 * (first.data != 0).sum()  # the second half mapped more


def test_loops_close_against_the_old_part_and_the_session_holds_both(continued):
    _, root, _ = continued
    first = load_session(root / "a" / f"flat{SUFFIX}")
    both = load_session(root / "b" / f"flat{SUFFIX}")
    n = len(first.scans)
    assert len(both.scans) > n
    # the old updates kept their scans and moved by no more than the loop corrections
    assert all(np.array_equal(a.ranges, b.ranges) for a, b in zip(first.scans, both.scans[:n], strict=False))
    assert np.hypot(*(both.poses[:n, :2] - first.poses[:, :2]).T).max() < 0.1
    resumed = json.loads((root / "b" / "stats.json").read_text())["resumed"]
    assert resumed["updates"] == n and resumed["loop_edges_to_it"] > 0


@pytest.mark.parametrize("part", ["a", "b"])
def test_a_saved_session_renders_the_map_written_beside_it(continued, part):
    """Resumed, a session goes on from the map the run wrote (the file a user looked at), cell by cell."""
    _, root, _ = continued
    written = load_map(root / part / "map.yaml")
    grid = load_session(root / part / f"flat{SUFFIX}").grid()
    assert grid.shape == written.shape and np.allclose(grid.origin, written.origin)
    cells = written.trinary()
    assert (cells == 100).sum() > 500 and (cells == 0).sum() > 10 * (cells == 100).sum()
    np.testing.assert_array_equal(grid.trinary(), cells)
