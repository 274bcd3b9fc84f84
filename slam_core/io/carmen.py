"""Streaming reader for CARMEN logs as published (plain, ``.bz2`` or ``.gz``).

Records come out in file order (timestamps that step backwards are kept as they
are). Supported messages: ``FLASER`` / ``RLASER`` (old and new forms),
``ROBOTLASER1``, ``ODOM`` and ``PARAM``; other CARMEN messages (``SYNC``,
``TRUEPOS``, ``RAWLASER*``, ``NMEA-*`` ...) are counted in :attr:`CarmenReader.skipped`.

Laser lines in the old form end after the six pose numbers plus ``ipc_timestamp``
and ``hostname``; the new form adds ``logger_timestamp``. ``FLASER`` carries no
angle information: by the datasets' convention the beams cover 180 degrees
starting at -90 degrees, in steps of ``180 / n`` degrees for an even count (180
beams: -90..+89) and ``180 / (n - 1)`` for an odd count (361 beams: -90..+90).
"""

from __future__ import annotations

import bz2
import gzip
import math
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

import numpy as np

from slam_core.geometry import relative, wrap_angle
from slam_core.io.read_ahead import ReadAhead
from slam_core.scan import Scan, uniform_angles

#: Largest pose or odometry value accepted (m, rad, m/s): larger ones are garbage, not travel.
MAX_POSE_VALUE = 1e6

#: Readings at or above this many metres mean "no return" in FLASER logs (81.83 / 81.91).
FLASER_NO_RETURN = 80.0
#: Readings below this are not measurements.
FLASER_RANGE_MIN = 0.01
#: Laser records read to tell a log's laser mount; how far (m, rad) their offsets may disagree.
MOUNT_RECORDS = 200
MOUNT_TOLERANCE = 1e-3

KNOWN_OTHER_MESSAGES = ("SYNC", "TRUEPOS", "RAWLASER", "ROBOTLASER0", "NMEA", "LASER",
                        "REMISSION", "GPS", "SONAR", "BUMPER", "IMU", "POSITIONLASER")


class LogFormatError(ValueError):
    """A log line that cannot be read; the message names file, line and problem."""

    def __init__(self, path, line_number: int, problem: str):
        super().__init__(f"{path}:{line_number}: {problem}")
        self.path = str(path)
        self.line_number = line_number
        self.problem = problem


class TruncatedLogError(LogFormatError):
    """The last line of the log is cut short; every record before it was delivered."""


@dataclass(frozen=True)
class Stamp:
    """Where a record came from: its ipc timestamp (float and exact text) and line."""

    ipc_time: float
    ipc_text: str
    line: int


@dataclass(frozen=True)
class LaserRecord:
    """A laser scan with the poses the log gives for it.

    ``pose`` is the laser's pose (``x y theta`` of the line), ``odom`` the raw
    odometry pose of the robot. ``kind`` is the message name.
    """

    kind: str
    scan: Scan
    pose: np.ndarray
    odom: np.ndarray
    stamp: Stamp


@dataclass(frozen=True)
class OdomRecord:
    """An odometry pose with translational / rotational velocity."""

    pose: np.ndarray
    tv: float
    rv: float
    stamp: Stamp


@dataclass(frozen=True)
class ParamRecord:
    name: str
    value: str
    line: int


def open_log(path) -> BinaryIO:
    """Open a log for binary reading, decompressing ``.bz2`` and ``.gz`` by their suffix."""
    path = Path(path)
    if path.suffix == ".bz2":
        return bz2.open(path, "rb")
    if path.suffix == ".gz":
        return gzip.open(path, "rb")
    return open(path, "rb")


def flaser_angles(n: int) -> np.ndarray:
    """Beam bearings of an ``n``-beam FLASER line under the datasets' 180-degree convention.

    An odd count is symmetric about straight ahead, so a single beam points at 0.
    """
    if n == 1:
        return np.zeros(1)
    step = math.pi / n if n % 2 == 0 else math.pi / (n - 1)
    return uniform_angles(n, -math.pi / 2, step)


class CarmenReader:
    """Iterate over the records of one log: ``for rec in CarmenReader(path): ...``.

    ``progress`` (optional) is called with the fraction of the file read so far.
    """

    def __init__(self, path, no_return: float = FLASER_NO_RETURN,
                 range_min: float = FLASER_RANGE_MIN, progress=None):
        self.path = Path(path)
        self.no_return = no_return
        self.range_min = range_min
        self.progress = progress
        self.skipped: Counter[str] = Counter()
        #: One bearings array per beam count (FLASER) or (count, start, step) (ROBOTLASER1), shared
        #: by every scan that has it: a log's scans are held to its end.
        self._angles: dict[tuple, np.ndarray] = {}

    def __iter__(self) -> Iterator[LaserRecord | OdomRecord | ParamRecord]:
        size = max(self.path.stat().st_size, 1)
        with open(self.path, "rb") as raw:
            lines = ReadAhead(_decompressing(raw, self.path), raw)
            line_number = 0
            pending = None
            try:
                for line_bytes in lines:
                    line_number += 1
                    if pending is not None:
                        yield pending
                    pending = self._parse_checked(line_bytes, line_number)
                    if self.progress is not None and line_number % 2000 == 0:
                        self.progress(min(lines.position / size, 1.0))
            except EOFError as exc:
                if pending is not None:
                    yield pending
                raise TruncatedLogError(self.path, line_number + 1,
                                        f"compressed stream ends early ({exc})") from exc
            except OSError as exc:  # not compressed as the suffix says, or corrupt
                if pending is not None:
                    yield pending
                raise LogFormatError(self.path, line_number + 1, f"cannot decompress ({exc})") from exc
            finally:
                lines.close()  # before the file closes under its thread
            if pending is not None:
                yield pending
            if self.progress is not None:
                self.progress(1.0)

    def _parse_checked(self, line_bytes: bytes, line_number: int):
        try:
            text = line_bytes.decode("ascii")
        except UnicodeDecodeError as exc:
            raise LogFormatError(self.path, line_number, f"non-ASCII bytes ({exc.reason})") from exc
        try:
            return self._parse(text.split(), line_number)
        except LogFormatError as exc:
            if not text.endswith("\n"):
                raise TruncatedLogError(self.path, line_number,
                                        f"last line is cut short: {exc.problem}") from exc
            raise

    def _parse(self, fields: list[str], line_number: int):
        if not fields or fields[0].startswith("#"):
            return None
        kind = fields[0]
        if kind in ("FLASER", "RLASER"):
            return self._laser(kind, fields, line_number)
        if kind == "ROBOTLASER1":
            return self._robotlaser(fields, line_number)
        if kind == "ODOM":
            return self._odom(fields, line_number)
        if kind == "PARAM":
            if len(fields) < 3:
                raise LogFormatError(self.path, line_number, "PARAM needs a name and a value")
            return ParamRecord(fields[1], fields[2], line_number)
        if kind.startswith(KNOWN_OTHER_MESSAGES) or kind.isupper():
            self.skipped[kind] += 1
            return None
        raise LogFormatError(self.path, line_number, f"unknown message {kind!r}")

    def _numbers(self, fields, start, count, line_number, what, finite=False):
        if len(fields) < start + count:
            raise LogFormatError(self.path, line_number,
                                 f"{what}: expected {count} numbers from field {start + 1}, "
                                 f"line has {len(fields)} fields")
        try:
            values = np.array(fields[start:start + count], dtype=np.float64)
        except ValueError as exc:
            raise LogFormatError(self.path, line_number, f"{what}: {exc}") from exc
        if finite and not np.isfinite(values).all():
            text = " ".join(fields[start:start + count])
            raise LogFormatError(self.path, line_number, f"{what}: not finite ({text})")
        if finite and np.abs(values).max() > MAX_POSE_VALUE:
            raise LogFormatError(self.path, line_number, f"{what}: a value beyond ±{MAX_POSE_VALUE:g} "
                                                         "(no robot travels that far)")
        return values

    def _stamp(self, fields, start, line_number, kind) -> Stamp:
        tail = fields[start:]
        if len(tail) not in (2, 3):
            raise LogFormatError(self.path, line_number,
                                 f"{kind}: expected 'ipc_timestamp hostname [logger_timestamp]' "
                                 f"after the data, found {len(tail)} fields")
        try:
            ipc = float(tail[0])
            if len(tail) == 3:
                float(tail[2])
        except ValueError as exc:
            raise LogFormatError(self.path, line_number, f"{kind}: bad timestamp ({exc})") from exc
        if not math.isfinite(ipc):
            raise LogFormatError(self.path, line_number, f"{kind}: timestamp is not finite")
        return Stamp(ipc, tail[0], line_number)

    def _count(self, fields, index, line_number, what, minimum=1) -> int:
        try:
            n = int(fields[index])
        except (IndexError, ValueError) as exc:
            raise LogFormatError(self.path, line_number, f"missing or bad {what}") from exc
        if n < minimum:
            raise LogFormatError(self.path, line_number, f"{what} must be at least {minimum}")
        return n

    def _laser(self, kind, fields, line_number) -> LaserRecord:
        n = self._count(fields, 1, line_number, f"{kind} beam count")
        if len(fields) not in (n + 10, n + 11) or not _is_number(fields[n + 8]):
            self._check_beam_count(kind, fields, n, line_number)
        ranges = self._numbers(fields, 2, n, line_number, f"{kind} ranges")
        poses = self._numbers(fields, 2 + n, 6, line_number, f"{kind} poses", finite=True)
        stamp = self._stamp(fields, 8 + n, line_number, kind)
        angles = self._angles.get((n,))
        if angles is None:
            angles = self._angles[(n,)] = flaser_angles(n)
        scan = Scan(angles, ranges, self.range_min, self.no_return, stamp.ipc_time)
        return LaserRecord(kind, scan, poses[:3], poses[3:], stamp)

    def _check_beam_count(self, kind, fields, n, line_number) -> None:
        """Name the problem of a laser line whose ranges do not line up with its beam count."""
        host = next((i for i in range(2, len(fields)) if not _is_number(fields[i])), None)
        if host is None:
            raise LogFormatError(self.path, line_number,
                                 f"{kind}: no 'ipc_timestamp hostname' after the {n} ranges and 6 pose "
                                 f"numbers (missing timestamp? the line has {len(fields)} fields)")
        numbers, expected = host - 2, n + 6 + 1
        if numbers == expected - 1:
            raise LogFormatError(self.path, line_number,
                                 f"{kind}: {numbers} numbers before the hostname, one short of {n} ranges "
                                 f"+ 6 pose numbers + ipc_timestamp (missing timestamp or too few ranges)")
        if numbers != expected:
            raise LogFormatError(self.path, line_number,
                                 f"{kind}: the beam count says {n} ranges but the line has {numbers - 7} "
                                 f"(too {'few' if numbers < expected else 'many'} ranges)")

    def _robotlaser(self, fields, line_number) -> LaserRecord:
        kind = "ROBOTLASER1"
        head = self._numbers(fields, 2, 5, line_number, f"{kind} header")
        start_angle, _fov, resolution, max_range, _accuracy = head
        n = self._count(fields, 8, line_number, f"{kind} beam count")
        ranges = self._numbers(fields, 9, n, line_number, f"{kind} ranges")
        n_rem = self._count(fields, 9 + n, line_number, f"{kind} remission count", minimum=0)
        at = 10 + n + n_rem
        poses = self._numbers(fields, at, 11, line_number, f"{kind} poses", finite=True)
        stamp = self._stamp(fields, at + 11, line_number, kind)
        angles = self._angles.get((n, start_angle, resolution))
        if angles is None:
            angles = self._angles[(n, start_angle, resolution)] = uniform_angles(n, start_angle, resolution)
        rmax = max_range if max_range > 0 else self.no_return
        scan = Scan(angles, ranges, self.range_min, rmax, stamp.ipc_time)
        return LaserRecord(kind, scan, poses[:3], poses[3:6], stamp)

    def _odom(self, fields, line_number) -> OdomRecord:
        values = self._numbers(fields, 1, 6, line_number, "ODOM", finite=True)
        stamp = self._stamp(fields, 7, line_number, "ODOM")
        return OdomRecord(values[:3], float(values[3]), float(values[4]), stamp)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _decompressing(raw: BinaryIO, path: Path):
    if path.suffix == ".bz2":
        return bz2.BZ2File(raw)
    if path.suffix == ".gz":
        return gzip.GzipFile(fileobj=raw)
    return raw


def laser_records(path, progress=None) -> Iterator[LaserRecord]:
    """Only the laser records of a log, in file order, each carrying its odometry."""
    for record in CarmenReader(path, progress=progress):
        if isinstance(record, LaserRecord):
            yield record


def laser_mount_of(path, records: int = MOUNT_RECORDS) -> np.ndarray | None:
    """The laser's pose in the robot frame, ``(x, y, theta)``, from a log's first laser records.

    Each laser line carries the laser's pose beside the robot's odometry pose; on a log
    that records the mount both differ by the same offset on every line. ``None`` when
    the offsets disagree (a log whose laser pose was corrected by some estimator), so
    the laser pose says nothing about the mount.
    """
    offsets = []
    try:
        for record in laser_records(path):
            offsets.append(relative(record.odom, record.pose))
            if len(offsets) >= records:
                break
    except TruncatedLogError:
        pass  # the records before the cut are all there is
    if not offsets:
        return None
    offsets = np.array(offsets)
    spread = offsets - offsets[0]
    spread[:, 2] = wrap_angle(spread[:, 2])
    if np.abs(spread).max() > MOUNT_TOLERANCE:
        return None
    return np.round(offsets[0], 6) + 0.0  # a micrometre: rounding noise is no mount (and no -0.0)
