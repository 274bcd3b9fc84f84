"""Thread-safe holders that grabbers publish into and workers read from."""

from __future__ import annotations

import threading
from collections import deque
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


class Backlog(Generic[T]):
    """The newest ``size`` values of a stream, numbered as :class:`Latest` numbers them.

    A reader a little slower than the writer, or one that meets a burst, still gets every
    value in order (:meth:`wait_after`); one more than ``size`` values behind misses the oldest.
    """

    def __init__(self, size: int) -> None:
        if size < 1:
            raise ValueError(f"a backlog holds at least one value, got {size}")
        self._cond = threading.Condition()
        self._seq = 0
        self._held: deque[tuple[int, T]] = deque(maxlen=size)

    def put(self, value: T) -> int:
        """Add ``value``; return its sequence number (1, 2, ...)."""
        with self._cond:
            self._seq += 1
            self._held.append((self._seq, value))
            self._cond.notify_all()
            return self._seq

    def get(self) -> tuple[int, T | None]:
        """``(seq, value)`` of the newest value; ``(0, None)`` before the first ``put``."""
        with self._cond:
            return self._held[-1] if self._held else (0, None)

    def wait_after(self, seq: int, timeout: float | None = None) -> list[tuple[int, T]]:
        """The values still held that are newer than ``seq``, oldest first; after waiting up to
        ``timeout`` for one when there is none (then the list is empty)."""
        with self._cond:
            self._cond.wait_for(lambda: self._seq > seq, timeout)
            return [item for item in self._held if item[0] > seq]


class Fanout:
    """Puts every value into each of ``outputs`` (anything with ``put``), in order."""

    def __init__(self, *outputs) -> None:
        self.outputs = outputs

    def put(self, value) -> None:
        for output in self.outputs:
            output.put(value)
