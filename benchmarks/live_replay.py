"""Benchmark: logs replayed through a real ``homebot serve --replay``, against ``homebot slam`` offline.

Per log, speed and seed it starts the server (``--exit-at-end``), watches its websocket
stream to the end, and prints: the live trajectory's relation error and its ratio to
``homebot slam``'s on the same log and seed, scans dropped, the worker's CPU seconds per
log second, and the stream's rates: pose messages and map frames per second (mean, and the
lowest over any 5 s window while the log plays), and the memory of the server's process tree
(proportional set size summed over the server, its workers and its fork server, sampled each second:
the shared map block counts once): the median sample and the peak.

    python benchmarks/live_replay.py [--logs intel mit-csail] [--speeds max 1] [--seeds 0]
        [--no-offline]

A log is a bundled name or a path; its relations are the bundled ones or ``<log>.relations``
beside a stress log (``../shared/datasets/stress/<name>/<name>.clf.bz2``).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import platform
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import websockets

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from slam_core.datasets import BUNDLED, resolve_relations  # noqa: E402
from slam_core.evaluation import evaluate_files  # noqa: E402

TOKEN = "live-replay-benchmark-token-0123456"
WINDOW_S = 5.0
CONNECT_TIMEOUT_S = 300.0


def relations_of(log: str) -> Path:
    if log in BUNDLED:
        return resolve_relations(log)
    path = Path(log)
    return path.parent / (path.name.split(".")[0] + ".relations")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


async def watch(port: int) -> dict[str, list[float]]:
    """Arrival times of pose messages and map frames, and of each replay phase's first status."""
    deadline = time.monotonic() + CONNECT_TIMEOUT_S
    while True:
        try:
            ws = await websockets.connect(f"ws://127.0.0.1:{port}/ws?token={TOKEN}", max_size=None)
            break
        except OSError:
            if time.monotonic() > deadline:
                raise
            await asyncio.sleep(0.2)
    times: dict[str, list[float]] = {"pose": [], "map": [], "playing": [], "optimising": [], "finished": []}
    async with ws:
        with contextlib.suppress(websockets.ConnectionClosed):
            async for raw in ws:
                now = time.monotonic()
                if isinstance(raw, bytes):
                    times["map"].append(now)
                    continue
                message = json.loads(raw)
                if message["type"] == "pose":
                    times["pose"].append(now)
                elif message["type"] == "status" and message.get("replay"):
                    times[message["replay"]["phase"]].append(now)
    return times


def rates(stamps: list[float], start: float, end: float) -> tuple[float, float]:
    """Mean rate over ``[start, end]`` and the lowest over any :data:`WINDOW_S` window in it."""
    t = np.asarray(stamps)
    t = t[(t >= start) & (t <= end)]
    span = end - start
    if span <= 0:
        return 0.0, 0.0
    mean = len(t) / span
    if span < WINDOW_S:
        return mean, mean
    edges = np.arange(start, end - WINDOW_S, 1.0)
    lowest = min(((t >= e) & (t < e + WINDOW_S)).sum() for e in edges) / WINDOW_S
    return mean, lowest


def tree_pss_mb(root: int) -> float:
    """Proportional set size of ``root`` and its descendants, MB (shared pages split, not counted twice)."""
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            with contextlib.suppress(OSError, IndexError, ValueError):
                ppid = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
                children.setdefault(ppid, []).append(int(entry.name))
    total_kb, todo = 0, [root]
    while todo:
        pid = todo.pop()
        todo.extend(children.get(pid, []))
        with contextlib.suppress(OSError):
            for line in Path(f"/proc/{pid}/smaps_rollup").read_text().splitlines():
                if line.startswith("Pss:"):
                    total_kb += int(line.split()[1])
    return total_kb / 1024


class TreeMemory(threading.Thread):
    """Samples :func:`tree_pss_mb` of a process tree once a second: the median and the highest
    sample (the peak is a moment, often the replay's final solve, and varies from run to run)."""

    def __init__(self, pid: int) -> None:
        super().__init__(daemon=True)
        self.pid, self.samples, self.stopped = pid, [], threading.Event()

    def run(self) -> None:
        while not self.stopped.wait(1.0):
            self.samples.append(tree_pss_mb(self.pid))


def replay(log: str, speed: str, seed: int, workdir: Path) -> dict:
    port = free_port()
    data = workdir / f"data-{Path(log).name}-{speed}-{seed}"
    env = {**os.environ, "HOMEBOT_TOKEN": TOKEN, "HOMEBOT_SEED": str(seed)}
    started = time.monotonic()
    proc = subprocess.Popen([sys.executable, "-m", "app.cli", "serve", "--port", str(port),
                             "--data", str(data), "--replay", log, "--speed", speed, "--exit-at-end"],
                            cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    memory = TreeMemory(proc.pid)
    memory.start()
    try:
        times = asyncio.run(watch(port))
        output, _ = proc.communicate(timeout=4 * 3600)
    finally:
        memory.stopped.set()
        if proc.poll() is None:
            proc.kill()
    if proc.returncode != 0:
        raise RuntimeError(f"homebot serve exited with {proc.returncode}:\n{output[-3000:]}")
    out = next((data / "replay").iterdir())
    stats = json.loads((out / "stats.json").read_text())
    first_pose = times["pose"][0] if times["pose"] else started
    playing_end = (times["optimising"] or times["finished"] or [time.monotonic()])[0]
    end = times["finished"][0] if times["finished"] else playing_end
    pose_mean, pose_low = rates(times["pose"], first_pose, playing_end)
    map_mean, map_low = rates(times["map"], first_pose, end)
    error = evaluate_files(out / "trajectory.txt", relations_of(log)).summary()
    return {"stats": stats, "error": error, "pose_hz": (pose_mean, pose_low), "map_hz": (map_mean, map_low),
            "trajectory": out / "trajectory.txt",
            "pss_mb": (float(np.median(memory.samples or [0.0])), max(memory.samples, default=0.0))}


def offline(log: str, seed: int, workdir: Path) -> dict:
    out = workdir / f"offline-{Path(log).name}-{seed}"
    subprocess.run([sys.executable, "-m", "app.cli", "slam", log, "--out", str(out), "--seed", str(seed)],
                   cwd=ROOT, check=True, capture_output=True, text=True)
    return evaluate_files(out / "trajectory.txt", relations_of(log)).summary()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--logs", nargs="+", default=["intel", "mit-csail"])
    parser.add_argument("--speeds", nargs="+", default=["max"])
    parser.add_argument("--seeds", nargs="+", type=int, default=[0])
    parser.add_argument("--no-offline", action="store_true", help="skip the `homebot slam` comparison")
    args = parser.parse_args()
    print(f"# {platform.node()}: {os.cpu_count()} cores, {platform.processor() or platform.machine()}, "
          f"load average {os.getloadavg()[0]:.1f}")
    print("| log | speed | seed | live m / deg | offline m | live / offline | dropped | worker CPU s / log s "
          "| pose Hz mean (lowest 5 s) | map Hz mean (lowest 5 s) | loop edges | wall s "
          "| PSS MB median / peak |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        workdir = Path(tmp)
        for log in args.logs:
            for seed in args.seeds:
                reference = None if args.no_offline else offline(log, seed, workdir)
                for speed in args.speeds:
                    r = replay(log, speed, seed, workdir)
                    s, e = r["stats"], r["error"]
                    ref = "-" if reference is None else f"{reference['trans_mean_m']:.4f}"
                    ratio = ("-" if reference is None
                             else f"{e['trans_mean_m'] / reference['trans_mean_m']:.3f}")
                    print(f"| {Path(log).name} | {speed} | {seed} | {e['trans_mean_m']:.4f} / "
                          f"{e['rot_mean_deg']:.3f} | {ref} | {ratio} | {s['dropped']} of {s['records']} | "
                          f"{s['worker_cpu_s'] / s['log_duration_s']:.3f} | {r['pose_hz'][0]:.1f} "
                          f"({r['pose_hz'][1]:.1f}) | {r['map_hz'][0]:.1f} ({r['map_hz'][1]:.1f}) | "
                          f"{s.get('loop_edges', 0)} | {s['wall_time_s']:.1f} | "
                          f"{r['pss_mb'][0]:.0f} / {r['pss_mb'][1]:.0f} |",
                          flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
