"""Events per second over a sliding window of the last few seconds: a steady figure to show."""

from __future__ import annotations

from collections import deque

#: Seconds of events a rate is averaged over.
RATE_WINDOW_S = 3.0


class SlidingRate:
    """Events per second among those of the last ``window_s`` seconds (0 once none is left)."""

    def __init__(self, window_s: float = RATE_WINDOW_S):
        self.window_s = window_s
        self._times: deque[float] = deque()

    def tick(self, now: float) -> None:
        self._times.append(now)
        self._drop_before(now - self.window_s)

    def rate(self, now: float) -> float:
        self._drop_before(now - self.window_s)
        t = self._times
        return (len(t) - 1) / (t[-1] - t[0]) if len(t) >= 2 and t[-1] > t[0] else 0.0

    def _drop_before(self, start: float) -> None:
        while self._times and self._times[0] < start:
            self._times.popleft()
