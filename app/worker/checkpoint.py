"""Durable worker state: lossless map snapshots, a frequent pose file, quarantine of bad snapshots.

A snapshot is one ``.npz`` per generation (``map-000042.npz``): the map's log-odds, its
per-cell hit sums (the mean beam endpoints the scan matcher aligns to), origin and
resolution, with the pose, mode and encoder counts at that moment. It is written to a temp
file, fsynced and renamed, so a crash leaves either the old or the new snapshot, never half
of one. The newest :data:`GENERATIONS_KEPT` are kept. Between snapshots the pose is saved,
just as atomically, to ``pose.json`` with the generation it belongs to.

Format 2 and :data:`VERSION` (``"version"`` in the state) are in the published map frame: after a
loop-closing solve the map is the optimised one, with hit sums rendered from the session's scans
at the optimised poses (:mod:`slam_core.rbpf.hit_render`), and the pose is the corrected one; while
the back end runs, the mapping session is beside it (``session-000042.session.npz``,
:mod:`slam_core.session`, written first, atomically too), so a restarted worker closes loops
against everything mapped before. A snapshot without ``"version"`` (format 1: the filter's own
map and pose, no session) still loads, a consistent map and pose in the filter's frame, and its
back end starts afresh. Format 3 keeps the hit sums of the cells an echo fell into only
(``hit_cells``, flat indices, and their ``hit_values``; format 2 kept them dense) and is deflated
at level 1 (:mod:`slam_core.io.npz`): a building floor's snapshot costs 40 % of the CPU time.
Any format may hold the odometry's errors the estimator measured (``odometry_alphas`` and
``odometry_errors``, :class:`~slam_core.odometry_calibration.MeasuredErrors`); a snapshot without
them resumes with a calibration that starts empty.
A snapshot of a newer format, or whose session is missing or damaged, is refused (and set aside
as below) rather than read wrongly.

A snapshot that fails to load, or that the supervisor blames for a crash loop
(:func:`quarantine_newest`), is renamed ``map-000042.bad-20260101T120000.npz`` (kept for
inspection, never loaded again) and the previous generation is used.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import time
import zipfile
import zlib
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from app.worker.estimators import Checkpoint
from app.worker.shared_map import MAX_SIDE
from slam_core.io.npz import write_npz
from slam_core.io.render import save_png
from slam_core.io.ros_map import save_map
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.odometry_calibration import MeasuredErrors
from slam_core.rbpf.hit_render import SparseHits
from slam_core.session import SUFFIX, SessionError, load_session, write_session

#: The snapshot format written; formats 1 (no ``"version"``) and 2 are read too.
VERSION = 3
READ_VERSIONS = (1, 2, VERSION)
POSE_FILE = "pose.json"
GENERATIONS_KEPT = 3
SNAPSHOT = re.compile(r"map-(\d{6})\.npz")


class BadCheckpoint(ValueError):
    """A snapshot that cannot be used (unreadable, inconsistent or absurd)."""


@dataclass
class Restored:
    """What :func:`load_checkpoint` found: the checkpoint (None: start afresh) and what it set aside."""

    checkpoint: Checkpoint | None
    generation: int = 0
    quarantined: list[tuple[Path, str]] = field(default_factory=list)  # (new path, reason)


def generations(directory: Path) -> list[int]:
    """Snapshot generations present, oldest first."""
    found = (SNAPSHOT.fullmatch(p.name) for p in Path(directory).glob("map-*.npz"))
    return sorted(int(m.group(1)) for m in found if m)


def snapshot_path(directory: Path, generation: int) -> Path:
    return Path(directory) / f"map-{generation:06d}.npz"


def session_path(directory: Path, generation: int) -> Path:
    return Path(directory) / f"session-{generation:06d}{SUFFIX}"


def write_atomically(path: Path, write) -> None:
    """Call ``write(file)`` on a temp file beside ``path``, fsync it, rename it over ``path``."""
    tmp = path.with_name(f".{path.name}.tmp")
    with open(tmp, "wb") as f:
        write(f)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
    directory = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(directory)
    finally:
        os.close(directory)


def _state(checkpoint: Checkpoint) -> dict:
    return {"version": VERSION, "mode": checkpoint.mode, "pose": [float(v) for v in checkpoint.pose],
            "mapping": checkpoint.mapping, "map_name": checkpoint.map_name,
            "ticks": None if checkpoint.ticks is None else [int(t) for t in checkpoint.ticks],
            "session": checkpoint.session is not None, "time": time.time()}


def save_snapshot(directory: Path, checkpoint: Checkpoint) -> int:
    """Write ``checkpoint`` (with its map and session) as the next generation; returns that generation."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    existing = generations(directory)
    generation = (existing[-1] if existing else 0) + 1
    grid = checkpoint.grid
    arrays = {"state": np.array(json.dumps(_state(checkpoint)))}
    if grid is not None and grid.data.size:
        arrays.update(log_odds=grid.data.astype(np.float32, copy=False),  # written at once: no copy
                      origin=np.asarray(grid.origin, float), resolution=np.array(grid.resolution))
        hits = checkpoint.hit_sums
        if hits is not None:
            if not hits.fits(grid):
                raise ValueError(f"hit sums of a {hits.shape} grid at {hits.origin} for a {grid.shape} map")
            arrays["hit_cells"], arrays["hit_values"] = hits.cells, hits.values
    errors = checkpoint.odometry_errors
    if errors is not None:
        arrays["odometry_alphas"], arrays["odometry_errors"] = errors.alphas, errors.rows
    if checkpoint.session is not None:
        write_atomically(session_path(directory, generation), lambda f: write_session(checkpoint.session, f))
    write_atomically(snapshot_path(directory, generation), lambda f: write_npz(f, arrays))
    for old in existing[:max(0, len(existing) + 1 - GENERATIONS_KEPT)]:
        snapshot_path(directory, old).unlink(missing_ok=True)
        session_path(directory, old).unlink(missing_ok=True)
    return generation


def save_pose(directory: Path, checkpoint: Checkpoint, generation: int) -> None:
    """The pose between snapshots (``checkpoint.grid`` is ignored)."""
    text = json.dumps({**_state(checkpoint), "generation": generation}).encode()
    write_atomically(Path(directory) / POSE_FILE, lambda f: f.write(text))


def read_snapshot(path: Path, max_cells: int, session: Path | None = None) -> Checkpoint:
    """One snapshot (with its mapping ``session`` file when it has one), checked;
    :class:`BadCheckpoint` says why it cannot be used."""
    try:
        with np.load(path, allow_pickle=False) as z:
            state = json.loads(str(z["state"]))
            grid = hits = None
            if "log_odds" in z:
                grid = OccupancyGrid(float(z["resolution"]), z["origin"], data=z["log_odds"])
                if "hit_sums" in z:  # format 2: dense
                    dense = z["hit_sums"]
                    if dense.shape != (*grid.shape, 3):
                        raise ValueError(f"hit sums of shape {dense.shape} for a {grid.shape} map")
                    hits = SparseHits.from_dense(dense, grid.origin)
                if "hit_cells" in z:
                    hits = SparseHits(grid.origin, grid.shape, z["hit_cells"], z["hit_values"])
            errors = None
            if "odometry_errors" in z:
                errors = MeasuredErrors(z["odometry_alphas"], z["odometry_errors"])
        checkpoint = Checkpoint(grid=grid, hit_sums=hits, odometry_errors=errors, **_state_fields(state))
    except (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        raise BadCheckpoint(f"unreadable: {type(exc).__name__}: {exc}") from None
    version = state.get("version", 1)
    if version not in READ_VERSIONS:
        raise BadCheckpoint(f"checkpoint format {version!r}; this homebot reads formats 1 to {VERSION}")
    if state.get("session"):
        if session is None or not session.exists():
            raise BadCheckpoint("its mapping session file is missing")
        try:
            checkpoint = replace(checkpoint, session=load_session(session))
        except SessionError as exc:
            raise BadCheckpoint(f"its mapping session: {exc}") from None
    if grid is not None:
        if grid.data.ndim != 2 or grid.data.size > max_cells or max(grid.data.shape) > MAX_SIDE:
            raise BadCheckpoint(f"map of shape {grid.data.shape} exceeds the limit of {max_cells} cells "
                                f"(sides of at most {MAX_SIDE})")
        if not np.all(np.isfinite(grid.data)) or (hits is not None and not np.all(np.isfinite(hits.values))):
            raise BadCheckpoint("map or hit sums hold non-finite values")
    return checkpoint


def _state_fields(state: dict) -> dict:
    """The :class:`Checkpoint` fields a snapshot's state (or the pose file) holds, checked."""
    pose = np.array(state["pose"], float)
    if pose.shape != (3,) or not np.all(np.isfinite(pose)):
        raise ValueError(f"pose {state['pose']!r} is not three finite numbers")
    ticks = state.get("ticks")
    return {"mode": str(state["mode"]), "pose": pose, "mapping": bool(state.get("mapping", True)),
            "map_name": state.get("map_name"),
            "ticks": None if ticks is None else (int(ticks[0]), int(ticks[1]))}


def load_checkpoint(directory: Path, max_cells: int) -> Restored:
    """The newest usable snapshot with the newest pose saved for it; bad snapshots are quarantined."""
    directory = Path(directory)
    restored = Restored(None)
    for generation in reversed(generations(directory)):
        path = snapshot_path(directory, generation)
        try:
            checkpoint = read_snapshot(path, max_cells, session_path(directory, generation))
        except BadCheckpoint as exc:
            restored.quarantined.append((quarantine(directory, generation), str(exc)))
            continue
        with contextlib.suppress(OSError, ValueError, KeyError, TypeError, IndexError):
            state = json.loads((directory / POSE_FILE).read_text())
            if state.get("generation") == generation:  # newer state; the map and the rest stay
                checkpoint = replace(checkpoint, **_state_fields(state))
        restored.checkpoint, restored.generation = checkpoint, generation
        return restored
    return restored


def quarantine(directory: Path, generation: int) -> Path:
    """Rename a snapshot (and its session) aside, with the time in the name, so it is kept but never
    loaded again; the snapshot's new path."""
    stamp = time.strftime("%Y%m%dT%H%M%S", time.gmtime())
    session = session_path(directory, generation)
    if session.exists():
        os.replace(session, session.with_name(f"{session.name.removesuffix(SUFFIX)}.bad-{stamp}{SUFFIX}"))
    path = snapshot_path(directory, generation)
    target = path.with_name(f"{path.stem}.bad-{stamp}{path.suffix}")
    os.replace(path, target)
    return target


def quarantine_newest(directory: Path) -> Path | None:
    """Set the newest snapshot aside (the supervisor blames it for a crash loop); its new path."""
    found = generations(directory)
    return quarantine(directory, found[-1]) if found else None


def save_exit_map(grid: OccupancyGrid, stem: Path, trajectory=None) -> list[Path]:
    """The map at shutdown: PGM + YAML (ROS map_server) and a PNG picture."""
    pgm, yml = save_map(grid, stem)
    png = save_png(grid, Path(stem).with_suffix(".png"), trajectory=trajectory)
    return [pgm, yml, png]
