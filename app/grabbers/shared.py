"""Thread-safe holders that grabbers publish into and workers read from."""

from __future__ import annotations

import threading
from typing import Generic, TypeVar

T = TypeVar("T")


class Latest(Generic[T]):
    """The newest value of a stream, with a sequence number that counts every ``put``.

    Readers never see a half-written value and never block a writer for long; a reader
    that is slower than the writer skips values (it only ever wants the newest one).
    ``seq`` is 0 before the first ``put``.
    """

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._seq = 0
        self._value: T | None = None

    def put(self, value: T) -> int:
        """Publish ``value``; return its sequence number (1, 2, ...)."""
        with self._cond:
            self._seq += 1
            self._value = value
            self._cond.notify_all()
            return self._seq

    def get(self) -> tuple[int, T | None]:
        """``(seq, value)`` of the newest value; ``(0, None)`` before the first ``put``."""
        with self._cond:
            return self._seq, self._value

    def wait_newer(self, seq: int, timeout: float | None = None) -> tuple[int, T] | None:
        """Wait until a value newer than ``seq`` is published; ``None`` on timeout."""
        with self._cond:
            if not self._cond.wait_for(lambda: self._seq > seq, timeout):
                return None
            return self._seq, self._value


class Fanout:
    """Puts every value into each of ``outputs`` (anything with ``put``), in order."""

    def __init__(self, *outputs) -> None:
        self.outputs = outputs

    def put(self, value) -> None:
        for output in self.outputs:
            output.put(value)
