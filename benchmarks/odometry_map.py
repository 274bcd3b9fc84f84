"""Benchmark ``homebot map`` (odometry mapping) on the bundled logs.

For each log, two fresh processes share a new, empty ``NUMBA_CACHE_DIR``: the
first ("cold") compiles the kernels, the second ("warm") loads them from the
cache. Each prints the kernels' compile/load time ("numba s"), the mapping
command's wall and CPU time, scans per second (wall), the process's peak
resident memory and the whole process's wall time (imports included).

    python benchmarks/odometry_map.py [--logs intel mit-csail]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, resource, sys, tempfile, time
from pathlib import Path
import numpy as np
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.scan import Scan
t0 = time.perf_counter()
grid = OccupancyGrid(0.05)
grid.integrate(Scan([0.0], [1.0], 0.1, 80.0), np.zeros(3))   # compiles or loads the kernels
compile_s = time.perf_counter() - t0
from app.cli import main
with tempfile.TemporaryDirectory() as out:
    t1, c1 = time.perf_counter(), time.process_time()
    code = main(["map", sys.argv[1], "--out", out])
    wall_s, cpu_s = time.perf_counter() - t1, time.process_time() - c1
    scans = len(Path(out, "trajectory.txt").read_text().splitlines())
rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
print("RESULT " + json.dumps({"code": code, "compile_s": compile_s, "wall_s": wall_s, "cpu_s": cpu_s,
                              "scans": scans, "peak_rss_mb": rss_mb}))
"""


def run_child(log: str, cache_dir: str) -> dict:
    env = {**os.environ, "NUMBA_CACHE_DIR": cache_dir}
    started = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", CHILD, log], cwd=ROOT, env=env,
                          capture_output=True, text=True, check=True)
    process_s = time.perf_counter() - started
    line = next(x for x in proc.stdout.splitlines() if x.startswith("RESULT "))
    result = json.loads(line[len("RESULT "):])
    result["process_s"] = process_s
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--logs", nargs="+", default=["intel", "mit-csail"])
    args = parser.parse_args()
    print(f"{'log':<10} {'run':<5} {'scans':>6} {'map wall s':>10} {'map cpu s':>9} {'scans/s':>8} "
          f"{'peak RSS MB':>11} {'numba s':>8} {'process s':>9}")
    for log in args.logs:
        with tempfile.TemporaryDirectory(prefix="numba-cache-") as cache:
            for run in ("cold", "warm"):
                r = run_child(log, cache)
                if r["code"] != 0:
                    raise SystemExit(f"homebot map {log} failed with exit code {r['code']}")
                print(f"{log:<10} {run:<5} {r['scans']:>6} {r['wall_s']:>10.2f} {r['cpu_s']:>9.2f} "
                      f"{r['scans'] / r['wall_s']:>8.0f} {r['peak_rss_mb']:>11.0f} "
                      f"{r['compile_s']:>8.2f} {r['process_s']:>9.2f}", flush=True)


if __name__ == "__main__":
    main()
