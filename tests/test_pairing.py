"""StampedPairing: each scan once, in order, with the odometry at its own stamp."""

from dataclasses import dataclass

import numpy as np

from app.grabbers.odometry_history import OdometryHistory
from app.grabbers.shared import Backlog
from app.worker.pairing import StampedPairing
from slam_core.scan import Scan


@dataclass(frozen=True)
class Reading:
    pose: np.ndarray
    stamp: float


def scan_at(stamp: float) -> Scan:
    return Scan(np.zeros(3), np.ones(3), 0.1, 5.0, stamp)


def test_a_scan_takes_the_odometry_interpolated_at_its_stamp_and_is_stepped_once():
    history, scans = OdometryHistory(), Backlog(8)
    pairing = StampedPairing(history, scans)
    history.put(Reading(np.array([0.0, 0.0, 0.0]), 10.0))
    history.put(Reading(np.array([1.0, 0.0, 0.0]), 10.1))
    history.put(Reading(np.array([2.0, 0.0, 0.0]), 10.2))  # newer odometry must not be taken
    scans.put(scan_at(10.05))
    pair = pairing.next(0.01)
    assert pair.scan_seq == 1 and np.allclose(pair.odometry.pose, [0.5, 0.0, 0.0])
    assert pairing.next(0.01) is None  # nothing new: never the same scan twice


def test_a_scan_ahead_of_the_odometry_waits_for_the_reading_after_it():
    history, scans = OdometryHistory(), Backlog(8)
    pairing = StampedPairing(history, scans, wait_s=10.0)
    history.put(Reading(np.array([0.0, 0.0, 0.0]), 1.0))
    scans.put(scan_at(1.5))
    assert pairing.next(0.01) is None and pairing.last_scan == 0  # still waiting
    history.put(Reading(np.array([1.0, 0.0, 0.0]), 2.0))
    assert np.allclose(pairing.next(0.01).odometry.pose, [0.5, 0.0, 0.0])


def test_past_the_wait_the_newest_odometry_is_held():
    history, scans = OdometryHistory(), Backlog(8)
    pairing = StampedPairing(history, scans, wait_s=0.0)
    history.put(Reading(np.array([3.0, 0.0, 0.0]), 1.0))
    scans.put(scan_at(1.5))
    assert np.allclose(pairing.next(0.01).odometry.pose, [3.0, 0.0, 0.0])


def test_a_scan_before_any_odometry_is_dropped():
    history, scans = OdometryHistory(), Backlog(8)
    pairing = StampedPairing(history, scans, wait_s=0.0)
    scans.put(scan_at(1.0))
    assert pairing.next(0.01) is None and pairing.last_scan == 1


def test_a_burst_of_scans_is_stepped_in_order_each_with_its_own_odometry():
    history, scans = OdometryHistory(), Backlog(8)
    pairing = StampedPairing(history, scans, wait_s=0.0)
    for k in range(5):  # a log's burst: five records within microseconds
        history.put(Reading(np.array([float(k), 0.0, 0.0]), 1.0 + k * 1e-6))
        scans.put(scan_at(1.0 + k * 1e-6))
    pairs = [pairing.next(0.01) for _ in range(5)]
    assert [p.scan_seq for p in pairs] == [1, 2, 3, 4, 5]
    assert np.allclose([p.odometry.pose[0] for p in pairs], [0, 1, 2, 3, 4])
    assert pairing.next(0.01) is None


def test_a_worker_far_behind_skips_to_the_scans_within_its_lag():
    history, scans = OdometryHistory(), Backlog(8)
    pairing = StampedPairing(history, scans, wait_s=0.0, max_lag_s=0.25)
    for k in range(6):  # 0.1 s apart; the worker was busy for all of them
        history.put(Reading(np.array([float(k), 0.0, 0.0]), 1.0 + 0.1 * k))
        scans.put(scan_at(1.0 + 0.1 * k))
    assert [pairing.next(0.01).scan_seq for _ in range(3)] == [4, 5, 6]  # within 0.25 s of the newest
    assert pairing.next(0.01) is None
