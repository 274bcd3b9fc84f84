"""The binary frame protocol between the robot's microcontroller (MCU) and homebot.

Every frame, in both directions, is laid out as (all multi-byte fields little-endian)::

    offset  size  field
    0       2     SYNC      0xAA 0x55
    2       1     TYPE      frame type (table below)
    3       1     LEN       payload length in bytes (0..MAX_PAYLOAD)
    4       LEN   PAYLOAD
    4+LEN   2     CRC       CRC-16/CCITT-FALSE over TYPE, LEN and PAYLOAD (not SYNC)

CRC-16/CCITT-FALSE: polynomial 0x1021, initial value 0xFFFF, no reflection, no final
XOR; ``crc16(b"123456789") == 0x29B1``.

Frame types::

    TYPE  dir         LEN  payload
    0x01  MCU -> host  14  ENCODER: seq u16, t_us u32, left i32, right i32
    0x81  host -> MCU  10  VELOCITY: seq u16, v f32 (m/s, forward), w f32 (rad/s, CCW)

* ``seq`` counts frames of that type, +1 per frame, wrapping 65535 -> 0.
* ``t_us`` is the MCU's clock in microseconds when the ticks were sampled, wrapping at 2**32.
* ``left``/``right`` are cumulative encoder counts since MCU start, two's-complement 32-bit
  (they wrap too); forward wheel motion counts up.
* ``v``/``w`` are IEEE-754 single floats: the body's linear and angular velocity (REP-103);
  the MCU turns them into wheel speeds ``v -+ w * wheel_base / 2``.

:class:`FrameDecoder` is fed arbitrary chunks of bytes and returns the frames they
complete. It never raises on bad input: garbled, truncated, oversized, wrong-length,
unknown-type and stale (duplicate or out-of-order sequence number) frames are counted per
reason and skipped, and after any rejected candidate it resumes the search one byte after
that candidate's SYNC, so an intact frame hidden behind garbage is still found.
``PROTOCOL.md`` next to this module is the same specification for firmware authors.
"""

from __future__ import annotations

import math
import struct
from collections import Counter
from dataclasses import dataclass, field, replace

SYNC = b"\xaa\x55"
HEADER_SIZE = 4  # SYNC, TYPE, LEN
CRC_SIZE = 2
MAX_PAYLOAD = 32

TYPE_ENCODER = 0x01
TYPE_VELOCITY = 0x81

_ENCODER = struct.Struct("<HIii")
_VELOCITY = struct.Struct("<Hff")
_CRC = struct.Struct("<H")
PAYLOAD_SIZES = {TYPE_ENCODER: _ENCODER.size, TYPE_VELOCITY: _VELOCITY.size}

SEQ_MODULUS = 1 << 16
TIME_MODULUS = 1 << 32
TICK_MODULUS = 1 << 32

#: After this many consecutive stale sequence numbers of one type the sender is taken to
#: have restarted (an MCU reset starts again at seq 0) and the next frame is accepted.
STALE_BEFORE_RESTART = 8

#: Reasons a candidate frame is rejected, as counted in :attr:`DecoderStats.rejected`.
REJECT_REASONS = (
    "bad_crc",  # frame complete but CRC mismatch (bit errors)
    "truncated",  # CRC mismatch and another SYNC inside the frame: cut short by the next frame
    "oversized",  # LEN above MAX_PAYLOAD
    "bad_length",  # LEN differs from the fixed payload size of TYPE
    "unknown_type",  # TYPE not in the protocol (or not accepted by this decoder)
    "invalid_payload",  # CRC ok but a field is unusable (non-finite velocity)
    "duplicate",  # same seq as the last accepted frame of that type
    "out_of_order",  # seq older than the last accepted frame of that type
)


def _crc16_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else (crc << 1)
        table.append(crc & 0xFFFF)
    return tuple(table)


_CRC_TABLE = _crc16_table()


def crc16(data: bytes | bytearray | memoryview, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE of ``data`` (table-driven, MSB first); ``crc`` continues a running value."""
    table = _CRC_TABLE
    for byte in bytes(data):
        crc = ((crc << 8) & 0xFFFF) ^ table[(crc >> 8) ^ byte]
    return crc


@dataclass(frozen=True)
class EncoderFrame:
    """MCU -> host: cumulative wheel encoder counts sampled at MCU time ``t_us``."""

    seq: int
    t_us: int
    left: int
    right: int

    frame_type = TYPE_ENCODER


@dataclass(frozen=True)
class VelocityCommand:
    """Host -> MCU: body velocity ``v`` (m/s) and ``w`` (rad/s, CCW positive)."""

    seq: int
    v: float
    w: float

    frame_type = TYPE_VELOCITY


Frame = EncoderFrame | VelocityCommand


def wrap_i32(value: int) -> int:
    """``value`` as the two's-complement signed 32-bit integer it would be on the MCU."""
    return ((int(value) + (1 << 31)) % TICK_MODULUS) - (1 << 31)


def _check_range(name: str, value, low: int, high: int) -> None:
    if not isinstance(value, int) or not low <= value <= high:
        raise ValueError(f"{name}={value!r} is outside the protocol's range [{low}, {high}]")


def encode_payload(frame: Frame) -> bytes:
    """The payload bytes of ``frame``; raises ``ValueError`` naming a field out of range."""
    _check_range("seq", frame.seq, 0, SEQ_MODULUS - 1)
    if isinstance(frame, EncoderFrame):
        _check_range("t_us", frame.t_us, 0, TIME_MODULUS - 1)
        _check_range("left", frame.left, -(1 << 31), (1 << 31) - 1)
        _check_range("right", frame.right, -(1 << 31), (1 << 31) - 1)
        return _ENCODER.pack(frame.seq, frame.t_us, frame.left, frame.right)
    if isinstance(frame, VelocityCommand):
        for name, value in (("v", frame.v), ("w", frame.w)):
            if not math.isfinite(value):
                raise ValueError(f"velocity command {name}={value!r} is not a finite number")
        return _VELOCITY.pack(frame.seq, frame.v, frame.w)
    raise ValueError(f"cannot encode {type(frame).__name__}: not a protocol frame")


def encode(frame: Frame) -> bytes:
    """The complete wire bytes of ``frame`` (SYNC, TYPE, LEN, PAYLOAD, CRC)."""
    payload = encode_payload(frame)
    body = bytes((frame.frame_type, len(payload))) + payload
    return SYNC + body + _CRC.pack(crc16(body))


def decode_payload(frame_type: int, payload: bytes) -> Frame | None:
    """The frame a CRC-checked payload carries, or ``None`` if a field is unusable."""
    if frame_type == TYPE_ENCODER:
        return EncoderFrame(*_ENCODER.unpack(payload))
    seq, v, w = _VELOCITY.unpack(payload)
    if not (math.isfinite(v) and math.isfinite(w)):
        return None
    return VelocityCommand(seq, v, w)


def seq_distance(new: int, last: int) -> int:
    """How far ``new`` is ahead of ``last`` in wrapping 16-bit serial arithmetic (RFC 1982).

    Positive: newer; 0: the same; negative: older.
    """
    d = (new - last) % SEQ_MODULUS
    return d - SEQ_MODULUS if d >= SEQ_MODULUS // 2 else d


@dataclass
class DecoderStats:
    """What the decoder has seen; ``bytes_in == bytes_in_frames + bytes_skipped + pending``."""

    frames: int = 0  # frames returned
    rejected: Counter = field(default_factory=Counter)  # reason -> count
    bytes_in: int = 0
    bytes_in_frames: int = 0  # bytes of CRC-valid frames (returned or rejected by seq)
    bytes_skipped: int = 0  # garbage and bytes of rejected candidates
    seq_gaps: int = 0  # frames missing between accepted sequence numbers
    stream_restarts: int = 0  # sender restarts detected from sequence numbers

    def snapshot(self) -> DecoderStats:
        """A copy that later decoding does not change."""
        return replace(self, rejected=Counter(self.rejected))


class FrameDecoder:
    """Incremental, resynchronising decoder: ``feed(chunk)`` returns the frames completed.

    ``accept`` limits the frame types returned (others count as ``unknown_type``), e.g.
    ``{TYPE_ENCODER}`` on the host. With ``check_sequence`` (default) a frame whose
    sequence number is not newer than the last accepted one of its type is rejected as
    ``duplicate`` or ``out_of_order``; after :data:`STALE_BEFORE_RESTART` stale frames in a
    row the sender is taken to have restarted.
    """

    def __init__(self, accept=None, check_sequence: bool = True):
        self.accept = frozenset(PAYLOAD_SIZES if accept is None else accept)
        unknown = self.accept - set(PAYLOAD_SIZES)
        if unknown:
            raise ValueError(f"accept lists frame types the protocol does not define: {sorted(unknown)}")
        self.check_sequence = check_sequence
        self.stats = DecoderStats()
        self._buf = bytearray()
        self._last_seq: dict[int, int] = {}
        self._stale_run: dict[int, int] = {}

    @property
    def pending(self) -> int:
        """Bytes held back waiting for the rest of a possible frame."""
        return len(self._buf)

    def reset(self) -> None:
        """Forget buffered bytes and sequence history (a new connection); keep the counters."""
        self.stats.bytes_skipped += len(self._buf)
        self._buf.clear()
        self._last_seq.clear()
        self._stale_run.clear()

    def feed(self, data: bytes | bytearray | memoryview) -> list[Frame]:
        """Consume ``data``; return the valid, in-sequence frames it completed, in order."""
        buf = self._buf
        buf += data
        self.stats.bytes_in += len(data)
        out: list[Frame] = []
        pos = 0
        n = len(buf)
        while True:
            start = buf.find(SYNC, pos)
            if start < 0:
                # Keep a trailing first SYNC byte: its partner may come in the next chunk.
                keep = 1 if pos < n and buf[-1] == SYNC[0] else 0
                self.stats.bytes_skipped += n - keep - pos
                pos = n - keep
                break
            self.stats.bytes_skipped += start - pos
            pos = start
            if n - pos < HEADER_SIZE:
                break
            frame_type, length = buf[pos + 2], buf[pos + 3]
            reason = self._header_problem(frame_type, length)
            if reason is not None:
                self._reject(reason)
                pos += 1
                continue
            end = pos + HEADER_SIZE + length + CRC_SIZE
            if end > n:
                break
            body = buf[pos + 2 : end - CRC_SIZE]
            if crc16(body) != _CRC.unpack_from(buf, end - CRC_SIZE)[0]:
                cut_short = buf.find(SYNC, pos + 1, end) >= 0
                self._reject("truncated" if cut_short else "bad_crc")
                pos += 1
                continue
            frame = decode_payload(frame_type, bytes(body[2:]))
            if frame is None:
                self._reject("invalid_payload")
                pos += 1
                continue
            self.stats.bytes_in_frames += end - pos
            pos = end
            if self._in_sequence(frame):
                self.stats.frames += 1
                out.append(frame)
        del buf[:pos]
        return out

    def _header_problem(self, frame_type: int, length: int) -> str | None:
        if frame_type not in self.accept:
            return "unknown_type"
        if length > MAX_PAYLOAD:
            return "oversized"
        if length != PAYLOAD_SIZES[frame_type]:
            return "bad_length"
        return None

    def _reject(self, reason: str) -> None:
        """Count a rejected candidate and skip its first byte (the caller resumes after it)."""
        self.stats.rejected[reason] += 1
        self.stats.bytes_skipped += 1

    def _in_sequence(self, frame: Frame) -> bool:
        kind = frame.frame_type
        last = self._last_seq.get(kind)
        if self.check_sequence and last is not None:
            d = seq_distance(frame.seq, last)
            if d <= 0:
                run = self._stale_run.get(kind, 0) + 1
                if run <= STALE_BEFORE_RESTART:
                    self._stale_run[kind] = run
                    self.stats.rejected["duplicate" if d == 0 else "out_of_order"] += 1
                    return False
                self.stats.stream_restarts += 1
            else:
                self.stats.seq_gaps += d - 1
        self._stale_run[kind] = 0
        self._last_seq[kind] = frame.seq
        return True
