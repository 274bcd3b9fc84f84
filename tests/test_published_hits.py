"""The published map's hit sums (what a checkpoint keeps after a loop-closing solve) are those the
filter's own kernels would accumulate from the session's scans at the session's poses; a session
saved right after a solve renders the published map itself."""

from __future__ import annotations

import numpy as np

from app.worker.loop_closing import LoopClosing
from slam_core.rbpf.config import RBPFConfig
from slam_core.rbpf.filter import RBPFSlam
from slam_core.rbpf.tiled_map import HIT_N, TiledMaps
from tests.synthetic_room import room_scan


def mapping(scans: int, step: tuple[float, float]):
    """A filter with the live back end driven through the synthetic room, ``step`` (m) a scan; yields
    it after each scan, every solve taken right after the update that started it."""
    slam = RBPFSlam(RBPFConfig(particles=3, linear_update=0.1, angular_update=0.1), seed=4)
    loops = LoopClosing()
    loops.attach(slam, seeded=False)
    for i in range(scans):
        pose = np.array([-1.0 + step[0] * i, -0.5 + step[1] * i, 0.08 * i])
        scan = room_scan(pose)
        if slam.step(pose, scan):
            loops.updated(slam, scan)
        loops.wait()
        loops.take(slam, slam.estimate().pose)
        yield slam, loops


def test_the_published_hit_sums_match_the_session_drawn_by_the_filters_kernels():
    *_, (slam, loops) = mapping(32, (0.09, 0.05))  # a solve after 20 updates, 12 more drawn in after it
    assert loops.solved is not None and len(loops.solved.poses) < len(loops.back_end.scans)
    session = loops.session(slam, slam.estimate().pose)
    hits = loops.published_hits(session).dense()
    grid = loops.published_grid
    maps = TiledMaps(1, grid.resolution, grid.model)
    for laser, scan in zip(session.laser_mount.laser_poses(session.poses), session.scans, strict=True):
        maps.integrate(laser[None], scan)
    expected, origin = maps.hit_sums(0), maps.to_grid(0).origin
    x, y = np.round((origin - grid.origin) / grid.resolution).astype(int)
    ny, nx = expected.shape[:2]
    assert x >= 0 and y >= 0 and hits[..., HIT_N].sum() == expected[..., HIT_N].sum() > 3000
    np.testing.assert_array_equal(hits[y:y + ny, x:x + nx, HIT_N], expected[..., HIT_N])
    np.testing.assert_allclose(hits[y:y + ny, x:x + nx], expected, atol=1e-4)


def test_a_session_saved_right_after_a_solve_renders_the_published_map():
    """Saved and resumed, a session must give back the map people saw: the solve's (clamped after
    the sum), not one integrated beam by beam, which differs wherever a cell was seen both ways."""
    compared = 0
    for slam, loops in mapping(45, (0.06, 0.04)):
        if loops.solved is not None and len(loops.solved.poses) == len(loops.back_end.scans):
            grid, published = loops.session(slam, slam.estimate().pose).grid(), loops.published_grid
            assert grid.shape == published.shape and np.array_equal(grid.origin, published.origin)
            assert np.count_nonzero(published.data) > 5000
            np.testing.assert_array_equal(grid.data, published.data)
            compared += 1
    assert compared > 0
