"""A per-client limit on failed logins (answered with 429 and ``Retry-After``)."""

from __future__ import annotations

import threading
import time
from collections import deque

#: Failed logins allowed per client within the window, and the window (s).
MAX_FAILED_LOGINS = 10
LOGIN_WINDOW_S = 60.0
#: Clients remembered at most; beyond that the idle ones are forgotten.
MAX_CLIENTS = 10_000


class LoginLimiter:
    """At most ``max_failures`` failed logins per client in a sliding ``window_s``."""

    def __init__(self, max_failures: int = MAX_FAILED_LOGINS, window_s: float = LOGIN_WINDOW_S):
        self.max_failures = max_failures
        self.window_s = window_s
        self._failures: dict[str, deque[float]] = {}
        self._lock = threading.Lock()

    def retry_after(self, client: str) -> float:
        """Seconds until ``client`` may try again (0 when it may now)."""
        now = time.monotonic()
        with self._lock:
            failures = self._failures.get(client)
            while failures and failures[0] <= now - self.window_s:
                failures.popleft()
            if not failures or len(failures) < self.max_failures:
                return 0.0
            return failures[0] + self.window_s - now

    def failed(self, client: str) -> None:
        now = time.monotonic()
        with self._lock:
            if len(self._failures) >= MAX_CLIENTS:
                recent = now - self.window_s
                self._failures = {c: f for c, f in self._failures.items() if f and f[-1] > recent}
            self._failures.setdefault(client, deque(maxlen=self.max_failures)).append(now)
