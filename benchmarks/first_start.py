"""The first start of ``homebot serve`` on a fresh data dir: seconds and CPU seconds to each milestone.

Runs the quickstart's ``homebot serve`` (simulated flat, touring) twice on one new
``NUMBA_CACHE_DIR``: "cold" (empty: a fresh install) and "warm" (the cache the first run filled).
For each it prints the wall seconds from the launch to: the console's "starting", the printed URL,
the first pose, the first map, and the end of the warm-up, with the CPU seconds of the server and
all its children at the first map.

    python benchmarks/first_start.py [--runs cold,warm]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import threading
import time
from pathlib import Path

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from tests.live_server import LiveServer
from tests.recovery_harness import descendants

TIMEOUT_S = 300.0
TICKS = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pids: list[int]) -> float:
    """User + system CPU seconds of ``pids`` so far (processes gone meanwhile count 0)."""
    total = 0
    for pid in pids:
        try:
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        total += int(fields[11]) + int(fields[12])
    return total / TICKS


def first_start(data: Path, cache: str) -> dict[str, float]:
    server = LiveServer(data, env={"HOMEBOT_SIM_TOUR": "1", "NUMBA_CACHE_DIR": cache})
    launched = time.monotonic()
    server.launch()
    marks: dict[str, float] = {}

    def read_console() -> None:
        for line in server.proc.stdout:
            for mark, text in (("starting", "starting"), ("url printed", "open http")):
                if text in line and mark not in marks:
                    marks[mark] = time.monotonic() - launched

    threading.Thread(target=read_console, daemon=True).start()
    try:
        while time.monotonic() - launched < TIMEOUT_S and "warmed up" not in marks:
            try:
                status = server.status()
            except (httpx.HTTPError, ValueError, OSError):
                time.sleep(0.1)
                continue
            now = time.monotonic() - launched
            if status.get("pose") is not None:
                marks.setdefault("first pose", now)
            if status.get("map") is not None and "first map" not in marks:
                marks["first map"] = now
                everyone = [server.proc.pid, *descendants(server.proc.pid)]
                marks["CPU s at the first map"] = cpu_seconds(everyone)
            if status.get("preparing") is None and "first map" in marks:
                marks["warmed up"] = now
            time.sleep(0.1)
    finally:
        server.stop()
    return marks


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", default="cold,warm")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="homebot-first-start-") as tmp:
        cache = str(Path(tmp) / "numba-cache")
        for run in args.runs.split(","):
            load = os.getloadavg()[0]
            marks = first_start(Path(tmp) / f"data-{run}", cache)
            print(f"{run} (load {load:.1f}): " + ", ".join(f"{k} {v:.1f}" for k, v in marks.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
