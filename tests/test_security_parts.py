"""The security pieces on their own: token length, CORS without credentials for '*', browser
sessions (expiry, revocation, a bounded table), the login limit and whose proxy headers count."""

from __future__ import annotations

import asyncio
import time
from pathlib import Path

import httpx
import pytest
import yaml
from pydantic import ValidationError

from app.cli.serve import server_config
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

    async def preflight() -> httpx.Response:  # no lifespan: the open health route needs no robot
        async with httpx.AsyncClient(transport=httpx.ASGITransport(app), base_url="http://homebot") as client:
            return await client.options("/api/health", headers={"Origin": "https://home.example",
                                                                "Access-Control-Request-Method": "GET"})

    r = asyncio.run(preflight())
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


def _scheme_seen(settings: Settings, client_ip: str) -> str:
    """The scheme the app sees for a request from ``client_ip`` saying ``X-Forwarded-Proto: https``,
    behind uvicorn's proxy-header handling as ``homebot serve`` configures it."""
    from uvicorn.middleware.proxy_headers import ProxyHeadersMiddleware

    async def scheme(scope, receive, send):
        await send({"type": "http.response.start", "status": 200, "headers": []})
        await send({"type": "http.response.body", "body": scope["scheme"].encode()})

    config = server_config(scheme, settings)
    app = ProxyHeadersMiddleware(scheme, trusted_hosts=config.forwarded_allow_ips)

    async def run():
        transport = httpx.ASGITransport(app=app, client=(client_ip, 50000))
        async with httpx.AsyncClient(transport=transport, base_url="http://t") as c:
            return (await c.get("/", headers={"X-Forwarded-Proto": "https"})).text

    return asyncio.run(run())


def test_proxy_headers_count_from_the_configured_proxy_only(tmp_path):
    local = Settings(data_dir=tmp_path)
    assert _scheme_seen(local, "127.0.0.1") == "https"
    assert _scheme_seen(local, "172.18.0.1") == "http"  # anyone else cannot claim https
    compose = yaml.safe_load((Path(__file__).resolve().parents[1] / "docker-compose.yml").read_text())
    proxies = compose["services"]["homebot"]["environment"]["HOMEBOT_FORWARDED_ALLOW_IPS"]
    docker = Settings(data_dir=tmp_path, forwarded_allow_ips=proxies)
    assert _scheme_seen(docker, "172.18.0.1") == "https"  # the host's proxy through Docker's gateway
    assert _scheme_seen(docker, "203.0.113.9") == "http"
