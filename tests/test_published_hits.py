"""The published map's hit sums (what a checkpoint keeps after a loop-closing solve) are those the
filter's own kernels would accumulate from the session's scans at the session's poses; a session
saved right after a solve renders the published map itself."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from app.worker.loop_closing import LoopClosing
from slam_core.estimator import Estimate
from slam_core.geometry import compose, relative, wrap_angle
from slam_core.pipelines.log_slam import best_updates
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


def test_a_closed_loop_reports_the_jump_of_the_pose_it_was_measured_at():
    """Twice round the room on odometry that turns 1 deg a metre too much, mapped by a filter that
    only follows the odometry: the live back end closes the loop. Each closure's jump is how far the
    published (corrected) pose moved at that step, measured ahead of the filter's last update
    (where the worker's pose is between updates): the correction turns, so the jump differs by the
    lever from the last update."""
    matcher = replace(RBPFConfig().matcher, min_matched=1.01, good_match=1.01, coarse_linear_cells=0,
                      lead_rotations=0)
    config = RBPFConfig(particles=1, linear_update=0.3, angular_update=0.3, matcher=matcher,
                        loop_closure=replace(RBPFConfig().loop_closure, submap_updates=6))
    slam = RBPFSlam(config, seed=2)
    loops = LoopClosing()
    loops.attach(slam, seeded=False)
    a = 2 * np.pi * np.arange(400) / 200  # 0.05 m a scan round an ellipse, 2.2 x 1.4 m
    truths = np.column_stack([0.5 + 2.2 * np.cos(a), 0.4 + 1.4 * np.sin(a), a + np.pi / 2])
    odometry = [truths[0]]
    for k in range(1, len(truths)):
        step = relative(truths[k - 1], truths[k])
        step[2] += np.radians(1) * np.hypot(step[0], step[1])
        odometry.append(compose(odometry[-1], step))
    jumps, levers = [], []
    updated_at = None
    for i, (truth, odom) in enumerate(zip(truths, odometry, strict=True)):
        scan = room_scan(truth)
        if slam.step(odom, scan):
            loops.updated(slam, scan)
            updated_at = odom
            loops.wait()  # a solve finishes at once, and is taken at every third scan
        if i % 3:
            continue
        pose = compose(slam.estimate().pose, relative(updated_at, odom))  # as the worker dead-reckons it
        before = loops.corrected(Estimate(pose=pose)).pose
        jump = loops.take(slam, pose)
        after = loops.corrected(Estimate(pose=pose)).pose
        if jump is not None:
            moved = after - before
            moved[2] = wrap_angle(moved[2])
            np.testing.assert_allclose(jump, moved, atol=1e-9)
            jumps.append(jump)
            levers.append(np.hypot(*(pose[:2] - best_updates(slam).poses[-1, :2])))
    assert loops.closures >= 1 and len(jumps) == loops.closures
    assert max(abs(j[2]) for j in jumps) > np.radians(3)  # the correction turned (seen: 6 deg)
    assert max(levers) > 0.03  # and was measured away from the last update (seen: 6-7 cm)
