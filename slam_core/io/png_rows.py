"""An RGB PNG written a few rows at a time, byte for byte as Pillow's ``Image.save`` writes it.

Pillow (``libImaging/ZipEncode.c``) gives each row the filter with the least sum of absolute
(signed-byte) values, trying none, up, sub, then Paeth, each only if strictly better and the best so
far is not zero; deflates with zlib's default level, ``memLevel`` 9 and the ``Z_FILTERED`` strategy;
and writes the stream in IDAT chunks of ``max(65536, 4 * width)`` bytes. zlib's output does not
depend on how its input is split, so a picture too large to hold whole can be written by bands.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: Pillow's ``ImageFile.MAXBLOCK``: the least IDAT chunk.
MAX_BLOCK = 65536
#: Bytes filtered at a time (each takes some 20 bytes of temporaries).
FILTER_BYTES = 1 << 20
BPP = 3  # bytes a pixel
NONE, SUB, UP, PAETH = 0, 1, 2, 4


#: A byte's distance from zero, read as a signed byte.
DISTANCE = np.array([v if v < 128 else 256 - v for v in range(256)], np.uint8)


def _cost(filtered: np.ndarray) -> np.ndarray:
    """Each row's sum of the bytes' distances from zero."""
    return DISTANCE[filtered].sum(axis=1, dtype=np.int64)


def filtered_rows(rows: np.ndarray, previous: np.ndarray) -> np.ndarray:
    """``rows`` (``(k, n)`` bytes, after the row ``previous``) each led by its filter type and filtered
    as Pillow chooses."""
    above = np.vstack([previous[None], rows[:-1]])
    left = np.zeros_like(rows)
    left[:, BPP:] = rows[:, :-BPP]
    upper_left = np.zeros_like(rows)
    upper_left[:, BPP:] = above[:, :-BPP]
    a, b, c = left.astype(np.int16), above.astype(np.int16), upper_left.astype(np.int16)
    pa, pb, pc = np.abs(b - c), np.abs(a - c), np.abs(a + b - 2 * c)
    predictor = np.where((pa <= pb) & (pa <= pc), a, np.where(pb <= pc, b, c)).astype(np.uint8)
    choices = [(UP, rows - above), (SUB, rows - left), (PAETH, rows - predictor)]
    kind = np.full(len(rows), NONE, np.uint8)
    out = rows.copy()
    best = _cost(rows)
    for code, data in choices:
        better = (best > 0) & (_cost(data) < best)
        kind[better], out[better], best[better] = code, data[better], _cost(data[better])
    return np.column_stack([kind, out])


class PngRows:
    """``width`` x ``height`` RGB pixels to ``path``, given from the top row down by :meth:`write`."""

    def __init__(self, path, width: int, height: int):
        self.path, self.width, self.height = Path(path), width, height
        self.chunk = max(MAX_BLOCK, 4 * width)
        self.previous = np.zeros(BPP * width, np.uint8)
        self.deflate = zlib.compressobj(zlib.Z_DEFAULT_COMPRESSION, zlib.DEFLATED, 15, 9, zlib.Z_FILTERED)
        self.pending = bytearray()
        self.rows = 0
        self.file = None

    def __enter__(self) -> PngRows:
        self.file = open(self.path, "wb")
        self.file.write(SIGNATURE)
        self._put(b"IHDR", struct.pack(">IIBBBBB", self.width, self.height, 8, 2, 0, 0, 0))
        return self

    def write(self, pixels: np.ndarray) -> None:
        """The next rows: ``(k, width, 3)`` uint8."""
        rows = np.ascontiguousarray(pixels, np.uint8).reshape(len(pixels), BPP * self.width)
        step = max(1, FILTER_BYTES // max(rows.shape[1], 1))
        for first in range(0, len(rows), step):
            block = rows[first:first + step]
            self.pending += self.deflate.compress(filtered_rows(block, self.previous).tobytes())
            self.previous = block[-1].copy()
            self._put_full()
        self.rows += len(rows)

    def __exit__(self, kind, value, traceback) -> None:
        try:
            if kind is None:
                if self.rows != self.height:
                    raise ValueError(f"{self.rows} rows written of {self.height}")
                self.pending += self.deflate.flush()
                self._put_full()
                if self.pending:
                    self._put(b"IDAT", bytes(self.pending))
                self._put(b"IEND", b"")
        finally:
            self.file.close()

    def _put_full(self) -> None:
        while len(self.pending) >= self.chunk:
            self._put(b"IDAT", bytes(self.pending[:self.chunk]))
            del self.pending[:self.chunk]

    def _put(self, kind: bytes, data: bytes) -> None:
        self.file.write(struct.pack(">I", len(data)) + kind + data
                        + struct.pack(">I", zlib.crc32(data, zlib.crc32(kind))))
