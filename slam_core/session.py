"""A mapping session that can be continued another day (as slam_toolbox serialises its pose graph).

A session holds what the back end needs to go on: the robot pose (map frame, after the
last optimisation) and the odometry at every filter update, the scan of each update, the
laser mount, the SLAM config and where the robot was at the last scan (a continuation
starts there). The map is rendered again from those on load, so loops
closed later can still move the old part.

File format (``.npz``, version :data:`VERSION`), one array per key:

=================  ===========  =============================================================
key                shape        meaning
=================  ===========  =============================================================
``format``         ()           the string ``homebot-session``
``version``        ()           int, :data:`VERSION`
``config``         ()           the SLAM config as JSON (``RBPFConfig.to_dict``)
``laser_mount``    (3,)         the laser's pose on the robot: x, y (m), theta (rad)
``poses``          (n, 3)       robot poses of the updates in the map frame (m, m, rad)
``odometry``       (n, 3)       the odometry of the updates, re-anchored to the map frame
``offsets``        (n + 1,)     int64: update k's beams are ``offsets[k]:offsets[k + 1]``
``angles``         (beams,)     float32 beam bearings (rad)
``ranges``         (beams,)     float32 ranges (m; ``inf``: no echo)
``range_limits``   (n, 2)       each scan's range_min, range_max (m)
``stamps``         (n,)         each scan's timestamp (s)
``end_pose``       (3,)         the robot pose at the session's last scan (map frame)
=================  ===========  =============================================================
"""

from __future__ import annotations

import json
import os
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from slam_core.io.npz import write_npz
from slam_core.map_bands import MapBands
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.rbpf import RBPFConfig
from slam_core.rbpf.hit_render import SparseHits, sparse_hit_sums
from slam_core.rbpf.laser_mount import LaserMount
from slam_core.scan import Scan

FORMAT = "homebot-session"
VERSION = 1
SUFFIX = ".session.npz"


class SessionError(ValueError):
    """A session file that cannot be used: damaged, of another version, or inconsistent."""


@dataclass(frozen=True)
class MappingSession:
    """The updates of a finished mapping run, in the map frame."""

    config: RBPFConfig
    laser_mount: LaserMount
    poses: np.ndarray
    odometry: np.ndarray
    scans: list[Scan]
    end_pose: np.ndarray

    def __post_init__(self):
        n = len(self.scans)
        if n == 0:
            raise SessionError("a session needs at least one update")
        for name, shape in (("poses", (n, 3)), ("odometry", (n, 3)), ("end_pose", (3,))):
            value = np.array(getattr(self, name), float)
            if value.shape != shape or not np.all(np.isfinite(value)):
                raise SessionError(f"{name} must be finite, of shape {shape}; got {value.shape}")
            object.__setattr__(self, name, value)

    def grid(self) -> OccupancyGrid:
        """The map, rendered from the updates' poses and scans as ``homebot slam`` writes it and the
        live back end publishes it after a solve: clamped after the sum (:mod:`slam_core.count_map`)."""
        c = self.config
        return MapBands(self.laser_mount.laser_poses(self.poses), self.scans, c.resolution, c.sensor,
                        c.loop_closure.submap_updates).grid()

    def hit_sums(self, grid: OccupancyGrid) -> SparseHits:
        """The updates' per-cell hit sums on ``grid``'s cells (as :meth:`grid` renders them), for a
        particle filter seeded with that map (:mod:`slam_core.rbpf.hit_render`)."""
        return sparse_hit_sums(grid, self.laser_mount.laser_poses(self.poses), self.scans,
                               self.config.sensor)


def write_session(session: MappingSession, file) -> None:
    """Write ``session``'s arrays (the format above) to an open binary ``file``."""
    offsets = np.concatenate([[0], np.cumsum([len(s) for s in session.scans])]).astype(np.int64)
    arrays = {
        "format": np.array(FORMAT), "version": np.array(VERSION),
        "config": np.array(json.dumps(session.config.to_dict())),
        "laser_mount": np.array(session.laser_mount.as_tuple(), float),
        "poses": session.poses, "odometry": session.odometry, "offsets": offsets,
        "angles": np.concatenate([s.angles for s in session.scans]).astype(np.float32),
        "ranges": np.concatenate([s.ranges for s in session.scans]).astype(np.float32),
        "range_limits": np.array([(s.range_min, s.range_max) for s in session.scans], float),
        "stamps": np.array([s.timestamp for s in session.scans], float),
        "end_pose": session.end_pose,
    }
    write_npz(file, arrays)


def save_session(session: MappingSession, path: Path) -> Path:
    """Write ``session`` to ``path`` atomically (written beside it, then renamed)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(path.name + ".partial")
    with open(partial, "wb") as f:
        write_session(session, f)
        f.flush()
        os.fsync(f.fileno())
    os.replace(partial, path)
    return path


def load_session(path: Path) -> MappingSession:
    """Read a session file; :class:`SessionError` naming the file for anything that is not a
    complete session of a known version."""
    path = Path(path)
    if path.is_file() and not zipfile.is_zipfile(path):  # np.load would read a .npy or guess pickle
        raise SessionError(f"{path}: not a session file (not a complete .npz archive)")
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {key: data[key] for key in data.files}
    except FileNotFoundError:
        raise SessionError(f"{path}: no such session file") from None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise SessionError(f"{path}: not a readable session file ({exc})") from None
    try:
        return _session(arrays)
    except SessionError as exc:
        raise SessionError(f"{path}: {exc}") from None
    except (KeyError, TypeError, ValueError) as exc:
        raise SessionError(f"{path}: damaged session ({type(exc).__name__}: {exc})") from None


def _session(a: dict[str, np.ndarray]) -> MappingSession:
    if str(a.get("format", "")) != FORMAT:
        raise SessionError("not a homebot session")
    version = int(a["version"])
    if version != VERSION:
        raise SessionError(f"session version {version}; this homebot reads version {VERSION}")
    offsets = a["offsets"].astype(np.int64)
    angles, ranges, limits, stamps = a["angles"], a["ranges"], a["range_limits"], a["stamps"]
    n = len(offsets) - 1
    if (n < 1 or offsets[0] != 0 or np.any(np.diff(offsets) < 0) or offsets[-1] != len(angles)
            or len(ranges) != len(angles) or limits.shape != (n, 2) or stamps.shape != (n,)):
        raise SessionError("its scans do not fit together (offsets, beams, limits)")
    if not (np.all(np.isfinite(angles)) and np.all(np.isfinite(limits)) and not np.any(np.isnan(ranges))):
        raise SessionError("its scans hold non-finite values")
    scans = [Scan(angles[offsets[k]:offsets[k + 1]], ranges[offsets[k]:offsets[k + 1]],
                  float(limits[k, 0]), float(limits[k, 1]), float(stamps[k])) for k in range(n)]
    config = RBPFConfig.from_dict(json.loads(str(a["config"])))
    return MappingSession(config, LaserMount.of(a["laser_mount"]), a["poses"], a["odometry"], scans,
                          a["end_pose"])
