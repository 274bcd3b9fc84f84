"""The first start: the URL is printed once the page answers; the warm-up is announced with progress;
on a fresh install a map grows while numba compiles, and the filter takes it over."""

from __future__ import annotations

import re
import threading
import time

import httpx

from app.worker.estimators import WARM_UP_STAGES
from tests.live_server import START_TIMEOUT_S, LiveServer, until
from tests.recovery_harness import agreement_with_truth, fetch_map, localized, pose_error

#: A fresh install compiles every kernel; on a busy machine that takes minutes.
COMPILE_TIMEOUT_S = 900.0

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


def test_a_fresh_install_shows_a_map_while_numba_compiles_and_the_filter_takes_it_over(tmp_path):
    """An empty numba cache: the preview map (drawn at the odometry's pose) is there before the
    warm-up ends and agrees with the true map; then the particle filter, having caught up on
    the scans, publishes a localized pose and a map that agree with the simulator's truth."""
    server = LiveServer(tmp_path / "data", env={"HOMEBOT_SIM_TOUR": "1",
                                                "NUMBA_CACHE_DIR": str(tmp_path / "numba-cache")}).launch()

    def status():
        try:
            return server.status()
        except (httpx.HTTPError, ValueError, OSError):
            return None

    try:
        preview = until(lambda: (s := status()) and s["map"] and s["pose"] and s["preparing"] and s,
                        COMPILE_TIMEOUT_S, "a map while the kernels compile")
        assert not preview["localized"]  # the odometry's pose, not a filter's
        agreement, cells = agreement_with_truth(fetch_map(server, tmp_path / "preview"))
        assert cells > 200 and agreement >= 0.95, (agreement, cells)

        until(lambda: (s := status()) and s["preparing"] is None and localized(s) and s["worker"]["steps"],
              COMPILE_TIMEOUT_S, "the filter's first localized pose")
        time.sleep(3.0)
        status_now = server.status()
        assert status_now["worker"]["restarts"] == 0
        assert pose_error(status_now) <= 0.1  # driving: pose and truth are sampled ~0.1 s apart
        agreement, cells = agreement_with_truth(fetch_map(server, tmp_path / "filter"))
        assert cells > 200 and agreement >= 0.98, (agreement, cells)
    finally:
        server.stop()
