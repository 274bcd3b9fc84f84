"""Crash and restart recovery of a local ``homebot serve`` (simulated flat, touring), over many tries.

Prints, each with min / median / max over the tries:

- after a SIGKILL of the worker: seconds to the new worker's first pose and to "localized",
  and the pose error against the simulator's truth 3 s later;
- after a SIGTERM and after a SIGKILL of the server, restarted on the same data dir: seconds
  from the launch to the first pose and to "localized", and the pose error then;
- map cells kept (known cells after a restart / before) and the map's agreement with the
  ground-truth map, against a run of the same length without kills;
- child processes still alive 3 s after a SIGKILL of the server;
- where each new worker's start-up went: wall and CPU seconds per stage, median over the tries
  (the worker's ``startup`` event, :mod:`app.worker.startup_clock`).

    python benchmarks/recovery.py [--tries 10] [--drive 30]
"""

from __future__ import annotations

import argparse
import os
import signal
import statistics
import sys
import tempfile
import time
from pathlib import Path

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from tests.live_server import LiveServer
from tests.recovery_harness import (
    agreement_with_truth,
    descendants,
    fetch_map,
    kill_worker,
    localized,
    pose_error,
    wait_for,
)

TIMEOUT_S = 120.0
TOUR = {"HOMEBOT_SIM_TOUR": "1"}


def running(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def summary(name: str, values: list[float], unit: str) -> None:
    if values:
        print(f"{name:48s} min {min(values):8.3f}  median {statistics.median(values):8.3f}  "
              f"max {max(values):8.3f} {unit}  (n={len(values)})")


def startup_stages(status: dict, into: dict[str, list[list[float]]]) -> None:
    """Add the newest ``startup`` event's stages (wall, CPU seconds) to ``into``."""
    event = next((e for e in reversed(status["events"]) if e["event"] == "startup"), None)
    for stage, seconds in (event or {}).get("stages", {}).items():
        into.setdefault(stage, []).append(seconds)


def stage_summary(name: str, stages: dict[str, list[list[float]]]) -> None:
    for stage, values in stages.items():
        wall = statistics.median(v[0] for v in values)
        cpu = statistics.median(v[1] for v in values)
        print(f"  {name} start-up, {stage:38s} median {wall:6.3f} s wall {cpu:6.3f} s CPU  (n={len(values)})")


def known_cells(server: LiveServer, directory: Path) -> tuple[int, float]:
    grid = fetch_map(server, directory)
    return int((grid.trinary() >= 0).sum()), agreement_with_truth(grid)[0]


def worker_kills(work: Path, tries: int, drive: float) -> None:
    server = LiveServer(work / "kills", env=TOUR).start()
    first, back, errors, stages = [], [], [], {}
    try:
        time.sleep(drive)
        for _ in range(tries):
            _, to_pose = kill_worker(server)
            status, to_localized = wait_for(server, localized, TIMEOUT_S)
            startup_stages(status, stages)
            first.append(to_pose)
            back.append(to_pose + to_localized)
            time.sleep(3.0)
            errors.append(pose_error(server.status()))
        cells, agreement = known_cells(server, work / "kills-map")
    finally:
        server.stop()
    reference = LiveServer(work / "reference", env=TOUR).start()
    try:
        time.sleep(drive + tries * 3.0)
        _, reference_agreement = known_cells(reference, work / "reference-map")
    finally:
        reference.stop()
    summary("worker kill: first pose", first, "s")
    summary("worker kill: localized", back, "s")
    summary("worker kill: pose error 3 s later", errors, "m")
    stage_summary("worker kill:", stages)
    print(f"map agreement with the truth: {agreement:.4f} after {tries} kills, "
          f"{reference_agreement:.4f} without kills ({cells} known cells)")


def server_restarts(work: Path, tries: int, drive: float, how: signal.Signals) -> None:
    data = work / f"restart-{how.name}"
    server = LiveServer(data, env=TOUR).start()
    first, back, errors, kept, stages = [], [], [], [], {}
    try:
        time.sleep(drive)
        for _ in range(tries):
            before, _ = known_cells(server, work / "before")
            server.proc.send_signal(how)
            server.proc.wait(60)
            server.stop()
            launched = time.monotonic()
            server = LiveServer(data, env=TOUR).launch()
            wait_for_server(server, lambda s: s["pose"] is not None)
            first.append(time.monotonic() - launched)
            status, _ = wait_for(server, localized, TIMEOUT_S)
            back.append(time.monotonic() - launched)
            startup_stages(status, stages)
            errors.append(pose_error(status))
            time.sleep(3.0)
            kept.append(known_cells(server, work / "after")[0] / before)
    finally:
        server.stop()
    summary(f"server {how.name}: first pose after the launch", first, "s")
    summary(f"server {how.name}: localized after the launch", back, "s")
    summary(f"server {how.name}: pose error when localized", errors, "m")
    summary(f"server {how.name}: map cells kept (after / before)", kept, "")
    stage_summary(f"server {how.name}:", stages)


def wait_for_server(server: LiveServer, condition) -> dict:
    """The first status that meets ``condition``, while the server may not answer yet."""
    deadline = time.monotonic() + TIMEOUT_S
    while time.monotonic() < deadline:
        try:
            status = server.status()
            if condition(status):
                return status
        except (httpx.HTTPError, ValueError):  # not listening yet
            pass
        time.sleep(0.05)
    raise TimeoutError("the server did not answer")


def orphans_after_server_kills(work: Path, tries: int) -> None:
    left = []
    for i in range(tries):
        server = LiveServer(work / f"orphans-{i}").start()
        children = descendants(server.proc.pid)
        os.kill(server.proc.pid, signal.SIGKILL)
        server.proc.wait()
        time.sleep(3.0)
        left.append(float(sum(running(pid) for pid in children)))
        server.stop()
    summary("children alive 3 s after a server SIGKILL", left, "")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--tries", type=int, default=10)
    parser.add_argument("--drive", type=float, default=30.0, help="seconds of touring before the faults")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="homebot-recovery-") as tmp:
        work = Path(tmp)
        worker_kills(work, args.tries, args.drive)
        for how in (signal.SIGTERM, signal.SIGKILL):
            server_restarts(work, args.tries, args.drive, how)
        orphans_after_server_kills(work, args.tries)
    return 0


if __name__ == "__main__":
    sys.exit(main())
