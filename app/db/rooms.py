"""Room layouts per map in SQLite (the same file as places and saved maps).

The key is a saved map's name, or :data:`LIVE` for the map being built. A layout is its label
grid (compressed ``.npy`` bytes), origin, resolution, next id and people's edits (JSON).
"""

from __future__ import annotations

import io
import json
import sqlite3
import zlib
from pathlib import Path

import numpy as np

from slam_core.rooms.layout import Edits, Merge, RoomLayout, Split

LIVE = ""

SCHEMA = """
CREATE TABLE IF NOT EXISTS room_layouts (
    map TEXT PRIMARY KEY,
    labels BLOB NOT NULL,
    origin_x REAL NOT NULL,
    origin_y REAL NOT NULL,
    resolution REAL NOT NULL,
    next_id INTEGER NOT NULL,
    edits TEXT NOT NULL
);
"""


class RoomStore:
    """Save and load one :class:`RoomLayout` per map."""

    def __init__(self, path: Path):
        self.path = Path(path)
        with self._connect() as db:
            db.executescript(SCHEMA)

    def _connect(self) -> sqlite3.Connection:
        return sqlite3.connect(self.path, timeout=5.0)

    def save(self, key: str, layout: RoomLayout) -> None:
        buffer = io.BytesIO()
        np.save(buffer, layout.labels.astype(np.int32))
        row = (key, zlib.compress(buffer.getvalue()), layout.origin[0], layout.origin[1], layout.resolution,
               layout.next_id, json.dumps(_edits_json(layout.edits)))
        db = self._connect()
        try:
            with db:
                db.execute("INSERT OR REPLACE INTO room_layouts VALUES (?, ?, ?, ?, ?, ?, ?)", row)
        finally:
            db.close()

    def load(self, key: str) -> RoomLayout | None:
        db = self._connect()
        try:
            row = db.execute("SELECT labels, origin_x, origin_y, resolution, next_id, edits "
                             "FROM room_layouts WHERE map = ?", (key,)).fetchone()
        finally:
            db.close()
        if row is None:
            return None
        blob, ox, oy, resolution, next_id, edits = row
        labels = np.load(io.BytesIO(zlib.decompress(blob)), allow_pickle=False)
        return RoomLayout(labels, (ox, oy), resolution, next_id, _edits_from(json.loads(edits)))


def _edits_json(edits: Edits) -> dict:
    return {"names": {str(k): v for k, v in edits.names.items()},
            "operations": [_operation_json(op) for op in edits.operations]}


def _operation_json(op: Merge | Split) -> dict:
    if isinstance(op, Merge):
        return {"merge": [op.keep, op.absorb]}
    return {"split": [op.room, op.new, list(op.a), list(op.b)]}


def _edits_from(data: dict) -> Edits:
    return Edits(names={int(k): v for k, v in data["names"].items()},
                 operations=tuple(_operation(op) for op in data["operations"]))


def _operation(data: dict) -> Merge | Split:
    if "merge" in data:
        keep, absorb = data["merge"]
        return Merge(int(keep), int(absorb))
    room, new, a, b = data["split"]
    return Split(int(room), int(new), tuple(a), tuple(b))
