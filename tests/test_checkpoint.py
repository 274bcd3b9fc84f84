"""Durable worker state: lossless, atomic snapshots; bad ones set aside; the map's growth limit."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from app.core.config import Settings
from app.worker.checkpoint import (
    GENERATIONS_KEPT,
    VERSION,
    generations,
    load_checkpoint,
    quarantine_newest,
    save_pose,
    save_snapshot,
    session_path,
    snapshot_path,
    write_atomically,
)
from app.worker.estimators import Checkpoint, make_estimator, map_with_hits, odometry_calibration
from app.worker.map_limits import check_room, map_box
from app.worker.shared_map import MapTooLarge
from slam_core.rbpf.config import RBPFConfig
from slam_core.rbpf.filter import RBPFSlam
from slam_core.rbpf.hit_render import SparseHits
from slam_core.rbpf.laser_mount import LaserMount
from slam_core.rbpf.tiled_map import HIT_N
from slam_core.scan import Scan
from slam_core.session import MappingSession
from tests.synthetic_room import room_scan

CAPACITY = 2048 * 2048


@pytest.fixture(scope="module")
def mapped_room() -> RBPFSlam:
    """A filter that has mapped the synthetic room along a short drive."""
    slam = RBPFSlam(RBPFConfig(particles=4, linear_update=0.1, angular_update=0.1), seed=1)
    for i in range(12):
        pose = np.array([0.1 * i, 0.05 * i, 0.03 * i])
        slam.step(pose, room_scan(pose))
    return slam


def checkpoint_of(slam: RBPFSlam, pose=(1.0, 0.5, 0.2)) -> Checkpoint:
    grid, hits = map_with_hits(slam)
    return Checkpoint("mapping", np.array(pose), grid, True, None, (120, -7), hits)


def test_a_snapshot_restores_the_map_and_its_hit_statistics_exactly(tmp_path, mapped_room):
    saved = checkpoint_of(mapped_room)
    assert saved.hit_sums.values[:, HIT_N].sum() > 100  # the map really holds beam endpoints
    save_snapshot(tmp_path, saved)
    loaded = load_checkpoint(tmp_path, CAPACITY).checkpoint
    assert np.array_equal(loaded.grid.data, saved.grid.data)
    assert np.array_equal(loaded.grid.origin, saved.grid.origin)
    assert np.array_equal(loaded.hit_sums.dense(), saved.hit_sums.dense())
    assert np.array_equal(loaded.pose, saved.pose) and loaded.ticks == (120, -7)
    # ... and a filter resumed from it holds the very same map, endpoints included.
    resumed = RBPFSlam(RBPFConfig(particles=4), seed=2, initial_pose=loaded.pose)
    resumed.maps.seed_from_grid(loaded.grid, loaded.hit_sums.dense())
    grid, hits = map_with_hits(resumed)
    assert np.array_equal(grid.data, saved.grid.data) and np.array_equal(hits.dense(), saved.hit_sums.dense())


def test_the_pose_file_updates_the_pose_of_its_own_generation_only(tmp_path, mapped_room):
    generation = save_snapshot(tmp_path, checkpoint_of(mapped_room, pose=(1.0, 0.5, 0.2)))
    save_pose(tmp_path, checkpoint_of(mapped_room, pose=(1.5, 0.7, 0.4)), generation)
    assert np.allclose(load_checkpoint(tmp_path, CAPACITY).checkpoint.pose, (1.5, 0.7, 0.4))
    save_pose(tmp_path, checkpoint_of(mapped_room, pose=(9.0, 9.0, 0.0)), generation + 5)
    assert np.allclose(load_checkpoint(tmp_path, CAPACITY).checkpoint.pose, (1.0, 0.5, 0.2))


def test_an_interrupted_write_leaves_the_previous_file_whole(tmp_path):
    target = tmp_path / "state.bin"
    target.write_bytes(b"old and whole")

    def crash_halfway(f):
        f.write(b"new but")
        raise OSError("power cut")

    with pytest.raises(OSError, match="power cut"):
        write_atomically(target, crash_halfway)
    assert target.read_bytes() == b"old and whole"


def test_only_the_newest_generations_are_kept(tmp_path, mapped_room):
    for _ in range(GENERATIONS_KEPT + 2):
        last = save_snapshot(tmp_path, checkpoint_of(mapped_room))
    assert generations(tmp_path) == list(range(last - GENERATIONS_KEPT + 1, last + 1))


def test_a_corrupt_snapshot_is_set_aside_and_the_previous_one_used(tmp_path, mapped_room):
    save_snapshot(tmp_path, checkpoint_of(mapped_room, pose=(1.0, 0.5, 0.2)))
    newest = save_snapshot(tmp_path, checkpoint_of(mapped_room, pose=(2.0, 0.5, 0.2)))
    path = snapshot_path(tmp_path, newest)
    path.write_bytes(path.read_bytes()[:200])  # torn off
    restored = load_checkpoint(tmp_path, CAPACITY)
    assert np.allclose(restored.checkpoint.pose, (1.0, 0.5, 0.2)) and restored.generation == newest - 1
    [(aside, reason)] = restored.quarantined
    assert aside.exists() and ".bad-" in aside.name and "unreadable" in reason
    assert generations(tmp_path) == [newest - 1]  # never loaded again


def test_a_snapshot_with_an_absurd_map_or_pose_is_refused(tmp_path, mapped_room):
    good = save_snapshot(tmp_path, checkpoint_of(mapped_room))
    too_big = checkpoint_of(mapped_room)
    save_snapshot(tmp_path, too_big)
    restored = load_checkpoint(tmp_path, max_cells=too_big.grid.data.size - 1)
    assert restored.checkpoint is None or restored.generation == good
    assert "exceeds the limit" in restored.quarantined[0][1]
    state_only = tmp_path / "nan"
    generation = save_snapshot(state_only, Checkpoint("mapping", np.zeros(3)))
    data = dict(np.load(snapshot_path(state_only, generation)))
    state = json.loads(str(data["state"]))
    state["pose"] = [float("nan"), 0.0, 0.0]
    np.savez(snapshot_path(state_only, generation), state=np.array(json.dumps(state)))
    restored = load_checkpoint(state_only, CAPACITY)
    assert restored.checkpoint is None and "finite" in restored.quarantined[0][1]


def test_quarantine_newest_falls_back_a_generation(tmp_path, mapped_room):
    first = save_snapshot(tmp_path, checkpoint_of(mapped_room))
    second = save_snapshot(tmp_path, checkpoint_of(mapped_room))
    aside = quarantine_newest(tmp_path)
    assert aside.name.startswith(f"map-{second:06d}.bad-")
    assert load_checkpoint(tmp_path, CAPACITY).generation == first


def _session(updates: int) -> MappingSession:
    rng = np.random.default_rng(updates)
    scans = [Scan(np.linspace(-1.5, 1.5, 30), rng.uniform(0.2, 8.0, 30), 0.05, 10.0, float(k))
             for k in range(updates)]
    poses = rng.normal(size=(updates, 3))
    return MappingSession(RBPFConfig(particles=4), LaserMount(0.05, 0.0, 0.0), poses, poses + 0.2, scans,
                          poses[-1])


def test_the_mapping_session_is_kept_with_its_snapshot_and_set_aside_with_it(tmp_path, mapped_room):
    first = save_snapshot(tmp_path, replace(checkpoint_of(mapped_room), session=_session(5)))
    newest = save_snapshot(tmp_path, replace(checkpoint_of(mapped_room), session=_session(9)))
    restored = load_checkpoint(tmp_path, CAPACITY).checkpoint
    assert len(restored.session.scans) == 9
    assert np.array_equal(restored.session.poses, _session(9).poses)
    assert np.array_equal(restored.session.scans[8].ranges, _session(9).scans[8].ranges.astype(np.float32))
    session_path(tmp_path, newest).write_bytes(b"not a session")  # damaged: the generation is set aside
    restored = load_checkpoint(tmp_path, CAPACITY)
    assert restored.generation == first and len(restored.checkpoint.session.scans) == 5
    [(aside, reason)] = restored.quarantined
    assert "mapping session" in reason and aside.name.startswith(f"map-{newest:06d}.bad-")
    assert not session_path(tmp_path, newest).exists()
    assert len(list(tmp_path.glob(f"session-{newest:06d}.bad-*"))) == 1  # kept for inspection
    for _ in range(GENERATIONS_KEPT):
        last = save_snapshot(tmp_path, replace(checkpoint_of(mapped_room), session=_session(3)))
    kept = sorted(p.name for p in tmp_path.glob("session-??????.session.npz"))
    assert kept == [session_path(tmp_path, g).name for g in range(last - GENERATIONS_KEPT + 1, last + 1)]


def test_a_snapshot_whose_session_is_missing_is_refused_not_resumed_without_it(tmp_path, mapped_room):
    first = save_snapshot(tmp_path, replace(checkpoint_of(mapped_room, (1.0, 0.5, 0.2)), session=_session(5)))
    newest = save_snapshot(tmp_path, replace(checkpoint_of(mapped_room), session=_session(9)))
    session_path(tmp_path, newest).unlink()
    restored = load_checkpoint(tmp_path, CAPACITY)
    assert restored.generation == first and len(restored.checkpoint.session.scans) == 5
    assert "session file is missing" in restored.quarantined[0][1]


def _rewrite_state(path, change) -> None:
    """Rewrite a snapshot's state (``change(state)`` edits it in place), its arrays kept."""
    data = dict(np.load(path))
    state = json.loads(str(data["state"]))
    change(state)
    np.savez(path, **{**data, "state": np.array(json.dumps(state))})


def _with_dense_hits(path) -> None:
    """The snapshot at ``path`` with its hit sums dense, as formats 1 and 2 kept them."""
    data = dict(np.load(path))
    hits = SparseHits(data["origin"], data["log_odds"].shape, data.pop("hit_cells"), data.pop("hit_values"))
    data["hit_sums"] = hits.dense()
    np.savez_compressed(path, **data)


@pytest.mark.parametrize("version", [1, 2])
def test_a_snapshot_of_an_older_format_still_loads_with_its_map_and_hit_sums(tmp_path, mapped_room, version):
    """Format 1 (before versions): the filter's own map and pose, no session; both dense hit sums."""
    saved = checkpoint_of(mapped_room, pose=(1.0, 0.5, 0.2))
    generation = save_snapshot(tmp_path, saved)
    path = snapshot_path(tmp_path, generation)
    _with_dense_hits(path)
    if version == 1:
        _rewrite_state(path, lambda state: (state.pop("version"), state.pop("session")))
    else:
        _rewrite_state(path, lambda state: state.update(version=2))
    restored = load_checkpoint(tmp_path, CAPACITY)
    assert restored.generation == generation and not restored.quarantined
    loaded = restored.checkpoint
    assert np.array_equal(loaded.grid.data, saved.grid.data)
    assert np.array_equal(loaded.hit_sums.dense(), saved.hit_sums.dense())
    assert np.allclose(loaded.pose, (1.0, 0.5, 0.2)) and loaded.session is None


def test_a_snapshot_of_a_newer_format_is_refused_with_its_format_named(tmp_path, mapped_room):
    first = save_snapshot(tmp_path, checkpoint_of(mapped_room, pose=(1.0, 0.5, 0.2)))
    newest = save_snapshot(tmp_path, checkpoint_of(mapped_room, pose=(2.0, 0.5, 0.2)))
    _rewrite_state(snapshot_path(tmp_path, newest), lambda state: state.update(version=VERSION + 1))
    restored = load_checkpoint(tmp_path, CAPACITY)
    assert restored.generation == first and np.allclose(restored.checkpoint.pose, (1.0, 0.5, 0.2))
    [(aside, reason)] = restored.quarantined
    assert f"checkpoint format {VERSION + 1}" in reason and aside.exists()


def test_hit_sums_of_cells_outside_the_map_are_refused(tmp_path, mapped_room):
    first = save_snapshot(tmp_path, checkpoint_of(mapped_room, pose=(1.0, 0.5, 0.2)))
    newest = save_snapshot(tmp_path, checkpoint_of(mapped_room, pose=(2.0, 0.5, 0.2)))
    path = snapshot_path(tmp_path, newest)
    data = dict(np.load(path))
    data["hit_cells"][-1] = data["log_odds"].size  # one past the last cell
    np.savez(path, **data)
    restored = load_checkpoint(tmp_path, CAPACITY)
    assert restored.generation == first and "outside the map" in restored.quarantined[0][1]


@pytest.mark.parametrize("x", [500.0, -5.8e16, float("inf")])
def test_a_pose_that_would_grow_the_map_past_its_limit_is_refused_before_any_allocation(mapped_room, x):
    box = map_box(mapped_room)
    tables_before = mapped_room.maps.tables.shape
    with pytest.raises(MapTooLarge, match=r"limit|finite"):
        check_room(box, (x, 0.0, 0.0), 8.0, 0.05, CAPACITY)
    assert mapped_room.maps.tables.shape == tables_before
    check_room(box, (2.0, 1.0, 0.0), 8.0, 0.05, CAPACITY)  # in the home: fine


def test_hit_sums_of_another_grid_are_refused_when_saving(tmp_path, mapped_room):
    saved = checkpoint_of(mapped_room)
    hits = saved.hit_sums
    moved = SparseHits(hits.origin + 0.05, saved.grid.shape, hits.cells, hits.values)  # a cell off
    with pytest.raises(ValueError, match="hit sums of a"):
        save_snapshot(tmp_path, replace(saved, hit_sums=moved))
    assert generations(tmp_path) == []


@pytest.mark.parametrize("mode", ["mapping", "localization"])
def test_a_restarted_estimator_goes_on_from_the_odometry_errors_of_its_snapshot(tmp_path, mapped_room, mode):
    """A power cut loses nothing the estimator learned of the odometry: the snapshot keeps the errors,
    and the filter (mapping) or the tracker (localization) built from it corrects as before."""
    rng = np.random.default_rng(5)
    learned = RBPFSlam(RBPFConfig(particles=4), seed=1).calibration
    for _ in range(80):  # an odometry that drifts 0.03 rad and over-reports 4 % a metre
        motion = np.array([rng.uniform(-0.2, 0.2), rng.uniform(0.1, 0.5), rng.uniform(-0.2, 0.2)])
        learned.observe(motion, np.array([-0.04 * motion[1], 0.0, 0.03 * motion[1] + rng.normal(0, 0.002)]))
    settings, saved = Settings(data_dir=str(tmp_path)), replace(checkpoint_of(mapped_room), mode=mode)
    generation = save_snapshot(tmp_path, replace(saved, odometry_errors=learned.measured()))
    save_pose(tmp_path, replace(saved, pose=np.array([1.5, 0.5, 0.3])), generation)  # the robot drove on
    loaded = load_checkpoint(tmp_path, CAPACITY).checkpoint
    np.testing.assert_array_equal(loaded.pose, [1.5, 0.5, 0.3])
    np.testing.assert_array_equal(loaded.odometry_errors.rows, learned.measured().rows)
    calibration = odometry_calibration(make_estimator(mode, settings, loaded))
    assert calibration.calibrated()
    np.testing.assert_allclose(calibration.bias(), learned.bias(), rtol=0, atol=1e-12)
    assert abs(calibration.bias()[0] - 0.03) < 0.005 and abs(calibration.bias()[2] + 0.04) < 0.005
    # a snapshot without them (an older homebot's) resumes with a calibration that starts empty
    save_snapshot(tmp_path, saved)
    loaded = load_checkpoint(tmp_path, CAPACITY).checkpoint
    assert loaded.odometry_errors is None
    assert not odometry_calibration(make_estimator(mode, settings, loaded)).calibrated()
