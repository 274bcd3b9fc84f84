"""Loading a saved mapping session: how long until the server can map on in it.

For each log, ``homebot slam LOG --save-session`` writes a session (a simulated world's tour is
recorded first with ``homebot sim record``); then a fresh process loads it the way
``homebot serve --resume`` and ``POST api/sessions/NAME/resume`` do, and prints per stage the
wall and CPU seconds: reading the file (:func:`slam_core.session.load_session`), rendering
its map from the updates (:meth:`~slam_core.session.MappingSession.grid`), and seeding a
particle filter with that map; then the whole, the peak RSS and the session's size.

    python benchmarks/session_load.py [--logs flat house mit-csail intel] [--repeat 3]
"""

from __future__ import annotations

import argparse
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

WORLDS = ("flat", "house")


def timed(stage: str, into: dict, function, *args):
    wall, cpu = time.perf_counter(), time.process_time()
    result = function(*args)
    into[stage] = (time.perf_counter() - wall, time.process_time() - cpu)
    return result


def load(path: Path) -> None:
    """Child process: load the session at ``path`` as the server does; print the stages."""
    from slam_core.rbpf import RBPFSlam
    from slam_core.session import load_session

    stages: dict[str, tuple[float, float]] = {}
    session = timed("read the file", stages, load_session, path)
    grid = timed("render the map", stages, session.grid)

    def seed():
        slam = RBPFSlam(session.config, seed=0, initial_pose=session.end_pose,
                        laser_mount=session.laser_mount)
        slam.maps.seed_from_grid(grid)
        return slam

    timed("seed the filter", stages, seed)
    for stage, (wall, cpu) in stages.items():
        print(f"STAGE {stage}|{wall:.4f}|{cpu:.4f}")
    print(f"TOTAL|{sum(w for w, _ in stages.values()):.4f}|{sum(c for _, c in stages.values()):.4f}")
    print(f"SIZE|{len(session.scans)}|{sum(len(s) for s in session.scans)}|{grid.shape[0]}x{grid.shape[1]}")
    print(f"RSS|{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f}")


def homebot(*args: str) -> None:
    subprocess.run([sys.executable, "-m", "app.cli", *args], check=True, stdout=subprocess.DEVNULL)


def session_of(log: str, work: Path) -> Path:
    out = work / log
    if log in WORLDS:
        homebot("sim", "record", log, "--out", str(out / "sim"))
        log_path = str(out / "sim" / "sim.clf")
    else:
        log_path = log
    homebot("slam", log_path, "--out", str(out), "--save-session", "bench")
    return out / "bench.session.npz"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--logs", nargs="+", default=["flat", "house", "mit-csail", "intel"])
    parser.add_argument("--repeat", type=int, default=3, help="loads per session (fresh processes)")
    parser.add_argument("--child", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child is not None:
        load(args.child)
        return 0
    with tempfile.TemporaryDirectory(prefix="homebot-sessions-") as tmp:
        for log in args.logs:
            path = session_of(log, Path(tmp))
            runs = []
            for _ in range(args.repeat):
                text = subprocess.run([sys.executable, __file__, "--child", str(path)], check=True,
                                      capture_output=True, text=True).stdout
                runs.append([line.split("|") for line in text.splitlines()])
            updates, beams, shape = next(r for r in runs[0] if r[0] == "SIZE")[1:]
            print(f"{log}: {updates} updates, {beams} beams, map {shape} cells, "
                  f"file {path.stat().st_size / 1e6:.1f} MB; median of {args.repeat} fresh processes:")
            for row in runs[0]:
                if row[0].startswith("STAGE") or row[0] == "TOTAL":
                    name = row[0].removeprefix("STAGE ").lower()
                    same = [r for run in runs for r in run if r[0] == row[0]]
                    wall = statistics.median(float(r[1]) for r in same)
                    cpu = statistics.median(float(r[2]) for r in same)
                    print(f"  {name:18s} {wall:7.3f} s wall {cpu:7.3f} s CPU")
            rss = statistics.median(float(next(r for r in run if r[0] == "RSS")[1]) for run in runs)
            print(f"  peak RSS {rss:.0f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
