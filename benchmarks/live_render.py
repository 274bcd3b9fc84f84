"""The live back end's map after each solve: rendered from scratch (before) or by moved submaps (after).

``homebot slam LOG --save-session`` maps the log once; the live schedule of solves
(:mod:`benchmarks.live_solves`: one per ``submap_updates`` updates, warm-started, a full one when the
updates have doubled) is replayed on the best particle's poses and each solve's optimised poses are
kept. Then, in a fresh process per mode, the map and hit sums of every solve are rendered:

- ``before``: every update traced into a fresh grid, clamped after every beam
  (``OccupancyGrid.integrate``), and dense ``(ny, nx, 3)`` hit sums (``hit_sums_on``);
- ``after``: :class:`slam_core.count_map.CountMap` (only submaps whose poses moved traced again,
  clamped after the sum) and its sparse hit sums.

Printed per mode: CPU seconds (all solves, and per solve), submaps traced, peak RSS; then how many
known cells of the two rules' maps differ, on the session's poses (``homebot slam``'s final map).

    python benchmarks/live_render.py [--logs mit-csail intel | LOG FILE ...] [--work DIR]
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from live_solves import filter_poses

MODES = ("before", "after")


def solve_poses(out: Path) -> None:
    """Child: the live schedule's solves; each one's optimised poses to ``solves.npz``."""
    from app.worker.live_back_end import FULL_SOLVE_GROWTH
    from slam_core.graph.loop_closure import close_loops
    from slam_core.session import load_session

    session = load_session(out / "bench.session.npz")
    poses, c = filter_poses(out, session), session.config
    every, memory, full_at, solved = c.loop_closure.submap_updates, None, 0, {}
    for n in range(every, len(poses) + 1, every):
        reuse = memory if n < FULL_SOLVE_GROWTH * full_at else None
        result, _ = close_loops(poses[:n], session.scans[:n], c.loop_closure, c.matcher, c.resolution,
                                c.sensor, session.laser_mount, reuse, session.odometry[:n])
        memory, full_at = result.memory, full_at if reuse is not None else n
        solved[f"s{len(solved):04d}"] = result.poses
    np.savez(out / "solves.npz", **solved)


def render(out: Path, mode: str) -> None:
    """Child: every solve's map and hit sums in ``mode``; print the figures."""
    from slam_core.count_map import CountMap
    from slam_core.occupancy_grid import OccupancyGrid
    from slam_core.rbpf.hit_render import hit_sums_on
    from slam_core.session import load_session

    session = load_session(out / "bench.session.npz")
    c, mount = session.config, session.laser_mount
    with np.load(out / "solves.npz") as z:
        solves = [z[k] for k in sorted(z.files)]
    counts = CountMap(c.resolution, c.sensor, c.loop_closure.submap_updates)
    # the filter's map as the layout (as live): the grid is sized once
    sized = CountMap(c.resolution, c.sensor, len(session.scans))
    sized.update(mount.laser_poses(session.poses), session.scans)
    layout = sized.grid()
    del sized
    cpu, traced = np.zeros(3), 0  # map, grid, hit sums
    for poses in solves:
        scans = session.scans[:len(poses)]
        laser = mount.laser_poses(poses)
        started = time.process_time()
        if mode == "before":
            grid = OccupancyGrid(c.resolution, layout.origin, layout.shape, model=c.sensor)
            for pose, scan in zip(laser, scans, strict=True):
                grid.integrate(scan, pose)
        else:
            traced += counts.update(laser, scans)
        gridded = time.process_time()
        if mode == "after":
            grid = counts.grid(layout.extent())
        hits = time.process_time()
        if mode == "before":
            hit_sums_on(grid, laser, scans, c.sensor)
        else:
            counts.hit_sums(grid)
        cpu += np.diff([started, gridded, hits, time.process_time()])
    submaps = sum(-(-len(p) // c.loop_closure.submap_updates) for p in solves)
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{mode}: {len(solves)} solves, {cpu.sum():.2f} s CPU, {1000 * cpu.sum() / len(solves):.0f} ms per "
          f"solve (map {1000 * cpu[0] / len(solves):.0f}, grid {1000 * cpu[1] / len(solves):.0f}, hit sums "
          f"{1000 * cpu[2] / len(solves):.0f}), "
          + (f"{traced} of {submaps} submaps traced, " if mode == "after" else "")
          + f"peak RSS {rss:.0f} MB")


def differing(out: Path) -> None:
    """Child: known cells of the final map (the session's poses) per rule, and how many differ."""
    from slam_core.count_map import CountMap
    from slam_core.occupancy_grid import OccupancyGrid
    from slam_core.session import load_session

    session = load_session(out / "bench.session.npz")
    c, laser = session.config, session.laser_mount.laser_poses(session.poses)
    counts = CountMap(c.resolution, c.sensor, c.loop_closure.submap_updates)
    counts.update(laser, session.scans)
    after = counts.grid()
    before = OccupancyGrid(c.resolution, after.origin, after.shape, model=c.sensor)
    for pose, scan in zip(laser, session.scans, strict=True):
        before.integrate(scan, pose)
    if before.shape != after.shape:
        raise SystemExit("the two maps differ in extent")
    a, b = after.trinary(), before.trinary()
    known = (a >= 0) | (b >= 0)
    print(f"final map: {known.sum()} known cells, {np.sum(known & (a != b))} differ "
          f"({100 * np.mean(a[known] != b[known]):.2f} %): "
          f"occupied {np.sum(b == 100)} -> {np.sum(a == 100)}, "
          f"free {np.sum(b == 0)} -> {np.sum(a == 0)}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--logs", nargs="+", default=["mit-csail", "intel"])
    parser.add_argument("--work", type=Path, help="keep the sessions and solves here (reused when present)")
    parser.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child is not None:
        out, mode = Path(args.child[0]), args.child[1]
        {"solves": solve_poses, "differ": differing}.get(mode, lambda o: render(o, mode))(out)
        return 0

    def child(out: Path, mode: str) -> str:
        return subprocess.run([sys.executable, __file__, "--child", str(out), mode], check=True,
                              capture_output=True, text=True).stdout.strip()

    with tempfile.TemporaryDirectory(prefix="homebot-render-") as tmp:
        for log in args.logs:
            out = (args.work or Path(tmp)) / Path(log).name  # a shipped log's name, or a log file
            if not (out / "solves.npz").exists():
                subprocess.run([sys.executable, "-m", "app.cli", "slam", log, "--out", str(out),
                                "--save-session", "bench"], check=True, stdout=subprocess.DEVNULL)
                child(out, "solves")
            print(f"{log}:")
            for mode in (*MODES, "differ"):
                print("  " + child(out, mode))
    return 0


if __name__ == "__main__":
    sys.exit(main())
