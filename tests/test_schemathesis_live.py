"""schemathesis (every check, ~25 examples per operation, all phases) against a live
``homebot serve``: no 5xx, every status and body as the OpenAPI says, bad data refused, good
data accepted (see ``tests/schemathesis/schemathesis.toml`` for the one widened check)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tests.live_server import LiveServer

CONFIG = Path(__file__).resolve().parent / "schemathesis" / "schemathesis.toml"
RUN_TIMEOUT_S = 600


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    srv = LiveServer(tmp_path_factory.mktemp("schemathesis-data")).start()
    yield srv
    srv.stop()


def test_schemathesis_finds_no_failure(server, tmp_path):
    st = Path(sys.executable).with_name("st")
    run = subprocess.run(
        [str(st), "--config-file", str(CONFIG), "--no-color", "run", f"{server.base}/openapi.json",
         "--checks", "all", "--max-examples", "25", "--workers", "1", "--seed", "17",
         "--header", f"Authorization: Bearer {server.token}",
         "--exclude-path", "/api/shutdown",  # it stops the server (tested in test_server_persistence)
         "--request-timeout", "30", "--report-dir", str(tmp_path)],
        capture_output=True, text=True, timeout=RUN_TIMEOUT_S)
    summary = run.stdout[-6000:]
    assert run.returncode == 0, summary + run.stderr[-2000:]
    assert "Tested: " in summary and "failures" not in summary.split("SUMMARY")[-1].lower(), summary
