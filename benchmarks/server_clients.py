"""50 websocket clients for 60 s against a local ``homebot serve`` (simulated flat, robot driving).

Prints frames/s delivered (per client and in total, by kind), end-to-end latency from the
worker's publish (``t`` in each pose frame) to the client, the server's CPU (server +
worker + simulator processes, % of one core) and memory (RSS) at start and end.

    python benchmarks/server_clients.py [--clients 50] [--seconds 60]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import websockets

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from tests.live_server import LiveServer

TOUR = [(3.2, 1.8), (1.0, 3.75), (5.4, 3.75), (8.0, 4.0), (5.4, 3.75), (1.0, 3.75)]
CLK_TCK = os.sysconf("SC_CLK_TCK")


def process_tree(pid: int) -> list[int]:
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        try:
            children = Path(f"/proc/{p}/task/{p}/children").read_text().split()
        except OSError:
            continue
        todo.extend(int(c) for c in children)
    return out


def cpu_seconds(pids: list[int]) -> float:
    total = 0
    for p in pids:
        try:
            fields = Path(f"/proc/{p}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        total += int(fields[11]) + int(fields[12])  # utime + stime
    return total / CLK_TCK


def rss_mb(pids: list[int]) -> float:
    total = 0
    for p in pids:
        try:
            for line in Path(f"/proc/{p}/status").read_text().splitlines():
                if line.startswith("VmRSS:"):
                    total += int(line.split()[1])
        except OSError:
            continue
    return total / 1024


async def client(url: str, seconds: float, stats: dict) -> None:
    counts: dict[str, int] = {}
    latencies: list[float] = []
    async with websockets.connect(url, max_size=None) as ws:
        end = time.monotonic() + seconds
        while (left := end - time.monotonic()) > 0:
            try:
                raw = await asyncio.wait_for(ws.recv(), left)
            except TimeoutError:
                break
            if isinstance(raw, bytes):
                counts["map"] = counts.get("map", 0) + 1
                continue
            kind = raw[9:raw.index('"', 9)]  # '{"type":"<kind>"': serialised with "type" first
            counts[kind] = counts.get(kind, 0) + 1
            if kind == "pose":
                latencies.append(time.time() - json.loads(raw)["t"])
    stats["counts"].append(counts)
    stats["latency"].extend(latencies)


async def drive(server: LiveServer, seconds: float) -> None:
    end = time.monotonic() + seconds
    with server.client() as c:
        for goal in TOUR * 10:
            if time.monotonic() > end:
                return
            c.post("/api/goal", json={"x": goal[0], "y": goal[1]})
            while time.monotonic() < end:
                await asyncio.sleep(0.5)
                if c.get("/api/path").json()["state"] != "driving":
                    break


async def run(server: LiveServer, clients: int, seconds: float) -> dict:
    stats = {"counts": [], "latency": []}
    url = f"{server.ws_url}?token={server.token}"
    await asyncio.gather(drive(server, seconds), *(client(url, seconds, stats) for _ in range(clients)))
    return stats


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clients", type=int, default=50)
    parser.add_argument("--seconds", type=float, default=60.0)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        server = LiveServer(Path(tmp) / "data").start()
        try:
            time.sleep(2.0)
            pids = process_tree(server.proc.pid)
            mem_start, cpu_start, t0 = rss_mb(pids), cpu_seconds(pids), time.monotonic()
            stats = asyncio.run(run(server, args.clients, args.seconds))
            wall = time.monotonic() - t0
            pids = process_tree(server.proc.pid)
            cpu = (cpu_seconds(pids) - cpu_start) / wall * 100
            mem_end = rss_mb(pids)
            status = server.status()
        finally:
            server.stop()
    kinds = sorted({k for c in stats["counts"] for k in c})
    print(f"clients {args.clients}, {args.seconds:.0f} s, {len(stats['counts'])} finished; "
          f"worker steps {status['worker']['steps']}, restarts {status['worker']['restarts']}")
    for kind in kinds:
        per = [c.get(kind, 0) / args.seconds for c in stats["counts"]]
        print(f"  {kind:10s} per client {statistics.mean(per):6.2f}/s (min {min(per):5.2f}), "
              f"total {sum(per):8.1f}/s")
    lat = sorted(stats["latency"])
    if lat:
        q = lambda f: lat[min(len(lat) - 1, int(f * len(lat)))] * 1000  # noqa: E731
        print(f"  pose latency worker->client: median {q(0.5):.1f} ms, p95 {q(0.95):.1f} ms, "
              f"p99 {q(0.99):.1f} ms, max {lat[-1] * 1000:.1f} ms ({len(lat)} frames)")
    print(f"  server CPU (server+worker+simulator): {cpu:.0f}% of one core")
    print(f"  server RSS: {mem_start:.0f} MB at start, {mem_end:.0f} MB at end")


if __name__ == "__main__":
    main()
