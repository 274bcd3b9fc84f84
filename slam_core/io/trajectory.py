"""Per-scan trajectory files: one line ``ipc_timestamp x y theta`` per laser record."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass
class Trajectory:
    """Poses ``(n, 3)`` with their timestamps, as exact text and as floats."""

    stamps: list[str]
    poses: np.ndarray

    @property
    def times(self) -> np.ndarray:
        return np.array([float(s) for s in self.stamps])

    def save(self, path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "w") as f:
            for stamp, (x, y, th) in zip(self.stamps, self.poses, strict=False):
                f.write(f"{stamp} {x:.6f} {y:.6f} {th:.6f}\n")
        return path

    @classmethod
    def load(cls, path) -> Trajectory:
        stamps, poses = [], []
        with open(path) as f:
            for number, line in enumerate(f, 1):
                fields = line.split()
                if not fields or fields[0].startswith("#"):
                    continue
                if len(fields) != 4:
                    raise ValueError(f"{path}:{number}: expected 'timestamp x y theta', "
                                     f"got {len(fields)} fields")
                try:
                    float(fields[0])
                    poses.append([float(v) for v in fields[1:]])
                except ValueError as exc:
                    raise ValueError(f"{path}:{number}: {exc}") from exc
                stamps.append(fields[0])
        return cls(stamps, np.array(poses, dtype=float).reshape(-1, 3))
