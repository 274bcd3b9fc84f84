"""Periodic checkpoints (map + pose + mode) a restarted worker resumes from, and the exit map."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import numpy as np

from app.worker.estimators import Checkpoint
from slam_core.io.render import save_png
from slam_core.io.ros_map import load_map, save_map
from slam_core.occupancy_grid import OccupancyGrid

STATE_FILE = "state.json"
MAP_STEM = "map"


def save_checkpoint(directory: Path, checkpoint: Checkpoint) -> None:
    """Write map then state, each atomically (temp file + rename), so a crash leaves the old pair."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    if checkpoint.grid is not None and checkpoint.grid.data.size:
        tmp = directory / "tmp"
        pgm, yml = save_map(checkpoint.grid, tmp / MAP_STEM)
        os.replace(pgm, directory / pgm.name)
        os.replace(yml, directory / yml.name)
    state = {
        "mode": checkpoint.mode,
        "pose": [float(v) for v in checkpoint.pose],
        "mapping": checkpoint.mapping,
        "map_name": checkpoint.map_name,
        "has_map": checkpoint.grid is not None and bool(checkpoint.grid.data.size),
        "time": time.time(),
    }
    tmp_state = directory / (STATE_FILE + ".tmp")
    tmp_state.write_text(json.dumps(state))
    os.replace(tmp_state, directory / STATE_FILE)


def load_checkpoint(directory: Path) -> Checkpoint | None:
    """The last checkpoint, or ``None`` when there is none (or it is unreadable)."""
    directory = Path(directory)
    try:
        state = json.loads((directory / STATE_FILE).read_text())
        grid = load_map(directory / f"{MAP_STEM}.yaml") if state.get("has_map") else None
        return Checkpoint(state["mode"], np.array(state["pose"], float), grid,
                          bool(state.get("mapping", True)), state.get("map_name"))
    except (OSError, ValueError, KeyError):
        return None


def clear_checkpoint(directory: Path) -> None:
    """Forget the checkpoint (a fresh start)."""
    for name in (STATE_FILE, f"{MAP_STEM}.yaml", f"{MAP_STEM}.pgm"):
        (Path(directory) / name).unlink(missing_ok=True)


def save_exit_map(grid: OccupancyGrid, stem: Path, trajectory=None) -> list[Path]:
    """The map at shutdown: PGM + YAML (ROS map_server) and a PNG picture."""
    pgm, yml = save_map(grid, stem)
    png = save_png(grid, Path(stem).with_suffix(".png"), trajectory=trajectory)
    return [pgm, yml, png]
