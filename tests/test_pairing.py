"""StampedPairing: each scan once, with the odometry at its own stamp."""

from dataclasses import dataclass

import numpy as np

from app.grabbers.odometry_history import OdometryHistory
from app.grabbers.shared import Latest
from app.worker.pairing import StampedPairing
from slam_core.scan import Scan


@dataclass(frozen=True)
class Reading:
    pose: np.ndarray
    stamp: float


def scan_at(stamp: float) -> Scan:
    return Scan(np.zeros(3), np.ones(3), 0.1, 5.0, stamp)


def test_a_scan_takes_the_odometry_interpolated_at_its_stamp_and_is_stepped_once():
    history, scans = OdometryHistory(), Latest()
    pairing = StampedPairing(history, scans)
    history.put(Reading(np.array([0.0, 0.0, 0.0]), 10.0))
    history.put(Reading(np.array([1.0, 0.0, 0.0]), 10.1))
    history.put(Reading(np.array([2.0, 0.0, 0.0]), 10.2))  # newer odometry must not be taken
    scans.put(scan_at(10.05))
    pair = pairing.next(0.01)
    assert pair.scan_seq == 1 and np.allclose(pair.odometry.pose, [0.5, 0.0, 0.0])
    assert pairing.next(0.01) is None  # nothing new: never the same scan twice


def test_a_scan_ahead_of_the_odometry_waits_for_the_reading_after_it():
    history, scans = OdometryHistory(), Latest()
    pairing = StampedPairing(history, scans, wait_s=10.0)
    history.put(Reading(np.array([0.0, 0.0, 0.0]), 1.0))
    scans.put(scan_at(1.5))
    assert pairing.next(0.01) is None and pairing.last_scan == 0  # still waiting
    history.put(Reading(np.array([1.0, 0.0, 0.0]), 2.0))
    assert np.allclose(pairing.next(0.01).odometry.pose, [0.5, 0.0, 0.0])


def test_past_the_wait_the_newest_odometry_is_held():
    history, scans = OdometryHistory(), Latest()
    pairing = StampedPairing(history, scans, wait_s=0.0)
    history.put(Reading(np.array([3.0, 0.0, 0.0]), 1.0))
    scans.put(scan_at(1.5))
    assert np.allclose(pairing.next(0.01).odometry.pose, [3.0, 0.0, 0.0])


def test_a_scan_before_any_odometry_is_dropped():
    history, scans = OdometryHistory(), Latest()
    pairing = StampedPairing(history, scans, wait_s=0.0)
    scans.put(scan_at(1.0))
    assert pairing.next(0.01) is None and pairing.last_scan == 1
