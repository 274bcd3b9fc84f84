"""Browser sessions in the SQLite database: random tokens (kept hashed) that expire, survive a
restart and that logout revokes. The cookie carries one of these, never the permanent token."""

from __future__ import annotations

import hashlib
import secrets
import sqlite3
import time
from pathlib import Path

#: How long a browser session lasts (s).
SESSION_LIFETIME_S = 12 * 3600
#: Sessions kept at most; the oldest goes first.
MAX_SESSIONS = 256

SCHEMA = "CREATE TABLE IF NOT EXISTS sessions (key TEXT PRIMARY KEY, expires REAL NOT NULL)"


def _key(token: str) -> str:
    return hashlib.sha256(token.encode()).hexdigest()


class Sessions:
    """Session tokens with their expiry (wall clock) in the ``sessions`` table of ``db_path``."""

    def __init__(self, db_path: Path, lifetime_s: float = SESSION_LIFETIME_S,
                 max_sessions: int = MAX_SESSIONS):
        self.db_path = Path(db_path)
        self.lifetime_s = lifetime_s
        self.max_sessions = max_sessions
        self.db_path.parent.mkdir(parents=True, exist_ok=True)
        with self._connect() as db:
            db.execute(SCHEMA)

    def _connect(self) -> sqlite3.Connection:
        return sqlite3.connect(self.db_path, timeout=5.0)

    def create(self) -> str:
        """A new session token, valid for ``lifetime_s``."""
        token = secrets.token_urlsafe(32)
        now = time.time()
        db = self._connect()
        try:
            with db:
                db.execute("DELETE FROM sessions WHERE expires <= ?", (now,))
                db.execute("DELETE FROM sessions WHERE key IN (SELECT key FROM sessions "
                           "ORDER BY expires DESC LIMIT -1 OFFSET ?)", (self.max_sessions - 1,))
                db.execute("INSERT INTO sessions (key, expires) VALUES (?, ?)",
                           (_key(token), now + self.lifetime_s))
        finally:
            db.close()
        return token

    def valid(self, token: str | None) -> bool:
        if not token or len(token) > 512:
            return False
        db = self._connect()
        try:
            row = db.execute("SELECT expires FROM sessions WHERE key = ?", (_key(token),)).fetchone()
        finally:
            db.close()
        return row is not None and row[0] > time.time()

    def revoke(self, token: str | None) -> None:
        if not token:
            return
        db = self._connect()
        try:
            with db:
                db.execute("DELETE FROM sessions WHERE key = ?", (_key(token),))
        finally:
            db.close()
