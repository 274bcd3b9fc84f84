"""What the worker keeps of a replay, and the outputs it writes at the end, like ``homebot slam``.

The worker tells :meth:`ReplayRecording.stepped` which record it stepped and whether the
filter updated with it. At the end of the log :meth:`ReplayRecording.finish` runs the
same back end as ``homebot slam`` (loop closing, a pose for every laser record, the map
from the optimised poses) and writes ``trajectory.txt`` (one line per record, robot
frame), ``particle_trajectory.txt``, the map (PGM + YAML + PNG), ``config.json`` and
``stats.json`` into ``DATA/replay/<log>/``. A record the worker never stepped (dropped at
a finite speed) gets the pose of its last stepped record moved by the odometry since.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from slam_core.datasets import CREDIT, is_bundled
from slam_core.graph.loop_closure import per_scan_poses
from slam_core.io.carmen import LaserRecord
from slam_core.io.render import save_png
from slam_core.io.ros_map import save_map
from slam_core.io.trajectory import Trajectory
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.pipelines.log_slam import best_updates, close_filter_loops
from slam_core.rbpf import RBPFSlam


@dataclass(frozen=True)
class ReplayProgress:
    """The replay part of the status: which log, how far, and the phase (``playing``,
    ``optimising``, ``finished``; ``failed`` when mapping stopped before the end, the map
    having outgrown its limit)."""

    log: str
    speed: float | None  # None: as fast as the worker steps
    records: int
    played: int
    stepped: int
    phase: str
    out_dir: str


@dataclass(frozen=True)
class ReplayResult:
    """The replay's final trajectory (one pose per record), its map and the files written."""

    poses: np.ndarray
    grid: OccupancyGrid
    paths: list[Path]
    loop_edges: int


class ReplayRecording:
    """Per-record bookkeeping of one replay, in the worker process."""

    def __init__(self, log_path: Path, name: str, records: list[LaserRecord], out_dir: Path,
                 speed: float | None, seed: int, warnings: list[str]):
        self.log_path = log_path
        self.name = name
        self.records = records
        self.out_dir = out_dir
        self.speed = speed
        self.seed = seed
        self.warnings = list(warnings)
        self.phase = "playing"
        self.started: float | None = None  # wall and CPU clocks at the first step
        self.cpu_started = 0.0
        self._update_of_record = np.full(len(records), -1, np.int64)
        self._is_update = np.zeros(len(records), bool)
        self._stepped = 0

    def stepped(self, index: int, updated: bool, update: int) -> None:
        """The worker stepped record ``index``; ``update`` is the filter's last update index."""
        if self.started is None:
            self.started, self.cpu_started = time.monotonic(), time.process_time()
        self._update_of_record[index] = update
        self._is_update[index] = updated
        self._stepped += 1

    def progress(self, played: int) -> ReplayProgress:
        return ReplayProgress(self.name, self.speed, len(self.records), played, self._stepped, self.phase,
                              str(self.out_dir))

    def _update_of_every_record(self) -> np.ndarray:
        """Each record's last update: a dropped record takes the one of the record stepped before it."""
        stepped = self._update_of_record >= 0
        last = np.maximum.accumulate(np.where(stepped, np.arange(len(stepped)), 0))
        return np.maximum(self._update_of_record[last], 0)

    def finish(self, slam: RBPFSlam) -> ReplayResult:
        """Close the loops of the whole replay and write its outputs (see the module docstring)."""
        filter_time = time.monotonic() - self.started
        config = slam.config
        update_of_scan = self._update_of_every_record()
        odometry = np.array([r.odom for r in self.records])
        best = best_updates(slam)
        particle = per_scan_poses(update_of_scan, odometry, best.odometry, best.poses)
        closed = None
        if config.loop_closure.enabled:
            scans = [r.scan for r in self.records]
            poses, bands, closed, _ = close_filter_loops(config, slam.mount, best, update_of_scan,
                                                         self._is_update, odometry, scans)
            grid = bands.grid()
        else:
            poses, grid = particle, slam.occupancy_map()
        stats = {
            "log": str(self.log_path), "seed": self.seed, "speed": self.speed or "max",
            "records": len(self.records), "stepped": self._stepped,
            "laser_mount": list(slam.mount.as_tuple()),
            "dropped": len(self.records) - self._stepped,
            "filter_time_s": round(filter_time, 3),
            "wall_time_s": round(time.monotonic() - self.started, 3),
            "worker_cpu_s": round(time.process_time() - self.cpu_started, 3),
            "log_duration_s": round(_log_duration(self.records), 3),
            **slam.stats.as_dict(),
            **(closed.stats() if closed is not None else {}),
            "warnings": self.warnings,
        }
        paths = self._write(poses, particle, grid, config.to_dict(), stats)
        self.phase = "finished"
        return ReplayResult(poses, grid, paths, closed.loop_edges if closed is not None else 0)

    def _write(self, poses: np.ndarray, particle: np.ndarray, grid: OccupancyGrid, config: dict,
               stats: dict) -> list[Path]:
        out = self.out_dir
        out.mkdir(parents=True, exist_ok=True)
        stamps = [r.stamp.ipc_text for r in self.records]
        caption = "homebot live replay" + (" - " + CREDIT if is_bundled(self.log_path) else "")
        paths = [*save_map(grid, out / "map"), save_png(grid, out / "map.png", poses, caption=caption),
                 Trajectory(stamps, poses).save(out / "trajectory.txt"),
                 Trajectory(stamps, particle).save(out / "particle_trajectory.txt")]
        for name, content in (("config.json", config), ("stats.json", stats)):
            (out / name).write_text(json.dumps(content, indent=2) + "\n")
            paths.append(out / name)
        return paths


def _log_duration(records: list[LaserRecord]) -> float:
    times = [r.stamp.ipc_time for r in records]
    return max(times) - min(times)
