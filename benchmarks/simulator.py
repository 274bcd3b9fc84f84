"""Simulator speed: real-time factor per sensor, ray casts per second, numba compile time.

Run from the repository root: ``python benchmarks/simulator.py [--seconds 60]``.
Prints one line per figure; nothing is asserted.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from slam_core.sim.lidar import Lidar
from slam_core.sim.raycast import cast_rays
from slam_core.sim.simulator import SimConfig, Simulator
from slam_core.sim.world import load_world

COMPILE_PROBE = """
import time
from slam_core.sim.world import load_world
from slam_core.sim.simulator import SimConfig, Simulator
w = load_world("flat")
t1, c1 = time.perf_counter(), time.process_time()
for sensor in ("lidar", "depth"):
    sim = Simulator(w, SimConfig(sensor=sensor), seed=0)
    sim.advance(0.2, 0.1)
print(f"{time.perf_counter() - t1:.2f} {time.process_time() - c1:.2f}")
"""


def compile_times() -> list[tuple[float, float]]:
    """First simulation step in a fresh process, (wall, CPU) s: empty numba cache (cold), then warm."""
    root = Path(__file__).resolve().parents[1]
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        out = []
        for _ in range(2):
            res = subprocess.run([sys.executable, "-c", COMPILE_PROBE], cwd=root, env=env,
                                 capture_output=True, text=True, check=True)
            wall, cpu = (float(v) for v in res.stdout.split())
            out.append((wall, cpu))
    return out


def realtime_factor(world_name: str, sensor: str, seconds: float) -> tuple[float, float, int]:
    """Simulated seconds per wall second and per CPU second (the latter is robust to a busy machine)."""
    sim = Simulator(load_world(world_name), SimConfig(sensor=sensor), seed=0)
    sim.advance(0.0, 0.0)  # compile outside the timing
    started, cpu = time.perf_counter(), time.process_time()
    frames = 0
    for _ in sim.tour(duration=seconds):
        frames += 1
    wall, cpu = time.perf_counter() - started, time.process_time() - cpu
    return sim.time / wall, sim.time / cpu, frames


def rays_per_second(world_name: str, beams: int = 360, scans: int = 400) -> float:
    world = load_world(world_name)
    lidar = Lidar(world)
    rng = np.random.default_rng(0)
    x0, y0, x1, y1 = world.bounds()
    poses = np.column_stack([rng.uniform(x0, x1, scans), rng.uniform(y0, y1, scans),
                             rng.uniform(-np.pi, np.pi, scans)])
    angles = np.linspace(-np.pi, np.pi, beams, endpoint=False)
    cast_rays(poses[0], angles, lidar.segments, lidar.circles, 8.0)
    started = time.process_time()
    for p in poses:
        cast_rays(p, angles, lidar.segments, lidar.circles, 8.0)
    return beams * scans / (time.process_time() - started)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="simulated seconds per tour run")
    args = parser.parse_args()
    (cold, cold_cpu), (warm, warm_cpu) = compile_times()
    print(f"compile (first lidar + depth step, fresh process): cold cache {cold:.2f} s wall "
          f"({cold_cpu:.2f} s CPU), warm cache {warm:.2f} s wall ({warm_cpu:.2f} s CPU)")
    for world in ("flat", "house"):
        w = load_world(world)
        print(f"{world}: {len(w.segments)} segments, {len(w.circles)} circles; "
              f"ray casts per CPU second (360 beams, 8 m): {rays_per_second(world) / 1e6:.2f} M")
        for sensor in ("lidar", "depth"):
            per_wall, per_cpu, frames = realtime_factor(world, sensor, args.seconds)
            print(f"{world} {sensor}: {per_wall:.1f} simulated s per wall s, {per_cpu:.1f} per CPU s "
                  f"({frames} frames at 20 Hz, physics 100 Hz)")
    print(f"peak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")


if __name__ == "__main__":
    main()
