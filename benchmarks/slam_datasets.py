"""Benchmark: ``homebot slam`` on the bundled intel and mit-csail logs and the stress logs.

Prints one table, a row per log and seed: wall time (all, and the particle filter's
share), CPU seconds, peak RSS, filter updates, loop edges found and rejected, and the
relation error (mean ± std) of the result and of the best particle's own trajectory
(before the loop-closing back end); before it, the numba compile time (cold cache and
warm cache). Stress logs are ``<stress-dir>/<name>/<name>.clf.bz2`` with their
``<name>.relations``; run it with ``nice -n 10`` on a shared machine.

    python benchmarks/slam_datasets.py [--particles 30] [--logs intel mit-csail belgioioso ...]
        [--seeds 0 1 2] [--stress-dir ../shared/datasets/stress] [--config config.json]

``--config`` runs every log with that SLAM config file (``homebot slam --config``; keys left
out keep their defaults), to judge a change of settings on every log at once.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SLICE_LINES = 150
BUNDLED_LOGS = ("intel", "mit-csail")
STRESS_LOGS = ("belgioioso", "fhw", "freiburg-101", "freiburg-campus", "orebro", "seattle")
STRESS_DIR = ROOT.parent / "shared" / "datasets" / "stress"  # beside the checkout


def homebot(*args: str, env=None) -> tuple[float, str]:
    started = time.perf_counter()
    out = subprocess.run([sys.executable, "-m", "app.cli", *args], cwd=ROOT, env=env, check=True,
                         capture_output=True, text=True)
    return time.perf_counter() - started, out.stdout


def children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def log_and_relations(name: str, stress_dir: Path) -> tuple[str, str]:
    """A bundled log's name twice, or a stress log's file and relations."""
    if name in BUNDLED_LOGS:
        return name, name
    folder = stress_dir / name
    return str(folder / f"{name}.clf.bz2"), str(folder / f"{name}.relations")


def evaluate(trajectory: Path, relations: str) -> dict:
    _, text = homebot("eval", str(trajectory), relations, "--json")
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
    parser.add_argument("--logs", nargs="+", default=[*BUNDLED_LOGS, *STRESS_LOGS])
    parser.add_argument("--seeds", nargs="+", type=int, default=[0], help="one run per seed")
    parser.add_argument("--stress-dir", type=Path, default=STRESS_DIR)
    parser.add_argument("--skip-compile", action="store_true", help="skip the cold / warm start-up runs")
    parser.add_argument("--config", type=Path, help="a SLAM config file for every run")
    args = parser.parse_args()
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"python {platform.python_version()}")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if not args.skip_compile:
            cold, warm = compile_times(tmp)
            print(f"start-up incl. numba compile, {SLICE_LINES}-line log: cold cache {cold:.1f} s, "
                  f"warm cache {warm:.1f} s")
        print("| log | seed | particles | wall s (filter) | CPU s | peak RSS MB | updates | "
              "loop edges (rejected) | translational m | rotational deg | best particle alone m / deg |")
        print("|---|---|---|---|---|---|---|---|---|---|---|")
        for name, seed in itertools.product(args.logs, args.seeds):
            log, relations = log_and_relations(name, args.stress_dir)
            out = tmp / f"{name}-{seed}"
            cpu = children_cpu()
            config = ["--config", str(args.config.resolve())] if args.config else []
            homebot("slam", log, "--out", str(out), "--particles", str(args.particles),
                    "--seed", str(seed), *config)
            cpu = children_cpu() - cpu
            stats = json.loads((out / "stats.json").read_text())
            err = evaluate(out / "trajectory.txt", relations)
            alone = evaluate(out / "particle_trajectory.txt", relations)
            print(f"| {name} | {seed} | {args.particles} | {stats['wall_time_s']:.1f} "
                  f"({stats['filter_time_s']:.1f}) | {cpu:.1f} | {stats['peak_rss_mb']:.0f} | "
                  f"{stats['updates']} | {stats.get('loop_edges', 0)} "
                  f"({stats.get('rejected_loop_edges', 0)}) | "
                  f"{err['trans_mean_m']:.4f} ± {err['trans_std_m']:.4f} | "
                  f"{err['rot_mean_deg']:.3f} ± {err['rot_std_deg']:.3f} | "
                  f"{alone['trans_mean_m']:.4f} / {alone['rot_mean_deg']:.3f} |", flush=True)


if __name__ == "__main__":
    main()
