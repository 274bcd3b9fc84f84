"""Localization mode in a running ``homebot serve`` (simulated flat): CPU, rate and accuracy.

The simulated robot tours the flat while the server maps it; the map is saved, the server is
switched to localization in it, and the tour goes on. Over the measuring window it prints the
worker process's CPU seconds per wall second (the issue's budget: 0.25 of one core), the state
rate the server receives, how often the published pose is flagged localized, and the published
pose's error against the simulator's true pose (median, 95th percentile, max).

    python benchmarks/live_localization.py [--map-s 90] [--measure-s 60] [--world flat]
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from tests.live_server import LiveServer, until

SAMPLE_S = 0.2


def cpu_seconds(pid: int) -> float:
    """User + system CPU seconds of a process (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def measure(server: LiveServer, seconds: float) -> dict:
    status = server.status()
    pid = status["worker"]["pid"]
    cpu0, wall0, steps0 = cpu_seconds(pid), time.monotonic(), status["worker"]["steps"]
    errors, flags = [], []
    while time.monotonic() - wall0 < seconds:
        status = server.status()
        pose, true = status["pose"], status["true_pose"]
        if pose and true:
            errors.append(math.hypot(pose["x"] - true[0], pose["y"] - true[1]))
            flags.append(bool(status["localized"]))
        time.sleep(SAMPLE_S)
    wall = time.monotonic() - wall0
    cpu = cpu_seconds(pid) - cpu0
    steps = status["worker"]["steps"] - steps0
    errors = np.array(errors)
    flags = np.array(flags)
    return {"worker_cpu_per_s": cpu / wall, "steps_hz": steps / wall, "localized": flags.mean(),
            "localized_far": (flags & (errors > 0.5)).mean(), "median": np.median(errors),
            "p95": np.percentile(errors, 95), "max": errors.max(), "samples": len(errors)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--map-s", type=float, default=90.0, help="seconds of touring while mapping")
    parser.add_argument("--measure-s", type=float, default=60.0, help="seconds measured in each mode")
    parser.add_argument("--world", default="flat")
    args = parser.parse_args()
    print(f"machine: {platform.node()}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f} at start")
    with tempfile.TemporaryDirectory() as tmp:
        server = LiveServer(Path(tmp), args.world, env={"HOMEBOT_SIM_TOUR": "1"}).start()
        try:
            time.sleep(args.map_s)
            mapping = measure(server, args.measure_s)
            with server.client() as c:
                assert c.post("/api/maps", json={"name": "bench"}).status_code == 201
                r = c.put("/api/mode", json={"mode": "localization", "map": "bench"})
                assert r.status_code in (200, 202), r.text
            until(lambda: server.status()["mode"] == "localization", 60, "localization mode")
            time.sleep(5.0)  # the tour goes on; let the filter settle on the saved map
            localization = measure(server, args.measure_s)
        finally:
            server.stop()
    print(f"load at end {os.getloadavg()[0]:.1f}")
    print("| mode | worker CPU s / s | steps Hz | localized | localized > 0.5 m off "
          "| error median / p95 / max (m) |")
    print("|---|---|---|---|---|---|")
    for name, m in (("mapping", mapping), ("localization", localization)):
        print(f"| {name} | {m['worker_cpu_per_s']:.3f} | {m['steps_hz']:.1f} | {m['localized']:.1%} | "
              f"{m['localized_far']:.1%} | {m['median']:.3f} / {m['p95']:.3f} / {m['max']:.3f} |")


if __name__ == "__main__":
    main()
