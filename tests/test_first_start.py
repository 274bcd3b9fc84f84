"""The first start: the URL is printed once the page answers; the warm-up is announced with progress."""

from __future__ import annotations

import re
import threading
import time

import httpx

from app.worker.estimators import WARM_UP_STAGES
from tests.live_server import START_TIMEOUT_S, LiveServer

LAST_STAGE = f"preparing the estimator {len(WARM_UP_STAGES)}/{len(WARM_UP_STAGES)}"


def test_the_printed_url_answers_at_once_and_the_warm_up_is_announced(tmp_path):
    server = LiveServer(tmp_path / "data").launch()
    lines: list[str] = []
    answered: list[int] = []

    def read_console() -> None:
        for line in server.proc.stdout:
            lines.append(line)
            link = re.search(r"open (http://\S+)", line)
            if link:  # the moment it is printed, the page must answer
                answered.append(httpx.get(link.group(1), timeout=10).status_code)
            if answered and any(LAST_STAGE in seen for seen in lines):
                return

    reader = threading.Thread(target=read_console, daemon=True)
    reader.start()
    try:
        reader.join(START_TIMEOUT_S)
        assert answered == [200], lines
        starting = next(i for i, line in enumerate(lines) if "starting" in line)
        link = next(i for i, line in enumerate(lines) if "open http" in line)
        assert starting < link
        for done in range(1, len(WARM_UP_STAGES) + 1):
            assert any(f"preparing the estimator {done}/{len(WARM_UP_STAGES)}" in line for line in lines)
        deadline = time.monotonic() + 60
        while server.status()["preparing"] is not None and time.monotonic() < deadline:
            time.sleep(0.2)
        assert server.status()["preparing"] is None  # warmed up: the dashboard stops saying so
    finally:
        server.stop()
    assert "leaked" not in server.output  # a clean stop unlinks every semaphore and shared block
