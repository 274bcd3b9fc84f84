"""The simulated robot as a virtual microcontroller on a pseudo-terminal.

:class:`VirtualMCU` owns a pty pair in raw mode. Its thread samples a wheel source's
cumulative encoder ticks at a fixed rate and writes ENCODER frames to the pty master;
velocity-command frames written by the host to the slave side are decoded and applied
to the wheel source. The host opens :attr:`VirtualMCU.path` (``/dev/pts/N``, or a symlink
of your choosing) with pyserial exactly as it would open ``/dev/ttyUSB0`` on a robot.

Like a UART without flow control, frames that do not fit into the pty's buffer (nobody
reading) are dropped and counted. :class:`LineFaults` corrupts the outgoing byte stream
(dropped bytes, flipped bits, random garbage) to test the host's decoder.
"""

from __future__ import annotations

import contextlib
import logging
import os
import select
import threading
import time
import tty
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from app.robot_link.protocol import (
    SEQ_MODULUS,
    TIME_MODULUS,
    TYPE_VELOCITY,
    EncoderFrame,
    FrameDecoder,
    encode,
    wrap_i32,
)

log = logging.getLogger(__name__)

DEFAULT_RATE_HZ = 50.0
READ_CHUNK = 4096
#: How long :meth:`VirtualMCU.power_cycle` keeps the MCU off by default (s).
POWER_OFF_S = 0.5


class WheelSource(Protocol):
    """What the virtual MCU drives: the simulator's robot (or a test's stand-in)."""

    def ticks(self) -> tuple[int, int]:
        """Cumulative (left, right) encoder counts."""

    def set_velocity(self, v: float, w: float) -> None:
        """Command body velocity ``v`` (m/s) and ``w`` (rad/s)."""


@dataclass
class LineFaults:
    """Random corruption of the MCU's outgoing bytes; ``rng`` makes it reproducible.

    ``drop_rate`` and ``flip_rate`` are per byte (a flip inverts one random bit);
    ``garbage_rate`` is the chance per frame of 1..``garbage_max`` random bytes before it.
    """

    rng: np.random.Generator
    drop_rate: float = 0.0
    flip_rate: float = 0.0
    garbage_rate: float = 0.0
    garbage_max: int = 16

    def __post_init__(self) -> None:
        for name in ("drop_rate", "flip_rate", "garbage_rate"):
            rate = getattr(self, name)
            if not 0.0 <= rate <= 1.0:
                raise ValueError(f"LineFaults.{name} must be a probability in [0, 1], got {rate!r}")
        if self.garbage_max < 1:
            raise ValueError(f"LineFaults.garbage_max must be at least 1, got {self.garbage_max!r}")

    def apply(self, data: bytes) -> bytes:
        """``data`` as it arrives after crossing the faulty line."""
        rng = self.rng
        arr = np.frombuffer(data, dtype=np.uint8).copy()
        flips = rng.random(arr.size) < self.flip_rate
        arr[flips] ^= (1 << rng.integers(0, 8, int(flips.sum()))).astype(np.uint8)
        arr = arr[rng.random(arr.size) >= self.drop_rate]
        out = arr.tobytes()
        if rng.random() < self.garbage_rate:
            out = rng.bytes(int(rng.integers(1, self.garbage_max + 1))) + out
        return out


@dataclass
class VirtualMCUStats:
    frames_sent: int = 0
    bytes_sent: int = 0
    bytes_dropped: int = 0  # did not fit into the pty buffer
    commands_applied: int = 0
    commands_refused: int = 0  # the wheel source raised on set_velocity
    tick_errors: int = 0  # the wheel source raised on ticks(); no frame sent
    watchdog_stops: int = 0
    power_cycles: int = 0


class VirtualMCU:
    """A wheel source behind a pty that speaks the robot-link protocol (see module doc).

    ``clock`` gives the MCU time in seconds (default: seconds since :meth:`start`);
    frames carry it as wrapping microseconds. When the wheel source runs on simulated time
    (faster or slower than the wall clock) pass the simulator's clock here, or the host
    will see wheels turning implausibly fast for the elapsed MCU time. With
    ``command_timeout`` (s) the MCU stops the wheels when no velocity command arrived for
    that long after the last one, as firmware should. ``link``, if given, is a symlink
    created to the slave device, so a restarted MCU can be found again under the same
    name (like ``/dev/serial/by-id``).
    """

    def __init__(
        self,
        wheels: WheelSource,
        rate_hz: float = DEFAULT_RATE_HZ,
        faults: LineFaults | None = None,
        clock=None,
        command_timeout: float | None = None,
        link: str | os.PathLike | None = None,
    ):
        if not rate_hz > 0:
            raise ValueError(f"rate_hz must be positive, got {rate_hz!r}")
        if command_timeout is not None and not command_timeout > 0:
            raise ValueError(f"command_timeout must be positive seconds or None, got {command_timeout!r}")
        self.wheels = wheels
        self.period = 1.0 / rate_hz
        self.faults = faults
        self.command_timeout = command_timeout
        self.link = os.fspath(link) if link is not None else None
        self.stats = VirtualMCUStats()
        self.decoder = FrameDecoder(accept={TYPE_VELOCITY})
        self._clock = clock
        self._seq = 0
        self._master = self._slave = -1
        self._slave_name = ""
        self._write_lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._power_back_at: float | None = None  # set by power_cycle(), read by the thread
        self._tick_origin = (0, 0)  # wheel ticks at the last power-up: the counters restart from 0
        self._clock_origin = 0.0

    @property
    def path(self) -> str:
        """The serial device path the host opens (the symlink if ``link`` was given)."""
        if not self._slave_name:
            raise RuntimeError("VirtualMCU has no device yet: call start() first")
        return self.link or self._slave_name

    @property
    def device(self) -> str:
        """The pty slave device itself (``/dev/pts/N``)."""
        return self._slave_name

    def start(self) -> VirtualMCU:
        if self._thread is not None:
            raise RuntimeError("VirtualMCU already started")
        self._master, self._slave = os.openpty()
        # Raw mode on the slave: no echo, no CR/LF translation, no signal characters.
        tty.setraw(self._slave)
        os.set_blocking(self._master, False)
        self._slave_name = os.ttyname(self._slave)
        if self.link is not None:
            tmp = f"{self.link}.{os.getpid()}.tmp"
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)
            os.symlink(self._slave_name, tmp)
            os.replace(tmp, self.link)
        if self._clock is None:
            t0 = time.monotonic()
            self._clock = lambda: time.monotonic() - t0
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="virtual-mcu", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop the thread and close the pty (the host then sees the device vanish)."""
        if self._thread is None:
            return
        self._stop.set()
        self._thread.join()
        self._thread = None
        if self.link is not None:
            with contextlib.suppress(OSError):
                if os.readlink(self.link) == self._slave_name:
                    os.unlink(self.link)
        for fd in (self._master, self._slave):
            with contextlib.suppress(OSError):
                os.close(fd)
        self._master = self._slave = -1

    def __enter__(self) -> VirtualMCU:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    def power_cycle(self, off_s: float = POWER_OFF_S) -> None:
        """Cut the power for ``off_s`` seconds (tests): no frames and the wheels stop; then the MCU
        boots again with its encoder counters, clock and frame sequence back at 0."""
        self._power_back_at = time.monotonic() + off_s

    def _powered(self) -> bool:
        """False while the power is cut (wheels stopped, input dropped); reboots when it returns."""
        back_at = self._power_back_at
        if back_at is None:
            return True
        if time.monotonic() < back_at:
            self._apply(0.0, 0.0)
            with contextlib.suppress(BlockingIOError, OSError):
                os.read(self._master, READ_CHUNK)
            time.sleep(self.period)
            return False
        self._tick_origin = tuple(int(t) for t in self.wheels.ticks())
        self._clock_origin = self._clock()
        self._seq = 0
        self.decoder.reset()
        self.stats.power_cycles += 1
        self._power_back_at = None
        return True

    def inject(self, data: bytes) -> int:
        """Write raw bytes onto the line between frames (tests); return how many fitted."""
        return self._write(data)

    def _write(self, data: bytes) -> int:
        with self._write_lock:
            try:
                written = os.write(self._master, data)
            except BlockingIOError:
                written = 0
        self.stats.bytes_sent += written
        self.stats.bytes_dropped += len(data) - written
        return written

    def _send_encoder_frame(self) -> None:
        try:
            left, right = self.wheels.ticks()
        except Exception as exc:  # a broken reading skips one frame, as a sensor glitch would
            log.warning("virtual MCU: wheel source failed to give ticks: %s", exc)
            self.stats.tick_errors += 1
            return
        left, right = left - self._tick_origin[0], right - self._tick_origin[1]
        t_us = round((self._clock() - self._clock_origin) * 1e6) % TIME_MODULUS
        frame = encode(EncoderFrame(self._seq, t_us, wrap_i32(left), wrap_i32(right)))
        self._seq = (self._seq + 1) % SEQ_MODULUS
        if self.faults is not None:
            frame = self.faults.apply(frame)
        self._write(frame)
        self.stats.frames_sent += 1

    def _apply(self, v: float, w: float) -> bool:
        """Hand a command to the wheels; a wheel source that refuses it is logged, like firmware would."""
        try:
            self.wheels.set_velocity(v, w)
        except Exception as exc:  # the MCU thread must survive whatever the wheel source does
            log.warning("virtual MCU: wheel source refused velocity (%r, %r): %s", v, w, exc)
            self.stats.commands_refused += 1
            return False
        return True

    def _run(self) -> None:
        next_send = time.monotonic()
        last_command = None
        while not self._stop.is_set():
            if not self._powered():
                next_send, last_command = time.monotonic(), None
                continue
            now = time.monotonic()
            if now >= next_send:
                self._send_encoder_frame()
                next_send += self.period
                if next_send < now:  # fell behind: skip the missed slots rather than burst
                    next_send = now + self.period
            ready, _, _ = select.select([self._master], [], [], max(0.0, next_send - time.monotonic()))
            if ready:
                try:
                    data = os.read(self._master, READ_CHUNK)
                except (BlockingIOError, OSError):
                    data = b""
                for command in self.decoder.feed(data):
                    if self._apply(command.v, command.w):
                        self.stats.commands_applied += 1
                    last_command = time.monotonic()
            if (
                self.command_timeout is not None
                and last_command is not None
                and time.monotonic() - last_command > self.command_timeout
            ):
                self._apply(0.0, 0.0)
                self.stats.watchdog_stops += 1
                last_command = None
