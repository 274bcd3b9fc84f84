"""The virtual MCU and the odometry grabber talking through a REAL pseudo-terminal with pyserial."""

from __future__ import annotations

import itertools
import os
import threading
import time

import numpy as np
import pytest
import serial

from app.grabbers.odometry_grabber import DEFAULT_BAUDRATE, WRITE_TIMEOUT, OdometryGrabber, write_within
from app.robot_link.protocol import wrap_i32
from app.robot_link.virtual_mcu import LineFaults, VirtualMCU
from slam_core.sensors.wheel_odometry import DiffDriveGeometry

GEOMETRY = DiffDriveGeometry(wheel_radius=0.035, wheel_base=0.23, ticks_per_rev=1440)
MAX_WHEEL_SPEED = 1.0
WAIT = 10.0  # s, generous limit for anything the threads must do


class ArcWheels:
    """Stands in for the simulator's robot: ideal wheels on simulated time.

    Every ``ticks()`` sample advances simulated time by ``DT`` at the commanded (v, w);
    counts start near the int32 limit so they wrap during the drive.
    """

    DT = 0.02

    def __init__(self, start=(2**31 - 150, -(2**31) + 40)):
        self._lock = threading.Lock()
        self.time = 0.0
        self.moving_time = 0.0
        self.v = self.w = 0.0
        self.s_left = self.s_right = 0.0
        self.start = start
        self.commands: list[tuple[float, float]] = []
        self.last_ticks = start

    def ticks(self) -> tuple[int, int]:
        with self._lock:
            self.time += self.DT
            if self.v or self.w:
                self.moving_time += self.DT
            half = 0.5 * self.w * GEOMETRY.wheel_base
            self.s_left += (self.v - half) * self.DT
            self.s_right += (self.v + half) * self.DT
            mpt = GEOMETRY.metres_per_tick
            self.last_ticks = (
                self.start[0] + round(self.s_left / mpt),
                self.start[1] + round(self.s_right / mpt),
            )
            return self.last_ticks

    def set_velocity(self, v: float, w: float) -> None:
        with self._lock:
            self.v, self.w = v, w
            self.commands.append((v, w))

    def clock(self) -> float:
        with self._lock:
            return self.time + 4294.9  # MCU microseconds wrap 2**32 shortly after start


def wait_until(predicate, what: str, timeout: float = WAIT) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.005)


def drive(grabber: OdometryGrabber, wheels: ArcWheels, v: float, w: float, seconds: float):
    """Command (v, w) through the grabber for ``seconds`` of simulated motion, stop, wait for odometry."""
    n = len(wheels.commands)
    assert grabber.send_velocity(v, w)
    wait_until(lambda: len(wheels.commands) > n, "the velocity command to reach the wheels")
    assert wheels.commands[n] == pytest.approx((v, w), rel=1e-6)  # float32 on the wire
    target = wheels.moving_time + seconds
    wait_until(lambda: wheels.moving_time >= target, "the drive")
    assert grabber.send_velocity(0.0, 0.0)
    wait_until(lambda: wheels.commands[-1] == (0.0, 0.0), "the stop command")
    final = tuple(wrap_i32(t) for t in wheels.last_ticks)

    def synced():
        odo = grabber.odometry.get()[1]
        return odo is not None and odo.ticks == tuple(wrap_i32(t) for t in wheels.last_ticks) == final

    wait_until(synced, "odometry of the final wheel position")
    return grabber.odometry.get()[1]


def analytic_arc(v: float, w: float, t: float) -> np.ndarray:
    th = w * t
    if w == 0:
        return np.array([v * t, 0.0, 0.0])
    return np.array([v / w * np.sin(th), v / w * (1 - np.cos(th)), np.arctan2(np.sin(th), np.cos(th))])


def assert_pose_close(pose, expected, pos_tol=2e-3, ang_tol=2e-3):
    assert np.hypot(*(pose[:2] - expected[:2])) < pos_tol, (pose, expected)
    assert abs(np.angle(np.exp(1j * (pose[2] - expected[2])))) < ang_tol, (pose, expected)


@pytest.fixture
def wheels():
    return ArcWheels()


def test_known_arc_over_a_real_pty(wheels):
    with (
        VirtualMCU(wheels, clock=wheels.clock) as mcu,
        OdometryGrabber(mcu.path, geometry=GEOMETRY, max_wheel_speed=MAX_WHEEL_SPEED) as grabber,
    ):
        assert mcu.path.startswith("/dev/")
        assert grabber.wait_connected(WAIT)
        assert grabber.odometry.wait_newer(0, WAIT) is not None
        v, w = 0.25, 0.9
        odo = drive(grabber, wheels, v, w, seconds=1.2)
        (v_wire, w_wire) = wheels.commands[0]
        assert_pose_close(odo.pose, analytic_arc(v_wire, w_wire, wheels.moving_time))
        assert abs(odo.pose[2]) > 1.0  # it really turned
        stats = grabber.stats()
    assert stats.frames_ok >= 60 and stats.commands_sent == 2
    assert stats.odometry_jumps_rejected == stats.odometry_time_gaps == 0
    assert sum(stats.rejected.values()) == 0 and stats.bytes_skipped == 0
    assert mcu.stats.commands_applied == 2


def test_random_bytes_and_bit_errors_on_the_line_are_skipped_without_a_jump(wheels):
    rng = np.random.default_rng(20261122)
    faults = LineFaults(np.random.default_rng(4), drop_rate=0.005, flip_rate=0.01, garbage_rate=0.3)
    samples = []
    done = threading.Event()
    with (
        VirtualMCU(wheels, clock=wheels.clock, faults=faults) as mcu,
        OdometryGrabber(mcu.path, geometry=GEOMETRY, max_wheel_speed=MAX_WHEEL_SPEED) as grabber,
    ):

        def collect():
            seq = 0
            while not done.is_set():
                got = grabber.odometry.wait_newer(seq, 0.05)
                if got:
                    seq, odo = got
                    samples.append(odo)

        def spray():
            while not done.is_set():
                mcu.inject(rng.bytes(int(rng.integers(1, 48))))
                time.sleep(0.004)

        threads = [threading.Thread(target=collect), threading.Thread(target=spray)]
        assert grabber.wait_connected(WAIT)
        assert grabber.odometry.wait_newer(0, WAIT) is not None
        for t in threads:
            t.start()
        try:
            odo = drive(grabber, wheels, 0.3, -0.7, seconds=1.5)
        finally:
            done.set()
            for t in threads:
                t.join()
        stats = grabber.stats()
    # Lost frames lose no motion (the counts are cumulative): the end pose is still the exact arc.
    v_wire, w_wire = wheels.commands[0]
    assert_pose_close(odo.pose, analytic_arc(v_wire, w_wire, wheels.moving_time))
    assert stats.bytes_skipped > 1000
    assert sum(stats.rejected.values()) >= 3
    assert stats.frames_ok > 40
    # No jump: between any two published readings the robot moved no faster than its wheels can.
    slack = 3 * GEOMETRY.metres_per_tick
    for a, b in itertools.pairwise(samples):
        assert np.hypot(*(b.pose[:2] - a.pose[:2])) <= MAX_WHEEL_SPEED * (b.mcu_time - a.mcu_time) + slack
    assert len(samples) > 20


def test_grabber_reconnects_when_the_device_vanishes_and_odometry_continues(wheels, tmp_path):
    link = tmp_path / "ttyROBOT"
    mcu = VirtualMCU(wheels, clock=wheels.clock, link=link).start()
    grabber = OdometryGrabber(str(link), geometry=GEOMETRY, reconnect_delay=0.02).start()
    try:
        assert grabber.wait_connected(WAIT)
        assert grabber.odometry.wait_newer(0, WAIT) is not None
        first = drive(grabber, wheels, 0.2, 0.0, seconds=0.5)
        assert_pose_close(first.pose, analytic_arc(0.2, 0.0, wheels.moving_time))

        mcu.stop()  # the device disappears (cable pulled / MCU reset)
        wait_until(lambda: grabber.stats().disconnects == 1, "the grabber to notice the lost device")
        assert not grabber.send_velocity(0.1, 0.0)  # nothing to send to: refused, counted

        # The MCU clock restarts from zero, still on the wheels' simulated time (the host's clock
        # would let a loaded machine deliver two 4 mm frames 1 ms apart: a jump, rightly dropped).
        booted = wheels.time
        mcu = VirtualMCU(wheels, clock=lambda: wheels.time - booted, link=link).start()
        wait_until(lambda: grabber.stats().connects == 2, "the reconnect")
        # The restarted MCU's first frame is a new baseline (its counts cannot be trusted to
        # continue the old ones); wait for odometry from the new stream before moving.
        assert grabber.odometry.wait_newer(grabber.odometry.get()[0], WAIT) is not None
        second = drive(grabber, wheels, 0.2, 0.0, seconds=0.5)
        stats = grabber.stats()
    finally:
        grabber.stop()
        mcu.stop()
    assert_pose_close(second.pose, analytic_arc(0.2, 0.0, wheels.moving_time))
    assert second.pose[0] > first.pose[0] + 0.05
    assert stats.odometry_time_gaps == 1  # the restarted clock broke the chain: re-baselined
    assert stats.commands_failed == 1
    assert stats.odometry_jumps_rejected == 0


def test_mcu_watchdog_stops_the_wheels_without_commands(wheels):
    with (
        VirtualMCU(wheels, clock=wheels.clock, command_timeout=0.1) as mcu,
        OdometryGrabber(mcu.path) as grabber,
    ):
        assert grabber.wait_connected(WAIT)
        assert grabber.send_velocity(0.1, 0.0)
        wait_until(lambda: mcu.stats.watchdog_stops == 1, "the watchdog")
        assert wheels.commands[-1] == (0.0, 0.0)


def test_line_faults_validate_their_rates():
    with pytest.raises(ValueError, match="flip_rate"):
        LineFaults(np.random.default_rng(0), flip_rate=1.5)


def test_path_before_start_is_an_error(wheels):
    with pytest.raises(RuntimeError, match="start"):
        _ = VirtualMCU(wheels).path


def test_grabber_waits_for_a_missing_device_and_refuses_bad_commands(tmp_path):
    with OdometryGrabber(str(tmp_path / "ttyNONE"), reconnect_delay=0.01) as grabber:
        assert not grabber.wait_connected(0.1)
        assert not grabber.send_velocity(0.1, 0.0)
        with pytest.raises(ValueError, match="finite"):
            grabber.send_velocity(float("nan"), 0.0)
        stats = grabber.stats()
    assert (stats.connected, stats.connects, stats.commands_failed) == (False, 0, 1)
    assert grabber.odometry.get() == (0, None)


class PickyWheels(ArcWheels):
    """A wheel source that refuses fast commands and fails its first tick readings."""

    failures = 3

    def ticks(self) -> tuple[int, int]:
        if self.failures:
            self.failures -= 1
            raise RuntimeError("encoder bus glitch")
        return super().ticks()

    def set_velocity(self, v: float, w: float) -> None:
        if abs(v) > 1.0:
            raise ValueError(f"v={v} too fast")
        super().set_velocity(v, w)


def test_a_refused_command_does_not_kill_the_mcu():
    wheels = PickyWheels()
    with VirtualMCU(wheels, clock=wheels.clock) as mcu, OdometryGrabber(mcu.path) as grabber:
        assert grabber.wait_connected(WAIT)
        assert grabber.send_velocity(5.0, 0.0)
        wait_until(lambda: mcu.stats.commands_refused == 1, "the refusal")
        assert grabber.send_velocity(0.5, 0.0)
        wait_until(lambda: wheels.commands == [(0.5, 0.0)], "the next command")
        seq = grabber.odometry.get()[0]
        assert grabber.odometry.wait_newer(seq, WAIT) is not None  # still sending frames
    assert mcu.stats.tick_errors == 3


def _hold_the_interpreter(stop: threading.Event, seconds: float, threads: int = 2) -> list[threading.Thread]:
    """Threads that take turns holding the GIL in single C calls of at least ``seconds`` each until
    ``stop`` (two of them: one is always waiting to take it when another thread lets it go)."""
    n = 1_000_000
    while True:
        t = time.perf_counter()
        sum(range(n))
        if time.perf_counter() - t >= seconds:
            break
        n = int(1.3 * n)

    def hold(holding: threading.Event):
        holding.set()
        while not stop.is_set():
            sum(range(n))

    started = []
    for _ in range(threads):
        holding = threading.Event()
        started.append(threading.Thread(target=hold, args=(holding,), daemon=True))
        started[-1].start()
        holding.wait()
    return started


def test_commands_sent_while_other_threads_hold_the_interpreter_are_not_counted_failed(wheels):
    # The sending thread lets the GIL go in its write and may get it back only after another
    # thread's long call; the bytes went out all the same (pyserial's own write timeout counted
    # such a command failed: 5-8 of 16 here).
    sent = [(0.01 * k, -0.02 * k) for k in range(1, 13)]
    with (
        VirtualMCU(wheels, clock=wheels.clock) as mcu,
        OdometryGrabber(mcu.path, geometry=GEOMETRY, max_wheel_speed=MAX_WHEEL_SPEED) as grabber,
    ):
        assert grabber.wait_connected(WAIT)
        stop = threading.Event()
        hogs = _hold_the_interpreter(stop, 1.2 * WRITE_TIMEOUT)
        try:
            taken = [time.sleep(0.01) or grabber.send_velocity(v, w) for v, w in sent]  # as the link's thread
        finally:
            stop.set()
            for hog in hogs:
                hog.join()
        wait_until(lambda: len(wheels.commands) == len(sent), "every command to reach the wheels")
        stats = grabber.stats()
    assert taken == [True] * len(sent)
    assert (stats.commands_sent, stats.commands_failed) == (len(sent), 0)
    assert np.array(wheels.commands) == pytest.approx(np.array(sent), rel=1e-6)  # float32 on the wire
    assert mcu.stats.commands_applied == len(sent)


def test_a_port_that_takes_no_more_bytes_times_out_within_the_limit():
    controller, device = os.openpty()  # nobody reads the controller side: its buffer fills
    port = serial.Serial(os.ttyname(device), DEFAULT_BAUDRATE)
    try:
        chunk = bytes(range(256)) * 16
        t = time.monotonic()
        with pytest.raises(serial.SerialTimeoutException, match="bytes not taken"):
            for _ in range(100_000):  # a pty buffers some kilobytes at most
                t = time.monotonic()
                write_within(port, chunk, WRITE_TIMEOUT)
        assert WRITE_TIMEOUT <= time.monotonic() - t < WRITE_TIMEOUT + 2.0
    finally:
        port.close()
        os.close(controller)
        os.close(device)
