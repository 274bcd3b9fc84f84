"""The bundled logs read once per test session (reading intel takes a few seconds)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

from slam_core.datasets import BUNDLED
from slam_core.io.carmen import CarmenReader, LaserRecord, OdomRecord, open_log


@dataclass(frozen=True)
class BundledLog:
    lasers: list[LaserRecord]
    odometry: list[OdomRecord]
    others: list
    skipped: dict


@cache
def read_bundled(name: str) -> BundledLog:
    reader = CarmenReader(BUNDLED[name][0])
    lasers, odometry, others = [], [], []
    for rec in reader:
        if isinstance(rec, LaserRecord):
            lasers.append(rec)
        elif isinstance(rec, OdomRecord):
            odometry.append(rec)
        else:
            others.append(rec)
    return BundledLog(lasers, odometry, others, dict(reader.skipped))


def log_slice(name: str, path, lasers: int):
    """Write the lines of a bundled log up to its ``lasers``-th laser line to ``path``."""
    with open_log(BUNDLED[name][0]) as src, open(path, "wb") as dst:
        seen = 0
        for line in src:
            dst.write(line)
            seen += line.startswith(b"FLASER")
            if seen == lasers:
                break
    return path
