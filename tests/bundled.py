"""The bundled logs read once per test session (reading intel takes a few seconds)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

from slam_core.datasets import BUNDLED
from slam_core.io.carmen import CarmenReader, LaserRecord, OdomRecord


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
