"""The security pieces on their own: token length, CORS without credentials for '*', browser
sessions (expiry, revocation, a bounded table) and the login limit."""

from __future__ import annotations

import time

import pytest
from fastapi.testclient import TestClient
from pydantic import ValidationError

from app.core.config import Settings
from app.core.login_limit import LoginLimiter
from app.db.sessions import Sessions
from app.main import create_app


def test_a_preset_token_needs_32_characters(tmp_path):
    with pytest.raises(ValidationError, match="at least 32"):
        Settings(data_dir=tmp_path, token="x" * 31)
    assert Settings(data_dir=tmp_path, token="x" * 32).token == "x" * 32


@pytest.mark.parametrize("origins, credentials", [("*", None), ("https://home.example", "true")])
def test_cors_wildcard_never_allows_credentials(tmp_path, origins, credentials):
    app = create_app(Settings(data_dir=tmp_path, cors_origins=origins))
    client = TestClient(app)  # no lifespan: the open health route needs no robot
    r = client.options("/api/health", headers={"Origin": "https://home.example",
                                               "Access-Control-Request-Method": "GET"})
    assert r.status_code == 200
    assert r.headers.get("access-control-allow-credentials") == credentials


def test_sessions_expire_are_revoked_and_stay_bounded(tmp_path):
    sessions = Sessions(tmp_path / "db.sqlite3", lifetime_s=0.3, max_sessions=3)
    first = sessions.create()
    assert sessions.valid(first) and not sessions.valid("made-up") and not sessions.valid(None)
    sessions.revoke(first)
    assert not sessions.valid(first)
    tokens = [sessions.create() for _ in range(4)]
    assert [sessions.valid(t) for t in tokens] == [False, True, True, True]  # the oldest went
    assert Sessions(tmp_path / "db.sqlite3").valid(tokens[-1]), "a session survives a restart"
    time.sleep(0.35)
    assert not any(sessions.valid(t) for t in tokens)


def test_the_login_limit_counts_failures_per_client_in_a_window():
    limiter = LoginLimiter(max_failures=3, window_s=0.3)
    for _ in range(3):
        assert limiter.retry_after("a") == 0.0
        limiter.failed("a")
    assert 0.0 < limiter.retry_after("a") <= 0.3 and limiter.retry_after("b") == 0.0
    time.sleep(0.35)
    assert limiter.retry_after("a") == 0.0
