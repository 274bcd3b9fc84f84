"""What checkpoints in the optimised map frame cost, on a home-sized and a building-sized session.

A session is made from a log as the filter would take its updates (every ``linear_update`` m or
``angular_update`` rad of odometry), at the odometry's poses (the costs depend on the beams and
the map's size, not on the poses' accuracy); the flat's simulated tour is recorded first with
``homebot sim record``. Then, median wall and CPU seconds over ``--repeat`` runs:

- in the back end's thread, per solve: rendering the map from the poses, every submap traced
  (:class:`slam_core.count_map.CountMap`; a live solve traces only those that moved) and its
  sparse hit sums;
- in the worker's thread, per snapshot: the published map's hit sums (the solve's, moved onto the
  grid, and one submap of updates since added) and writing the snapshot, with the session beside it
  and without;
- at a restart: loading the newest snapshot with its session.

    python benchmarks/checkpoint_cost.py [--logs flat mit-csail] [--repeat 5]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from app.worker.checkpoint import load_checkpoint, save_snapshot, session_path, snapshot_path
from app.worker.estimators import Checkpoint
from slam_core.count_map import CountMap
from slam_core.datasets import resolve_log
from slam_core.geometry import relative, wrap_angle
from slam_core.io.carmen import laser_mount_of, laser_records
from slam_core.rbpf import RBPFConfig
from slam_core.rbpf.hit_render import sparse_hit_sums
from slam_core.rbpf.laser_mount import LaserMount
from slam_core.session import MappingSession

WORLDS = ("flat", "house")
CAPACITY = 8192 * 8192


def session_of(log: str, work: Path) -> MappingSession:
    """The updates of ``log`` at its odometry's poses."""
    if log in WORLDS:
        out = work / log
        subprocess.run([sys.executable, "-m", "app.cli", "sim", "record", log, "--out", str(out)], check=True,
                       stdout=subprocess.DEVNULL)
        path = out / "sim.clf"
    else:
        path = resolve_log(log)
    config = RBPFConfig()
    logged = laser_mount_of(path)
    mount = LaserMount(0.0, 0.0, 0.0) if logged is None else LaserMount.of(logged)
    odometry, scans, last = [], [], None
    for record in laser_records(path):
        if last is not None:
            step = relative(last, record.odom)
            turn = abs(wrap_angle(step[2]))
            if np.hypot(*step[:2]) < config.linear_update and turn < config.angular_update:
                continue
        last = record.odom
        odometry.append(record.odom)
        scans.append(record.scan)
    poses = np.array(odometry)
    return MappingSession(config, mount, poses, poses, scans, poses[-1])


def timed(runs: dict, name: str, function, *args):
    wall, cpu = time.perf_counter(), time.process_time()
    result = function(*args)
    runs.setdefault(name, []).append((time.perf_counter() - wall, time.process_time() - cpu))
    return result


def render(session: MappingSession) -> CountMap:
    c = session.config
    counts = CountMap(c.resolution, c.sensor, c.loop_closure.submap_updates)
    counts.update(session.laser_mount.laser_poses(session.poses), session.scans)
    return counts


def published_hits(session: MappingSession, counts: CountMap, first: int):
    """The solve's hit sums with those of ``session``'s updates from ``first`` on added (as
    ``LoopClosing.published_hits``)."""
    grid = counts.grid()
    laser = session.laser_mount.laser_poses(session.poses[first:])
    solved = counts.hit_sums(grid)
    since = sparse_hit_sums(grid, laser, session.scans[first:], session.config.sensor)
    return solved.plus(since)


def measure(session: MappingSession, directory: Path, repeat: int) -> dict:
    c = session.config
    last_submap = len(session.scans) - c.loop_closure.submap_updates
    runs: dict = {}
    for k in range(repeat):
        counts = timed(runs, "back end, per solve: trace every submap", render, session)
        grid = timed(runs, "back end, per solve: the grid", counts.grid)
        timed(runs, "back end, per solve: its hit sums", counts.hit_sums, grid)
        hits = timed(runs, f"worker, per snapshot: hit sums (+{c.loop_closure.submap_updates} updates)",
                     published_hits, session, counts, last_submap)
        checkpoint = Checkpoint("mapping", session.end_pose, grid, True, None, (0, 0), hits)
        timed(runs, "worker, per snapshot: write, no session",
              save_snapshot, directory / f"without-{k}", checkpoint)
        generation = timed(runs, "worker, per snapshot: write, with session",
                           save_snapshot, directory / f"with-{k}", replace(checkpoint, session=session))
        timed(runs, "restart: load the snapshot and its session",
              load_checkpoint, directory / f"with-{k}", CAPACITY)
    sizes = (snapshot_path(directory / "with-0", generation).stat().st_size,
             session_path(directory / "with-0", generation).stat().st_size)
    return {"runs": runs, "grid": grid.shape, "sizes": sizes}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--logs", nargs="+", default=["flat", "mit-csail"])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="homebot-checkpoint-cost-") as tmp:
        for log in args.logs:
            session = session_of(log, Path(tmp))
            found = measure(session, Path(tmp) / f"{log}-out", args.repeat)
            beams = sum(len(s) for s in session.scans)
            ny, nx = found["grid"]
            print(f"{log}: {len(session.scans)} updates, {beams} beams, map {nx}x{ny} cells; snapshot "
                  f"{found['sizes'][0] / 1e6:.2f} MB, session {found['sizes'][1] / 1e6:.2f} MB; "
                  f"median of {args.repeat}:")
            for name, values in found["runs"].items():
                wall = statistics.median(v[0] for v in values)
                cpu = statistics.median(v[1] for v in values)
                print(f"  {name:52s} {wall:7.3f} s wall {cpu:7.3f} s CPU")
    return 0


if __name__ == "__main__":
    sys.exit(main())
