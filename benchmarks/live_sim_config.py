"""Benchmark: the live simulated robot mapping with different SLAM configs (issue #15).

For each config it starts ``homebot serve`` (simulated flat, scripted tour on), waits for the
first map, then for ``--seconds`` samples the status once a second and prints the SLAM worker's
CPU seconds per second (``/proc/PID/stat``), its step rate, and the published pose's error
against the simulator's ground truth (mean and max). Configs: ``slam`` (``homebot slam``'s
defaults, what the server uses now) and ``old`` (the server's former update thresholds,
0.25 m / 0.2 rad, given as a ``--config`` file).

    python benchmarks/live_sim_config.py [--seconds 90] [--configs slam old] [--robot FILE]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from slam_core.rbpf.config import RBPFConfig  # noqa: E402

TOKEN = "live-sim-config-benchmark-token-0123456"
CONFIGS = {"slam": RBPFConfig(),
           "old": dataclasses.replace(RBPFConfig(), linear_update=0.25, angular_update=0.2)}
READY_TIMEOUT_S = 300.0


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def run(name: str, seconds: float, robot: str | None) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        config = Path(tmp) / "config.json"
        config.write_text(json.dumps(CONFIGS[name].to_dict()))
        port = free_port()
        env = {**os.environ, "HOMEBOT_TOKEN": TOKEN, "HOMEBOT_SIM_TOUR": "1", "PYTHONPATH": str(ROOT)}
        args = [sys.executable, "-m", "app.cli", "serve", "--port", str(port), "--data", f"{tmp}/data",
                "--config", str(config)] + (["--robot", robot] if robot else [])
        proc = subprocess.Popen(args, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        client = httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=30.0,
                              headers={"Authorization": f"Bearer {TOKEN}"})
        try:
            status = wait_ready(client)
            pid, steps0 = status["worker"]["pid"], status["worker"]["steps"]
            cpu0, t0 = cpu_seconds(pid), time.monotonic()
            errors = []
            while time.monotonic() - t0 < seconds:
                time.sleep(1.0)
                status = client.get("/api/status").json()
                pose, true = status["pose"], status["true_pose"]
                errors.append(math.hypot(pose["x"] - true[0], pose["y"] - true[1]))
            elapsed = time.monotonic() - t0
            return {"config": name, "seconds": round(elapsed, 1),
                    "worker_cpu_per_s": round((cpu_seconds(pid) - cpu0) / elapsed, 3),
                    "steps_per_s": round((status["worker"]["steps"] - steps0) / elapsed, 1),
                    "pose_error_mean_m": round(sum(errors) / len(errors), 3),
                    "pose_error_max_m": round(max(errors), 3)}
        finally:
            client.close()
            proc.terminate()
            proc.wait(30)


def wait_ready(client: httpx.Client) -> dict:
    deadline = time.monotonic() + READY_TIMEOUT_S
    while time.monotonic() < deadline:
        try:
            status = client.get("/api/status").json()
            if status.get("map") and status.get("pose") and status["worker"].get("pid"):
                return status
        except (httpx.HTTPError, ValueError):
            pass
        time.sleep(0.5)
    raise RuntimeError("the server did not become ready")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=90.0)
    parser.add_argument("--configs", nargs="+", choices=sorted(CONFIGS), default=["slam", "old"])
    parser.add_argument("--robot", help="a robot file (default: the simulated robot)")
    args = parser.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.1f}")
    for name in args.configs:
        print(json.dumps(run(name, args.seconds, args.robot)), flush=True)
    print(f"load average after: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
