"""Fault injection against a real server in simulation, judged by the simulator's ground truth.

Shared by ``tests/test_recovery.py`` and ``benchmarks/recovery.py``.
"""

from __future__ import annotations

import math
import os
import signal
import time
from pathlib import Path

from slam_core.io.ros_map import load_map
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.sim.ground_truth import ground_truth_map
from slam_core.sim.map_agreement import map_agreement
from slam_core.sim.world import load_world
from tests.live_server import LiveServer

POLL_S = 0.05


def descendants(pid: int) -> list[int]:
    """All processes below ``pid`` (children of every thread, recursively)."""
    found = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            children = (task / "children").read_text().split()
        except OSError:
            continue
        for child in map(int, children):
            found += [child, *descendants(child)]
    return found


def simulator_pid(server: LiveServer) -> int:
    """The simulator process: the server's child that is neither the worker nor the resource tracker."""
    worker = server.status()["worker"]["pid"]
    return next(pid for pid in descendants(server.proc.pid)
                if pid != worker and b"resource_tracker" not in Path(f"/proc/{pid}/cmdline").read_bytes())


def pose_error(status: dict) -> float:
    """Distance (m) between the published pose and the simulator's true pose."""
    pose, true = status["pose"], status["true_pose"]
    return math.hypot(pose["x"] - true[0], pose["y"] - true[1])


def pose_change(before: dict, after: dict) -> tuple[float, float]:
    """How far the published pose moved between two statuses: ``(metres, |radians|)``."""
    a, b = before["pose"], after["pose"]
    return math.hypot(b["x"] - a["x"], b["y"] - a["y"]), abs(math.remainder(b["yaw"] - a["yaw"], math.tau))


def wait_for(server: LiveServer, condition, timeout: float) -> tuple[dict, float]:
    """Poll the status until ``condition(status)``; ``(status, seconds waited)``; raises on timeout."""
    start = time.monotonic()
    while True:
        status = server.status()
        if condition(status):
            return status, time.monotonic() - start
        if time.monotonic() - start > timeout:
            raise TimeoutError(f"condition not met in {timeout} s: worker {status['worker']}, "
                               f"events {status['events']}")
        time.sleep(POLL_S)


def kill_worker(server: LiveServer) -> tuple[dict, float]:
    """SIGKILL the worker; wait for the new worker's first pose; ``(status, seconds to it)``."""
    before = server.status()["worker"]
    killed_at = time.time()
    os.kill(before["pid"], signal.SIGKILL)
    return wait_for(server, lambda s: s["worker"]["pid"] != before["pid"]
                    and (s["worker"]["state_t"] or 0) > killed_at, timeout=60)


def localized(status: dict) -> bool:
    return status["localized"] and not status["worker"]["relocalizing"]


def stop_robot(server: LiveServer, settle_s: float = 1.5) -> dict:
    """End the tour and let the robot stand still, so the pose can be compared with the truth."""
    with server.client() as c:
        c.post("/api/teleop", json={"v": 0.0, "w": 0.0}).raise_for_status()
    time.sleep(settle_s)
    return server.status()


def fetch_map(server: LiveServer, directory: Path) -> OccupancyGrid:
    directory.mkdir(parents=True, exist_ok=True)
    with server.client() as c:
        (directory / "map.pgm").write_bytes(c.get("/api/map.pgm").content)
        (directory / "map.yaml").write_bytes(c.get("/api/map.yaml").content)
    return load_map(directory / "map.yaml")


def agreement_with_truth(grid: OccupancyGrid, world: str = "flat") -> tuple[float, int]:
    return map_agreement(grid, ground_truth_map(load_world(world), grid.resolution))
