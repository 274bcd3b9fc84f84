"""Tell the person at the console when the server really answers, not before."""

from __future__ import annotations

import threading
import time
import urllib.error
import urllib.request

POLL_S = 0.2
PROBE_TIMEOUT_S = 2.0


def local_address(host: str) -> str:
    """Where this machine reaches a server listening on ``host`` (any-address binds included)."""
    return "127.0.0.1" if host in ("0.0.0.0", "", "::") else host


def answers(url: str) -> bool:
    try:
        with urllib.request.urlopen(url, timeout=PROBE_TIMEOUT_S) as response:
            return response.status == 200
    except (OSError, urllib.error.URLError, ValueError):
        return False


def announce_when_serving(host: str, port: int, lines: list[str], stop: threading.Event | None = None
                          ) -> threading.Thread:
    """Print ``lines`` once ``api/health`` answers on ``host:port`` (a daemon thread, returned started)."""
    probe = f"http://{local_address(host)}:{port}/api/health"
    stop = stop or threading.Event()

    def wait_and_print() -> None:
        while not stop.is_set() and not answers(probe):
            time.sleep(POLL_S)
        if not stop.is_set():
            for line in lines:
                print(line, flush=True)

    thread = threading.Thread(target=wait_and_print, name="announce", daemon=True)
    thread.start()
    return thread
