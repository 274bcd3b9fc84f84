"""The odometry grabber: wheel-encoder frames from a serial port to published odometry poses.

A thread opens the port with pyserial (a robot's ``/dev/ttyUSB0`` or the simulator's
:class:`~app.robot_link.virtual_mcu.VirtualMCU` pty), feeds the bytes to the protocol's
:class:`~app.robot_link.protocol.FrameDecoder`, integrates each ENCODER frame with
:class:`~slam_core.sensors.wheel_odometry.OdometryIntegrator` and publishes the newest
:class:`Odometry` into a :class:`~app.grabbers.shared.Latest`. :meth:`send_velocity`
writes VELOCITY frames back. If the device vanishes (cable pulled, MCU reset, simulator
restarted) the thread logs it and reopens the same path until it is back; odometry
continues from the last pose.
"""

from __future__ import annotations

import logging
import os
import select
import threading
import time
from collections import Counter
from dataclasses import dataclass, field

import numpy as np
import serial

from app.grabbers.odometry_history import OdometryHistory
from app.grabbers.shared import Latest
from app.robot_link.protocol import (
    SEQ_MODULUS,
    TYPE_ENCODER,
    EncoderFrame,
    FrameDecoder,
    VelocityCommand,
    encode,
)
from slam_core.robot_config import robot_from
from slam_core.sensors.wheel_odometry import DiffDriveGeometry, OdometryIntegrator

log = logging.getLogger(__name__)

DEFAULT_BAUDRATE = 115200
READ_TIMEOUT = 0.05  # s; also bounds how long stop() waits
RECONNECT_DELAY = 0.2  # s between attempts to reopen a vanished device
WRITE_TIMEOUT = 0.1  # s; a command that cannot be written by then is dropped and counted


def write_within(port: serial.Serial, data: bytes, timeout: float) -> None:
    """Write all of ``data`` to ``port``, waiting up to ``timeout`` (s) in all for it to take more when
    its buffer is full; ``SerialTimeoutException`` only when part of ``data`` was not taken.

    pyserial's own write timeout also runs out when the writing thread was merely held up after the
    bytes had gone out (waiting for the GIL behind another thread's long call, or for a core on a
    busy machine), and then reports a frame that was sent as failed."""
    deadline = time.monotonic() + timeout
    left = memoryview(data)
    while left:
        try:
            sent = os.write(port.fileno(), left)  # the port is non-blocking
        except BlockingIOError:
            sent = 0
        left = left[sent:]
        if left and not sent:  # the port's buffer is full: wait for room
            wait = deadline - time.monotonic()
            if wait <= 0 or not select.select([], [port.fileno()], [], wait)[1]:
                raise serial.SerialTimeoutException(
                    f"write timeout: {len(left)} of {len(data)} bytes not taken")


@dataclass(frozen=True)
class Odometry:
    """One odometry reading: the raw wheel-odometry pose and when it was taken."""

    pose: np.ndarray  # (x, y, theta) in the odometry frame
    stamp: float  # host clock (``clock``) when the frame arrived, seconds
    mcu_time: float  # MCU seconds since the grabber's first frame (unwrapped)
    mcu_us: int  # the frame's raw MCU timestamp (wrapping microseconds)
    seq: int  # the frame's sequence number
    ticks: tuple[int, int]  # cumulative (left, right) encoder counts


@dataclass(frozen=True)
class OdometryGrabberStats:
    connected: bool
    connects: int
    disconnects: int
    frames_ok: int
    rejected: dict = field(default_factory=dict)  # protocol reason -> count (see REJECT_REASONS)
    bytes_skipped: int = 0
    seq_gaps: int = 0
    stream_restarts: int = 0
    odometry_published: int = 0
    odometry_jumps_rejected: int = 0  # implausible tick deltas, skipped
    odometry_time_gaps: int = 0  # MCU clock stepped back or jumped, chain re-baselined
    commands_sent: int = 0
    commands_failed: int = 0  # not connected or write error


class OdometryGrabber:
    """Reads wheel encoders over a serial line in a thread; see the module docstring.

    ``output`` is the :class:`Latest` (or :class:`~app.grabbers.odometry_history.OdometryHistory`)
    to publish into (a new ``Latest`` by default, available as :attr:`odometry`); ``clock``
    stamps readings on arrival (default ``time.time``). ``geometry`` and ``max_wheel_speed`` (m/s,
    beyond which a reading is corrupt) come from the robot file; by default the simulated robot's.
    """

    def __init__(
        self,
        port: str,
        baudrate: int = DEFAULT_BAUDRATE,
        geometry: DiffDriveGeometry | None = None,
        max_wheel_speed: float | None = None,
        output: Latest[Odometry] | OdometryHistory | None = None,
        clock=time.time,
        read_timeout: float = READ_TIMEOUT,
        reconnect_delay: float = RECONNECT_DELAY,
    ):
        self.port = port
        self.baudrate = baudrate
        self.geometry = geometry or robot_from(None).wheels
        self.odometry = output if output is not None else Latest()
        if max_wheel_speed is None:
            max_wheel_speed = robot_from(None).max_wheel_speed
        self.integrator = OdometryIntegrator(self.geometry, max_wheel_speed)
        self.decoder = FrameDecoder(accept={TYPE_ENCODER})
        self._clock = clock
        self._read_timeout = read_timeout
        self._reconnect_delay = reconnect_delay
        self._serial: serial.Serial | None = None
        self._lock = threading.Lock()  # guards the decoder, the integrator and the counters
        self._write_lock = threading.Lock()  # guards _serial and the command sequence number
        self._connected = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._command_seq = 0
        self._counts = Counter()

    # -- lifecycle -------------------------------------------------------------------------
    def start(self) -> OdometryGrabber:
        if self._thread is not None:
            raise RuntimeError("OdometryGrabber already started")
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name=f"odometry-grabber {self.port}", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        if self._thread is None:
            return
        self._stop.set()
        self._thread.join()
        self._thread = None

    def __enter__(self) -> OdometryGrabber:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    def wait_connected(self, timeout: float | None = None) -> bool:
        """Block until the port is open; False on timeout."""
        return self._connected.wait(timeout)

    # -- commands --------------------------------------------------------------------------
    def send_velocity(self, v: float, w: float) -> bool:
        """Send body velocity ``v`` (m/s), ``w`` (rad/s) to the MCU; False if it could not be sent."""
        with self._write_lock:
            seq = self._command_seq
            frame = encode(VelocityCommand(seq, float(v), float(w)))  # ValueError if not finite
            self._command_seq = (seq + 1) % SEQ_MODULUS
            port = self._serial
            ok = False
            if port is not None:
                try:
                    write_within(port, frame, WRITE_TIMEOUT)
                    ok = True
                except (serial.SerialException, OSError) as exc:
                    log.warning("odometry grabber: velocity command to %s failed: %s", self.port, exc)
        with self._lock:
            self._counts["commands_sent" if ok else "commands_failed"] += 1
        return ok

    # -- counters --------------------------------------------------------------------------
    def stats(self) -> OdometryGrabberStats:
        with self._lock:
            d = self.decoder.stats.snapshot()
            c = Counter(self._counts)
            integ = self.integrator
            return OdometryGrabberStats(
                connected=self._connected.is_set(),
                connects=c["connects"],
                disconnects=c["disconnects"],
                frames_ok=d.frames,
                rejected=dict(d.rejected),
                bytes_skipped=d.bytes_skipped,
                seq_gaps=d.seq_gaps,
                stream_restarts=d.stream_restarts,
                odometry_published=c["published"],
                odometry_jumps_rejected=integ.jumps_rejected,
                odometry_time_gaps=integ.time_gaps,
                commands_sent=c["commands_sent"],
                commands_failed=c["commands_failed"],
            )

    # -- the thread ------------------------------------------------------------------------
    def _open(self) -> serial.Serial | None:
        try:
            return serial.Serial(self.port, self.baudrate, timeout=self._read_timeout)
        except (serial.SerialException, OSError, ValueError) as exc:
            if not self._counts["open_failures"]:
                log.warning("odometry grabber: cannot open %s (%s); retrying", self.port, exc)
            self._counts["open_failures"] += 1
            return None

    def _run(self) -> None:
        while not self._stop.is_set():
            port = self._open()
            if port is None:
                self._stop.wait(self._reconnect_delay)
                continue
            with self._lock:
                self.decoder.reset()  # a new byte stream: no half frame, no sequence history
                self._counts["connects"] += 1
                self._counts["open_failures"] = 0
            with self._write_lock:
                self._serial = port
            self._connected.set()
            log.info("odometry grabber: reading %s at %d baud", self.port, self.baudrate)
            try:
                self._read_until_stopped(port)
            except (serial.SerialException, OSError) as exc:
                log.warning("odometry grabber: lost %s (%s); reconnecting", self.port, exc)
                with self._lock:
                    self._counts["disconnects"] += 1
            finally:
                self._connected.clear()
                with self._write_lock:
                    self._serial = None
                port.close()

    def _read_until_stopped(self, port: serial.Serial) -> None:
        while not self._stop.is_set():
            data = port.read(max(1, port.in_waiting))
            if not data:
                continue
            arrived, arrived_monotonic = self._clock(), time.monotonic()
            with self._lock:
                frames = self.decoder.feed(data)
            for frame in frames:
                self._handle(frame, arrived, arrived_monotonic)

    def _handle(self, frame: EncoderFrame, arrived: float, arrived_monotonic: float) -> None:
        integ = self.integrator
        with self._lock:
            moved = integ.update(frame.t_us, frame.left, frame.right, arrived_monotonic)
            if moved:
                self._counts["published"] += 1
            pose, mcu_time = integ.pose.copy(), integ.time
        if moved:
            ticks = (frame.left, frame.right)
            self.odometry.put(Odometry(pose, arrived, mcu_time, frame.t_us, frame.seq, ticks))
