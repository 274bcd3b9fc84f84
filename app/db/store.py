"""SQLite (stdlib ``sqlite3``) storage of named places and saved-map records.

One short-lived connection per call keeps it safe from any thread; WAL journaling
lets readers and the writer overlap.
"""

from __future__ import annotations

import sqlite3
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path

SCHEMA = """
CREATE TABLE IF NOT EXISTS places (
    name TEXT PRIMARY KEY,
    x REAL NOT NULL,
    y REAL NOT NULL,
    yaw REAL NOT NULL DEFAULT 0
);
CREATE TABLE IF NOT EXISTS maps (
    name TEXT PRIMARY KEY,
    created REAL NOT NULL,
    width INTEGER NOT NULL,
    height INTEGER NOT NULL,
    resolution REAL NOT NULL
);
"""


class NotFound(KeyError):
    """No record of that name."""


class AlreadyExists(ValueError):
    """A record of that name exists."""


@dataclass(frozen=True)
class Place:
    name: str
    x: float
    y: float
    yaw: float = 0.0

    def dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class MapRecord:
    name: str
    created: float
    width: int
    height: int
    resolution: float

    def dict(self) -> dict:
        return asdict(self)


class Store:
    """Places and saved-map records in one SQLite file."""

    def __init__(self, path: Path):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with self._connect() as db:
            db.execute("PRAGMA journal_mode=WAL")
            db.executescript(SCHEMA)

    @contextmanager
    def _connect(self) -> Iterator[sqlite3.Connection]:
        db = sqlite3.connect(self.path, timeout=5.0)
        try:
            with db:
                yield db
        finally:
            db.close()

    # places
    def list_places(self) -> list[Place]:
        with self._connect() as db:
            rows = db.execute("SELECT name, x, y, yaw FROM places ORDER BY name").fetchall()
        return [Place(*row) for row in rows]

    def get_place(self, name: str) -> Place:
        with self._connect() as db:
            row = db.execute("SELECT name, x, y, yaw FROM places WHERE name = ?", (name,)).fetchone()
        if row is None:
            raise NotFound(f"no place named {name!r}")
        return Place(*row)

    def add_place(self, place: Place) -> Place:
        try:
            with self._connect() as db:
                db.execute("INSERT INTO places (name, x, y, yaw) VALUES (?, ?, ?, ?)",
                           (place.name, place.x, place.y, place.yaw))
        except sqlite3.IntegrityError:
            raise AlreadyExists(f"a place named {place.name!r} exists") from None
        return place

    def update_place(self, name: str, new: Place) -> Place:
        try:
            with self._connect() as db:
                cur = db.execute("UPDATE places SET name = ?, x = ?, y = ?, yaw = ? WHERE name = ?",
                                 (new.name, new.x, new.y, new.yaw, name))
                if cur.rowcount == 0:
                    raise NotFound(f"no place named {name!r}")
        except sqlite3.IntegrityError:
            raise AlreadyExists(f"a place named {new.name!r} exists") from None
        return new

    def delete_place(self, name: str) -> None:
        with self._connect() as db:
            if db.execute("DELETE FROM places WHERE name = ?", (name,)).rowcount == 0:
                raise NotFound(f"no place named {name!r}")

    # maps
    def list_maps(self) -> list[MapRecord]:
        with self._connect() as db:
            rows = db.execute("SELECT name, created, width, height, resolution FROM maps "
                              "ORDER BY name").fetchall()
        return [MapRecord(*row) for row in rows]

    def get_map(self, name: str) -> MapRecord:
        with self._connect() as db:
            row = db.execute("SELECT name, created, width, height, resolution FROM maps WHERE name = ?",
                             (name,)).fetchone()
        if row is None:
            raise NotFound(f"no saved map named {name!r}")
        return MapRecord(*row)

    def add_map(self, name: str, width: int, height: int, resolution: float) -> MapRecord:
        record = MapRecord(name, time.time(), int(width), int(height), float(resolution))
        try:
            with self._connect() as db:
                db.execute("INSERT INTO maps (name, created, width, height, resolution) "
                           "VALUES (?, ?, ?, ?, ?)", (record.name, record.created, record.width,
                                                      record.height, record.resolution))
        except sqlite3.IntegrityError:
            raise AlreadyExists(f"a saved map named {name!r} exists") from None
        return record

    def delete_map(self, name: str) -> None:
        with self._connect() as db:
            if db.execute("DELETE FROM maps WHERE name = ?", (name,)).rowcount == 0:
                raise NotFound(f"no saved map named {name!r}")
