"""Benchmark: ``homebot slam`` on the bundled intel and mit-csail logs.

Prints, per log: wall time (all, and the particle filter's share), real-time factor,
peak RSS, numba compile time (cold cache and warm cache), filter updates, loop edges,
and the relation error (mean ± std) of the result and of the best particle's own
trajectory (before the loop-closing back end).

    python benchmarks/slam_datasets.py [--particles 30] [--logs intel mit-csail] [--seeds 0 1 2]
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SLICE_LINES = 150


def homebot(*args: str, env=None) -> tuple[float, str]:
    started = time.perf_counter()
    out = subprocess.run([sys.executable, "-m", "app.cli", *args], cwd=ROOT, env=env, check=True,
                         capture_output=True, text=True)
    return time.perf_counter() - started, out.stdout


def evaluate(trajectory: Path, name: str) -> dict:
    _, text = homebot("eval", str(trajectory), name, "--json")
    return json.loads(text)


def compile_times(workdir: Path) -> tuple[float, float]:
    """Seconds for a short run with an empty numba cache, then with the cache it left.

    The slice (the first 150 lines of mit-csail) ends after the robot starts to move, so
    that every kernel of an update runs; its first 50 scans alone stand still.
    """
    from slam_core.datasets import BUNDLED
    from slam_core.io.carmen import open_log

    tiny = workdir / "tiny.clf"
    with open_log(BUNDLED["mit-csail"][0]) as src, open(tiny, "wb") as dst:
        for n, line in enumerate(src):
            dst.write(line)
            if n >= SLICE_LINES - 1:
                break
    env = {**os.environ, "NUMBA_CACHE_DIR": str(workdir / "numba-cache")}
    cold, _ = homebot("slam", str(tiny), "--out", str(workdir / "tiny-cold"), env=env)
    warm, _ = homebot("slam", str(tiny), "--out", str(workdir / "tiny-warm"), env=env)
    return cold, warm


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--particles", type=int, default=30)
    parser.add_argument("--logs", nargs="+", default=["intel", "mit-csail"])
    parser.add_argument("--seeds", nargs="+", type=int, default=[0], help="one run per seed")
    args = parser.parse_args()
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"python {platform.python_version()}")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        cold, warm = compile_times(tmp)
        print(f"start-up incl. numba compile, {SLICE_LINES}-line log: cold cache {cold:.1f} s, "
              f"warm cache {warm:.1f} s")
        print("| log | seed | particles | wall s (filter) | real-time factor | peak RSS MB | updates | "
              "resamplings | loop edges | translational m | rotational deg | best particle alone m / deg |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|")
        for name, seed in itertools.product(args.logs, args.seeds):
            out = tmp / f"{name}-{seed}"
            homebot("slam", name, "--out", str(out), "--particles", str(args.particles),
                    "--seed", str(seed))
            stats = json.loads((out / "stats.json").read_text())
            err = evaluate(out / "trajectory.txt", name)
            alone = evaluate(out / "particle_trajectory.txt", name)
            print(f"| {name} | {seed} | {args.particles} | {stats['wall_time_s']:.1f} "
                  f"({stats['filter_time_s']:.1f}) | {stats['real_time_factor']:.1f} | "
                  f"{stats['peak_rss_mb']:.0f} | {stats['updates']} | {stats['resamplings']} | "
                  f"{stats.get('loop_edges', 0)} | {err['trans_mean_m']:.4f} ± {err['trans_std_m']:.4f} | "
                  f"{err['rot_mean_deg']:.3f} ± {err['rot_std_deg']:.3f} | "
                  f"{alone['trans_mean_m']:.4f} / {alone['rot_mean_deg']:.3f} |", flush=True)


if __name__ == "__main__":
    main()
