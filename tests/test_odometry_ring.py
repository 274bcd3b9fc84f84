"""The odometry ring: what the robot link writes, the worker reads, in order, across processes."""

from __future__ import annotations

import multiprocessing as mp
import time

import numpy as np

from app.grabbers.odometry_history import OdometryHistory
from app.grabbers.ring_odometry_grabber import RingOdometryGrabber
from app.robot.odometry_ring import SLOTS, OdometryRing, RingOdometry


def reading(i: int, ticks: bool = True) -> RingOdometry:
    return RingOdometry(np.array([0.01 * i, -0.02 * i, 0.001 * i]), 1000.0 + 0.02 * i,
                        (3 * i, 5 * i) if ticks else None)


def _write_readings(ring: OdometryRing, n: int) -> None:
    for i in range(1, n + 1):
        ring.put(reading(i))
        time.sleep(0.002)


def test_readings_come_back_in_order_with_their_stamps_poses_and_ticks():
    ring = OdometryRing.create()
    assert ring.newest() is None and ring.read_since(0) == (0, [])
    for i in range(1, 11):
        ring.put(reading(i, ticks=i % 2 == 0))
    count, got = ring.read_since(0)
    assert count == 10 and len(got) == 10
    for i, r in enumerate(got, start=1):
        assert r.stamp == reading(i).stamp and np.array_equal(r.pose, reading(i).pose)
        assert r.ticks == ((3 * i, 5 * i) if i % 2 == 0 else None)
    assert [r.stamp for r in ring.read_since(7)[1]] == [reading(i).stamp for i in (8, 9, 10)]
    assert ring.newest().stamp == reading(10).stamp


def test_a_reader_that_fell_behind_gets_the_newest_slots_only():
    ring = OdometryRing.create()
    for i in range(1, SLOTS + 51):
        ring.put(reading(i))
    count, got = ring.read_since(3)
    assert count == SLOTS + 50 and len(got) == SLOTS
    assert got[0].stamp == reading(51).stamp and got[-1].stamp == reading(SLOTS + 50).stamp


def test_a_writer_in_another_process_reaches_the_worker_history_in_order():
    ctx = mp.get_context("spawn")
    ring = OdometryRing.create(ctx)
    history = OdometryHistory(length=1000)
    grabber = RingOdometryGrabber(ring, history).start()
    n = 600
    writer = ctx.Process(target=_write_readings, args=(ring, n))
    writer.start()
    writer.join(60)
    deadline = time.monotonic() + 5
    while not history.covers(reading(n).stamp) and time.monotonic() < deadline:
        time.sleep(0.01)
    grabber.stop()
    assert writer.exitcode == 0
    last = history.at(reading(n).stamp)
    assert np.allclose(last.pose, reading(n).pose) and last.ticks == reading(n).ticks
    middle = history.at(reading(n // 2).stamp)  # an exact stamp: that reading, not an interpolation
    assert np.allclose(middle.pose, reading(n // 2).pose)
