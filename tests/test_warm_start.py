"""The first map while numba compiles: the preview draws at the odometry's pose, the warm-up runs aside."""

from __future__ import annotations

import time
from types import SimpleNamespace

import numpy as np
import pytest

from app.worker.pairing import Pair
from app.worker.warm_start import KEEP_LINEAR_M, BackgroundWarmUp, PreviewMap
from slam_core.rbpf.laser_mount import LaserMount
from tests.synthetic_room import ROOM, room_scan

RESOLUTION = 0.05


def wall_distance(points: np.ndarray) -> np.ndarray:
    """Distance of each point to the nearest wall segment of the synthetic room."""
    p = points[:, None, :]
    a, b = ROOM[None, :, :2], ROOM[None, :, 2:]
    ab = b - a
    t = np.clip(np.sum((p - a) * ab, axis=2) / np.sum(ab * ab, axis=2), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[..., None] * ab), axis=2).min(axis=1)


def drive(preview: PreviewMap, steps: np.ndarray) -> list[Pair]:
    """Drive along x from (-1, 0) by ``steps`` (m), the odometry exact; the pairs fed to the preview."""
    pairs = []
    for i, x in enumerate(-1.0 + np.cumsum(steps)):
        pose = np.array([x, 0.0, 0.1])
        pair = Pair(SimpleNamespace(pose=pose, ticks=None), room_scan(pose, n=360), i)
        preview.add(pair, pose)
        pairs.append(pair)
    return pairs


def test_the_preview_draws_the_room_where_it_is_and_keeps_the_scans_that_moved():
    preview = PreviewMap(RESOLUTION, LaserMount.of(None), capacity_cells=4_000_000)
    steps = np.r_[0.0, np.full(20, 0.012), np.full(10, 0.1)]  # off the 5 cm boundary
    pairs = drive(preview, steps)

    grid = preview.grid
    occupied = np.argwhere(grid.data > 0)[:, ::-1]
    centres = grid.origin + (occupied + 0.5) * RESOLUTION
    assert len(centres) > 300  # the room's walls, seen from the path
    assert np.mean(wall_distance(centres) <= RESOLUTION) >= 0.95  # drawn where the walls are

    expected, last = [], None
    for pair in pairs:
        x = pair.odometry.pose[0]
        if last is None or abs(x - last) >= KEEP_LINEAR_M:
            expected.append(pair.scan_seq)
            last = x
    assert [p.scan_seq for p in preview.pairs] == expected
    assert 10 < len(expected) < len(pairs)  # the slow creep was thinned, every long step kept


def test_the_preview_stops_drawing_at_the_map_limit_but_keeps_the_scans():
    preview = PreviewMap(RESOLUTION, LaserMount.of(None), capacity_cells=100 * 100)
    drive(preview, np.r_[0.0, np.full(5, 0.1)])
    assert preview.grid.data.size == 0  # a 5 m x 5 m limit: the room's scans do not fit
    assert len(preview.pairs) == 6


def test_the_background_warm_up_reports_its_stages_and_ends():
    seen = []
    warming = BackgroundWarmUp(SimpleNamespace(resolution=RESOLUTION), "localization",
                               lambda done, total, stage: seen.append((done, total, stage)))
    deadline = time.monotonic() + 600
    while not warming.done():
        assert time.monotonic() < deadline, "the warm-up never ended"
        time.sleep(0.05)
    assert seen == [(0, 1, "re-localization")]


def test_the_background_warm_up_hands_its_error_to_the_loop():
    warming = BackgroundWarmUp(SimpleNamespace(resolution=-1.0), "ekf")
    deadline = time.monotonic() + 60
    with pytest.raises(ValueError, match="resolution"):
        while not warming.done():
            assert time.monotonic() < deadline, "the warm-up never ended"
            time.sleep(0.05)
