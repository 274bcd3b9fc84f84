"""No-go zones and virtual walls per map in SQLite (key: a saved map's name, or ``""`` for the live map)."""

from __future__ import annotations

import json
import sqlite3
from dataclasses import asdict, dataclass
from pathlib import Path

SCHEMA = """
CREATE TABLE IF NOT EXISTS zones (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    map TEXT NOT NULL,
    kind TEXT NOT NULL CHECK (kind IN ('zone', 'wall')),
    points TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS zones_by_map ON zones (map);
"""
#: The largest id SQLite can hold; a larger one names no zone (and must not reach SQLite: OverflowError).
MAX_ID = 2**63 - 1


@dataclass(frozen=True)
class ZoneRecord:
    id: int
    kind: str  # "zone" (a polygon) or "wall" (a segment)
    points: list[list[float]]

    def dict(self) -> dict:
        return asdict(self)


class ZoneStore:
    def __init__(self, path: Path):
        self.path = Path(path)
        db = self._connect()
        try:
            db.executescript(SCHEMA)
        finally:
            db.close()

    def _connect(self) -> sqlite3.Connection:
        return sqlite3.connect(self.path, timeout=5.0)

    def list(self, key: str) -> list[ZoneRecord]:
        db = self._connect()
        try:
            rows = db.execute("SELECT id, kind, points FROM zones WHERE map = ? ORDER BY id",
                              (key,)).fetchall()
        finally:
            db.close()
        return [ZoneRecord(i, kind, json.loads(points)) for i, kind, points in rows]

    def add(self, key: str, kind: str, points: list[list[float]]) -> ZoneRecord:
        db = self._connect()
        try:
            with db:
                cur = db.execute("INSERT INTO zones (map, kind, points) VALUES (?, ?, ?)",
                                 (key, kind, json.dumps(points)))
        finally:
            db.close()
        return ZoneRecord(int(cur.lastrowid), kind, points)

    def delete(self, key: str, zone_id: int) -> bool:
        if not 0 < zone_id <= MAX_ID:
            return False
        db = self._connect()
        try:
            with db:
                return db.execute("DELETE FROM zones WHERE map = ? AND id = ?", (key, zone_id)).rowcount > 0
        finally:
            db.close()

    def copy(self, source: str, target: str) -> None:
        db = self._connect()
        try:
            with db:
                db.execute("DELETE FROM zones WHERE map = ?", (target,))
                db.execute("INSERT INTO zones (map, kind, points) SELECT ?, kind, points FROM zones "
                           "WHERE map = ? ORDER BY id", (target, source))
        finally:
            db.close()
