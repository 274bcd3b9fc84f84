"""The live back end's solves over a whole log, warm-started and cold, side by side.

``homebot slam LOG --save-session`` maps the log once (its session holds each update's scan; the
best particle's own trajectory, ``particle_trajectory.txt``, gives the filter's pose at each
update). Then, in a fresh process per mode, the solves the live back end makes are replayed on
those poses: one every ``submap_updates`` updates, going on from the last solve's memory, a full
one each time the updates have doubled (:mod:`app.worker.live_back_end`'s schedule). Printed per
mode: solves, CPU seconds, Gauss-Newton steps, loop edges at the end; and how far the two modes'
last poses lie apart. ``cold`` starts every optimisation from the filter's poses, as before warm
starts.

    python benchmarks/live_solves.py [--logs mit-csail intel]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

MODES = ("warm", "cold")


def filter_poses(out: Path, session) -> np.ndarray:
    """The best particle's own pose at each update of ``session`` (from ``particle_trajectory.txt``)."""
    trajectory = np.loadtxt(out / "particle_trajectory.txt")
    stamps = np.array([scan.timestamp for scan in session.scans])
    rows = np.searchsorted(trajectory[:, 0], stamps)
    if not np.allclose(trajectory[rows, 0], stamps):
        raise SystemExit(f"{out}: the trajectory does not hold every update's scan")
    return trajectory[rows, 1:4]


def solves(out: Path, mode: str, poses_file: Path) -> None:
    """Child process: the live schedule of solves in ``mode``; print the figures and save the poses."""
    from app.worker.live_back_end import FULL_SOLVE_GROWTH
    from slam_core.graph import loop_closure, pose_graph
    from slam_core.session import load_session

    session = load_session(out / "bench.session.npz")
    poses = filter_poses(out, session)
    steps = []
    solve_step = pose_graph.spsolve
    pose_graph.spsolve = lambda *a: steps.append(1) or solve_step(*a)
    if mode == "cold":
        robust_solve = loop_closure.robust_solve
        loop_closure.robust_solve = lambda p, chain, edges, chi2, start=None: robust_solve(p, chain, edges,
                                                                                           chi2)
        loop_closure.LoopMemory.warm_start = lambda self, p: p.copy()
    c = session.config
    every = c.loop_closure.submap_updates
    memory, full_at, cpu, count = None, 0, 0.0, 0
    for n in range(every, len(poses) + 1, every):
        reuse = memory if n < FULL_SOLVE_GROWTH * full_at else None
        started = time.process_time()
        result, _ = loop_closure.close_loops(poses[:n], session.scans[:n], c.loop_closure, c.matcher,
                                             c.resolution, c.sensor, session.laser_mount, reuse,
                                             session.odometry[:n])
        cpu += time.process_time() - started
        count += 1
        memory = result.memory
        if reuse is None:
            full_at = n
    np.save(poses_file, result.poses)
    print(f"{mode}: {count} solves, {cpu:.1f} s CPU, {len(steps)} Gauss-Newton steps, "
          f"{result.loop_edges} loop edges")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--logs", nargs="+", default=["mit-csail", "intel"])
    parser.add_argument("--child", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child is not None:
        solves(Path(args.child[0]), args.child[1], Path(args.child[2]))
        return 0
    with tempfile.TemporaryDirectory(prefix="homebot-solves-") as tmp:
        for log in args.logs:
            out = Path(tmp) / log
            subprocess.run([sys.executable, "-m", "app.cli", "slam", log, "--out", str(out),
                            "--save-session", "bench"], check=True, stdout=subprocess.DEVNULL)
            print(f"{log}:")
            for mode in MODES:
                print("  " + subprocess.run([sys.executable, __file__, "--child", str(out), mode,
                                             str(out / f"{mode}.npy")],
                                            check=True, capture_output=True, text=True).stdout.strip())
            warm, cold = (np.load(out / f"{mode}.npy") for mode in MODES)
            print(f"  last solve's poses apart: {np.abs(warm[:, :2] - cold[:, :2]).max():.2e} m")
    return 0


if __name__ == "__main__":
    sys.exit(main())
