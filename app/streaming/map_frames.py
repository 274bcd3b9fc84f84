"""Binary map frames (see PROTOCOL.md): a 44-byte header, then tiles of ``uint8`` cells.

Encoding works on :class:`~app.worker.shared_map.MapSnapshot`; decoding exists for
tests, the benchmark and any Python client.
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass

import numpy as np

from app.worker.shared_map import UNKNOWN, MapSnapshot, tile_count

MAP_MESSAGE = 1
FLAG_FULL = 1
FLAG_ZLIB = 2
HEADER = struct.Struct("<BBHIdddIII")
TILE_INDEX = np.dtype("<u4")
ZLIB_LEVEL = 1


def encode(snapshot: MapSnapshot, tile: int, tiles: np.ndarray | None = None, compress: bool = True) -> bytes:
    """A frame with the given tile indices, or every tile (a FULL frame) when ``tiles`` is None."""
    tx, ty = tile_count(snapshot.width, snapshot.height, tile)
    full = tiles is None
    idx = np.arange(tx * ty) if full else np.asarray(tiles, np.int64)
    padded = np.full((ty * tile, tx * tile), UNKNOWN, np.uint8)
    padded[: snapshot.height, : snapshot.width] = snapshot.cells
    blocks = padded.reshape(ty, tile, tx, tile).transpose(0, 2, 1, 3).reshape(tx * ty, tile * tile)
    records = np.empty(len(idx), dtype=[("index", TILE_INDEX), ("cells", np.uint8, tile * tile)])
    records["index"] = idx
    records["cells"] = blocks[idx]
    payload = records.tobytes()
    flags = FLAG_FULL if full else 0
    if compress:
        payload = zlib.compress(payload, ZLIB_LEVEL)
        flags |= FLAG_ZLIB
    header = HEADER.pack(MAP_MESSAGE, flags, tile, snapshot.seq & 0xFFFFFFFF, snapshot.resolution,
                         snapshot.origin[0], snapshot.origin[1], snapshot.width, snapshot.height, len(idx))
    return header + payload


@dataclass
class MapFrame:
    full: bool
    tile: int
    seq: int
    resolution: float
    origin: tuple[float, float]
    width: int
    height: int
    tiles: dict[int, np.ndarray]  # tile index -> (tile, tile) uint8


def decode(frame: bytes) -> MapFrame:
    """Parse a binary map frame; raises ``ValueError`` on anything malformed."""
    if len(frame) < HEADER.size:
        raise ValueError(f"map frame of {len(frame)} bytes is shorter than its {HEADER.size}-byte header")
    kind, flags, tile, seq, res, ox, oy, w, h, n = HEADER.unpack_from(frame)
    if kind != MAP_MESSAGE:
        raise ValueError(f"not a map frame (type {kind})")
    payload = frame[HEADER.size:]
    if flags & FLAG_ZLIB:
        payload = zlib.decompress(payload)
    size = 4 + tile * tile
    if len(payload) != n * size:
        raise ValueError(f"payload of {len(payload)} bytes does not hold {n} tiles of {size} bytes")
    records = np.frombuffer(payload, dtype=[("index", TILE_INDEX), ("cells", np.uint8, tile * tile)])
    tiles = {int(r["index"]): r["cells"].reshape(tile, tile) for r in records}
    return MapFrame(bool(flags & FLAG_FULL), tile, seq, res, (ox, oy), w, h, tiles)


class MapCanvas:
    """A client-side map rebuilt from frames (what the dashboard does, in numpy)."""

    def __init__(self):
        self.cells: np.ndarray | None = None
        self.frame: MapFrame | None = None

    def apply(self, frame: MapFrame) -> None:
        if frame.full:
            self.cells = np.full((frame.height, frame.width), UNKNOWN, np.uint8)
        elif self.cells is None or self.cells.shape != (frame.height, frame.width):
            raise ValueError("a delta frame arrived before a full frame of the same size")
        t = frame.tile
        tx, _ = tile_count(frame.width, frame.height, t)
        for i, block in frame.tiles.items():
            y0, x0 = (i // tx) * t, (i % tx) * t
            view = self.cells[y0:y0 + t, x0:x0 + t]
            view[...] = block[: view.shape[0], : view.shape[1]]
        self.frame = frame
