"""The live back end's solves trace again only the submaps whose poses moved, and the newest."""

from __future__ import annotations

import weakref

import numpy as np

from app.worker import live_back_end
from app.worker.live_back_end import LiveBackEnd
from app.worker.loop_closing import LoopClosing
from slam_core.count_map import CountMap
from slam_core.rbpf.config import RBPFConfig
from slam_core.rbpf.filter import RBPFSlam
from tests.synthetic_room import room_scan


def test_solves_without_moved_poses_trace_the_newest_submap_only_and_equal_a_full_render():
    slam = RBPFSlam(RBPFConfig(particles=1, linear_update=0.1, angular_update=0.1), seed=4)
    back_end = LiveBackEnd.attached_to(slam)
    results = []
    for i in range(64):  # one particle: its path is never rewritten; an update per step, no loop
        pose = np.array([-1.2 + 0.03 * i, -0.3 + 0.01 * i, 0.11 * i])
        scan = room_scan(pose)
        if slam.step(pose, scan):
            back_end.updated(slam, scan)
            back_end.wait()
            result = back_end.take()
            if result is not None:
                results.append(result)
    size = slam.config.loop_closure.submap_updates
    assert len(results) >= 2 and all(r.loop_edges == 0 for r in results)
    assert [r.traced for r in results] == [1] * len(results)
    assert [len(r.poses) for r in results] == [size * (k + 1) for k in range(len(results))]
    last = results[-1]
    scratch = CountMap(slam.config.resolution, slam.config.sensor, size)
    scratch.update(slam.mount.laser_poses(last.poses), back_end.scans[:len(last.poses)])
    full = scratch.grid(last.grid.extent())
    assert full.shape == last.grid.shape and np.count_nonzero(full.data) > 1000
    np.testing.assert_array_equal(full.data, last.grid.data)


def test_a_failed_solve_is_reported_once_and_the_next_submap_solves_again(monkeypatch, capsys):
    slam = RBPFSlam(RBPFConfig(particles=1, linear_update=0.1, angular_update=0.1), seed=4)
    back_end = LiveBackEnd.attached_to(slam)
    real, calls = live_back_end.close_loops, []

    def first_fails(*args, **kwargs):  # a fault injected into the first solve only
        calls.append(len(args[0]))
        if len(calls) == 1:
            raise FloatingPointError("injected")
        return real(*args, **kwargs)

    monkeypatch.setattr(live_back_end, "close_loops", first_fails)
    failures, results = [], []
    for i in range(64):
        pose = np.array([-1.2 + 0.03 * i, -0.3 + 0.01 * i, 0.11 * i])
        scan = room_scan(pose)
        if slam.step(pose, scan):
            back_end.updated(slam, scan)
            back_end.wait()
            failures.append(back_end.failure())
            results.append(back_end.take())
    reported = [f for f in failures if f is not None]
    assert reported == ["FloatingPointError: injected"]
    assert "FloatingPointError" in capsys.readouterr().err  # the traceback is in the worker's log
    after = [r for r, f in zip(results, failures, strict=True) if r is not None]
    assert len(calls) >= 3 and results[failures.index(reported[0])] is None
    assert [len(r.poses) for r in after] == calls[1:]  # every later solve finished, on all updates so far


def test_the_worker_lets_the_published_map_go_before_it_draws_a_solves_map(monkeypatch):
    """A solve's grid is drawn when the worker takes it, after the published map it replaces is let
    go: the worker holds one whole map at a time, not two (freiburg-campus: 93 MB a grid)."""
    slam = RBPFSlam(RBPFConfig(particles=1, linear_update=0.1, angular_update=0.1), seed=4)
    loops = LoopClosing()
    loops.attach(slam, seeded=False)
    published, alive_at_draw, real_draw = [], [], CountMap.draw

    def draw(counts, grid):
        alive_at_draw.append([ref() is not None for ref in published])
        assert not grid.data.any()  # the solve left it blank
        real_draw(counts, grid)

    monkeypatch.setattr(CountMap, "draw", draw)
    for i in range(84):
        pose = np.array([-1.2 + 0.03 * i, -0.3 + 0.01 * i, 0.11 * i])
        scan = room_scan(pose)
        if slam.step(pose, scan):
            loops.updated(slam, scan)
            loops.back_end.wait()
            loops.take(slam, pose)
            grid = loops.published_grid
            if grid is not None and (not published or published[-1]() is not grid):
                published.append(weakref.ref(grid))
            del grid
    assert len(published) >= 3 and len(alive_at_draw) == len(published)
    assert alive_at_draw[0] == [] and all(not any(alive) for alive in alive_at_draw[1:])
    assert np.count_nonzero(loops.published_grid.data) > 1000
