"""A file's lines, read (and decompressed) by a thread ahead of the reader.

bz2 and zlib release the GIL while they decompress, so a compressed log read this way is
decompressed on another core while the reader's thread parses the lines it already has (intel:
about 1.5 s off the filter's thread). The parsing stays with the reader: it holds the GIL.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Iterator
from typing import BinaryIO

#: Decompressed bytes handed over at a time, and how many such chunks may wait ahead of the reader.
CHUNK = 1 << 20
CHUNKS_AHEAD = 4


class ReadAhead:
    """Iterate over the lines of ``stream`` (``raw``, or a decompressing file over it) as ``readline``
    gives them: each ending with its ``b"\\n"``, the last one as it is. An error of the stream
    (a truncated or corrupt file) is raised after every complete line before it.
    ``position`` is how far into ``raw`` the lines handed out so far were read from.
    :meth:`close` (called when the iteration ends or is abandoned) stops the thread, and must
    come before ``raw`` is closed."""

    def __init__(self, stream: BinaryIO, raw: BinaryIO):
        self.position = 0
        self._queue: queue.Queue = queue.Queue(CHUNKS_AHEAD)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._read, args=(stream, raw), name="read-ahead", daemon=True)
        self._thread.start()

    def __iter__(self) -> Iterator[bytes]:
        tail = b""
        try:
            while True:
                data, position = self._queue.get()
                if isinstance(data, BaseException):
                    raise data  # the cut line (``tail``) goes with it, as it does with readline
                if not data:
                    if tail:
                        yield tail
                    return
                self.position = position
                lines = (tail + data).split(b"\n")
                tail = lines.pop()
                for line in lines:
                    yield line + b"\n"
        finally:
            self.close()

    def close(self) -> None:
        self._stop.set()
        self._thread.join()

    def _read(self, stream: BinaryIO, raw: BinaryIO) -> None:
        while True:
            pieces, size, error = [], 0, None
            try:  # read1: what one read decompressed is kept when the next one fails
                while size < CHUNK and (piece := stream.read1(CHUNK - size)):
                    pieces.append(piece)
                    size += len(piece)
            except BaseException as exc:  # raised again in the reader's thread
                error = exc
            if pieces and not self._hand((b"".join(pieces), raw.tell())):
                return
            if error is not None or size < CHUNK:  # an error, or the end (an empty chunk)
                self._hand((error or b"", None))
                return

    def _hand(self, item: tuple) -> bool:
        """Queue ``item`` unless the reader stopped first (``False``)."""
        while not self._stop.is_set():
            try:
                self._queue.put(item, timeout=0.05)
                return True
            except queue.Full:
                continue
        return False
