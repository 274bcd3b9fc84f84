"""The access token (generated once, stored in the data dir, compared in constant time), the
browser session cookie's name and the websocket Origin check."""

from __future__ import annotations

import hmac
import os
import secrets
from pathlib import Path

TOKEN_FILE = "token"
TOKEN_BYTES = 32
#: Shortest permanent token accepted (from ``HOMEBOT_TOKEN`` or the token file).
MIN_TOKEN_LENGTH = 32
#: The browser's cookie: a session token from ``app.core.sessions``, never the permanent token.
COOKIE_NAME = "homebot_session"
#: The one SameSite policy of that cookie (set and cleared alike).
COOKIE_SAMESITE = "strict"


def load_or_create_token(data_dir: Path, preset: str | None = None) -> tuple[str, bool]:
    """The server's token and whether it was created now (first start).

    A ``preset`` token (from the settings) wins and is not written to disk.
    """
    if preset:
        return preset, False
    path = Path(data_dir) / TOKEN_FILE
    if path.exists():
        token = path.read_text().strip()
        if len(token) >= MIN_TOKEN_LENGTH:
            return token, False
    path.parent.mkdir(parents=True, exist_ok=True)
    token = secrets.token_urlsafe(TOKEN_BYTES)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w") as fh:
        fh.write(token + "\n")
    return token, True


def token_matches(given: str | None, expected: str) -> bool:
    """Constant-time comparison; ``None`` never matches."""
    if not given:
        return False
    return hmac.compare_digest(given.encode(), expected.encode())


def bearer_token(authorization: str | None) -> str | None:
    """The token of an ``Authorization: Bearer ...`` header, if that is what it is."""
    if not authorization:
        return None
    scheme, _, value = authorization.partition(" ")
    return value.strip() if scheme.lower() == "bearer" and value.strip() else None


def origin_allowed(origin: str | None, host: str | None, secure: bool, allowed: list[str]) -> bool:
    """Whether a websocket from page ``origin`` may connect: no Origin (not a browser), the server's
    own origin (``host`` over http(s)), or one of the configured CORS origins (``*``: any)."""
    if origin is None:
        return True
    own = f"{'https' if secure else 'http'}://{host}" if host else None
    return origin == own or "*" in allowed or origin in allowed
